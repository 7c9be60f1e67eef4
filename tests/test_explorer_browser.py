"""The sky explorer end to end in headless Chromium (Debian's chromium, driven by Playwright).

Load the page; move the elevation slider (a new image and new irradiance readouts); move the exposure (the page
re-maps the image it has, with no request, to the server's PNG within one 8-bit level) and the tilted plane (only
the irradiance is asked for); click a direction (its spectrum appears and matches the evaluator); the charts'
ticks are 1, 2 or 5 x 10^k; zoom to 16x and pan by dragging, zoom with the wheel; the help panel; open a dataset
at run time from the allowed folder and put the sun at -2 deg; pin a state for comparison; save a PNG under a
chosen name at 2048 pixels (and refuse a name with a folder); a page of another origin cannot make it write or
read it; check that the page made no request to another origin and raised no error. Skips cleanly when
Playwright or a Chromium executable is missing (``.ci/run`` installs both).
"""

import io
import json
import math
import os
import shutil
import threading

import pytest

playwright = pytest.importorskip("playwright.sync_api")

CHROMIUM = os.environ.get("WIDESKY_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable (set WIDESKY_CHROMIUM)")]


@pytest.fixture(scope="module")
def page_url(tmp_path_factory):
    from widesky.explorer import Explorer, make_server
    from widesky.skymodel.synthetic import write_synthetic_dataset

    out = tmp_path_factory.mktemp("explorer-browser")
    dsdir = tmp_path_factory.mktemp("explorer-datasets")
    write_synthetic_dataset(dsdir / "twilight.dat", n_channels=12, channel_start=360.0, channel_width=40.0,
                            visibilities=(20.0, 131.8), albedos=(0.0, 1.0))
    srv = make_server(Explorer(output_dir=out, threads=1, dataset_dirs=[dsdir]), port=0)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{srv.server_address[1]}/", out
    srv.shutdown()
    srv.server_close()


def _other_origin_folder(out):
    """A folder beside the explorer's output folder for the other origin's page."""
    d = out.parent / "other-origin"
    d.mkdir(exist_ok=True)
    return d


def _other_origin_page(folder):
    """Serve a blank page from another origin (another port of 127.0.0.1); returns its URL."""
    from functools import partial
    from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

    (folder / "index.html").write_text("<!DOCTYPE html><title>another site</title><p>hello</p>")
    handler = partial(SimpleHTTPRequestHandler, directory=str(folder))
    srv = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    return f"http://127.0.0.1:{srv.server_address[1]}/index.html"


def _input(page, selector, value):
    page.eval_on_selector(selector, "(el, v) => { el.value = v; el.dispatchEvent(new Event('input', {bubbles: true})); }",
                          str(value))


def _shown(page, needle):
    """Wait until image A of a state containing ``needle`` (e.g. 'elevation=8') is drawn."""
    page.wait_for_function("n => { const s = window.wideskyShown.A; return !!s && ('&' + s.state + '&').includes('&' + n + '&'); }",
                           arg=needle, timeout=30000)


def _canvas_rgb(page, side="A"):
    import numpy as np

    data = page.evaluate(f"(() => {{ const c = document.getElementById('view{side}'); "
                         "return [c.width, Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data)]; })()")
    n, px = data
    return np.array(px, np.uint8).reshape(n, n, 4)[..., :3]


def _is_nice(ticks):
    """Evenly spaced ticks whose step is 1, 2 or 5 x 10^k, each a whole multiple of it."""
    if len(ticks) < 2:
        return False
    step = ticks[1] - ticks[0]
    mant = step / 10 ** math.floor(math.log10(step))
    return (any(abs(mant - m) < 1e-6 for m in (1, 2, 5, 10))
            and all(abs(t / step - round(t / step)) < 1e-6 for t in ticks)
            and all(abs((b - a) - step) < 1e-9 * max(1.0, abs(b)) for a, b in zip(ticks, ticks[1:])))


def test_explorer_in_a_browser(page_url):
    import numpy as np
    from PIL import Image

    from widesky import skymodel

    url, out = page_url
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        # under its own Content-Security-Policy the page loads, renders and reports no violation
        strict = browser.new_page()
        console = []
        strict.on("console", lambda msg: console.append(msg.text))
        strict.goto(url)
        strict.locator("#timeA").filter(has_text="render").wait_for(timeout=30000)
        assert not [c for c in console if "Content Security Policy" in c], console
        strict.close()
        # the test's own probes run as evaluated strings, which the page's CSP (script-src 'self') forbids
        page = browser.new_page(viewport={"width": 1400, "height": 1100}, bypass_csp=True)
        requests, errors = [], []
        page.on("request", lambda r: requests.append(r.url))
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        _shown(page, "elevation=30")
        page.wait_for_function("document.querySelector('#readout tbody').rows.length > 0 && "
                               "document.querySelector('#readout tbody').rows[0].cells[1].textContent !== ''",
                               timeout=30000)
        ghi0 = page.evaluate("document.querySelector('#readout tbody').rows[0].cells[1].textContent")
        assert "render" in page.inner_text("#timeA")

        # move the elevation slider: a new image and new irradiance readouts
        _input(page, "input[name=elevation]", 8)
        _shown(page, "elevation=8")
        page.wait_for_function(f"document.querySelector('#readout tbody').rows[0].cells[1].textContent !== {ghi0!r}",
                               timeout=30000)
        ghi1 = float(page.evaluate("document.querySelector('#readout tbody').rows[0].cells[1].textContent"))
        assert ghi1 < float(ghi0)                      # a lower sun gives less global horizontal irradiance
        # the page's image is the server's PNG of that state (within one 8-bit level: the sRGB table is
        # computed in the browser)
        state = page.evaluate("window.wideskyShown.A.state").split("&exposure=")[0].replace("format=raw", "format=png")
        ref = np.asarray(Image.open(io.BytesIO(page.request.get(url + "api/render?" + state).body())).convert("RGB"))
        diff = np.abs(_canvas_rgb(page).astype(int) - ref)
        assert diff.max() <= 1 and (diff > 0).mean() < 0.02

        # exposure: re-mapped in the page, no request; the exposure range reaches +-20 EV
        n_render = sum("/api/render" in r for r in requests)
        assert page.get_attribute("input[name=exposure]", "max") == "20"
        _input(page, "input[name=exposure]", 3)
        _shown(page, "exposure=3")
        ref3 = np.asarray(Image.open(io.BytesIO(page.request.get(url + "api/render?" + state + "&exposure=3").body()))
                          .convert("RGB"))
        assert np.abs(_canvas_rgb(page).astype(int) - ref3).max() <= 1 and not np.array_equal(ref3, ref)
        assert sum("/api/render" in r for r in requests) == n_render      # (page.request does not count)
        _input(page, "input[name=exposure]", 0)

        # the tilted plane: a new readout, no new image
        n_render = sum("/api/render" in r for r in requests)
        tilted0 = page.evaluate("document.querySelector('#readout tbody').rows[0].cells[2].textContent")
        _input(page, "input[name=surface_tilt]", 80)
        page.wait_for_function(f"document.querySelector('#readout tbody').rows[0].cells[2].textContent !== {tilted0!r}",
                               timeout=30000)
        assert sum("/api/render" in r for r in requests) == n_render

        # click the image centre: the zenith's spectrum, equal to the evaluator's
        box = page.locator("#viewA").bounding_box()
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.wait_for_function("document.getElementById('dirinfo').textContent.includes('zenith')", timeout=30000)
        zen = float(page.evaluate("document.getElementById('dirinfo').textContent.match(/zenith ([0-9.]+)/)[1]"))
        assert zen < 1.0
        spec = page.evaluate("fetch('/api/spectrum?' + new URLSearchParams({elevation: 8, u: 0.5, v: 0.5})"
                             ".toString()).then(r => r.json())")
        m = skymodel.load_dataset()
        ref_s = skymodel.sky_radiance(m, skymodel.directions_from_angles([spec["zenith_deg"]], [spec["azimuth_deg"]]),
                                      8, 180, 50, 0.2)[0]
        np.testing.assert_allclose(spec["sky_radiance"], ref_s, rtol=1e-6)
        page.wait_for_function("document.getElementById('spectrum').dataset.yticks.length > 2", timeout=30000)

        # the charts' ticks: 1, 2 or 5 x 10^k (never 0.0638, 0.0851), on both charts, linear and log
        for canvas in ("spectrum", "irrplot"):
            for axis in ("xticks", "yticks"):
                ticks = json.loads(page.get_attribute(f"#{canvas}", f"data-{axis}"))
                assert _is_nice(ticks), (canvas, axis, ticks)
        assert page.evaluate("niceTicks(0.0425, 0.2127, 5).ticks") == [0.0, 0.05, 0.1, 0.15, 0.2, 0.25]
        page.check("#logy")
        logt = json.loads(page.get_attribute("#spectrum", "data-yticks"))
        assert all(abs(math.log10(t) - round(math.log10(t))) < 1e-9 or str(t)[0] in "25" for t in logt), logt

        # zoom to 16x about the centre and pan by dragging; a click then still picks the direction under it
        _input(page, "#zoom", 4)
        assert page.evaluate("document.getElementById('viewA').getBoundingClientRect().width") == pytest.approx(8192)
        assert page.inner_text("#zoomout") == "16x"
        frame = page.locator("#frameA").bounding_box()
        s0 = page.evaluate("[document.getElementById('frameA').scrollLeft, document.getElementById('frameA').scrollTop]")
        assert s0[0] == pytest.approx(8192 / 2 - 256, abs=2)                  # zoomed about the centre
        cx, cy = frame["x"] + 256, frame["y"] + 256
        page.mouse.move(cx, cy)
        page.mouse.down()
        page.mouse.move(cx - 100, cy - 60, steps=5)
        page.mouse.up()
        s1 = page.evaluate("[document.getElementById('frameA').scrollLeft, document.getElementById('frameA').scrollTop]")
        assert s1[0] == pytest.approx(s0[0] + 100, abs=2) and s1[1] == pytest.approx(s0[1] + 60, abs=2)
        page.mouse.click(cx, cy)
        page.wait_for_function("document.getElementById('dirinfo').textContent.includes('zenith')", timeout=30000)
        u_expected = (s1[0] + 256) / 8192
        pick = page.evaluate("pick")
        assert pick["u"] == pytest.approx(u_expected, abs=1e-3)
        # the wheel zooms (about the cursor); 0 resets
        page.mouse.move(cx, cy)
        page.mouse.wheel(0, -100)
        page.wait_for_function("parseFloat(document.getElementById('zoom').value) > 4", timeout=5000)
        page.keyboard.press("0")
        assert page.evaluate("document.getElementById('viewA').getBoundingClientRect().width") == pytest.approx(512)

        # the help panel
        assert page.is_hidden("#help")
        page.click("#helpbtn")
        assert page.is_visible("#help") and "Zoom and pan" in page.inner_text("#help")
        page.keyboard.press("h")
        assert page.is_hidden("#help")

        # open a dataset at run time from the allowed folder; its twilight elevations become reachable
        page.wait_for_function("document.getElementById('available').options.length === 1", timeout=30000)
        assert not page.is_hidden("#loader")
        page.click("#loadds")
        page.wait_for_function("document.getElementById('dataset').options.length === 2", timeout=30000)
        assert page.evaluate("document.getElementById('dataset').value") == "1"
        assert float(page.get_attribute("input[name=elevation]", "min")) < 0
        _input(page, "input[name=elevation]", -2)
        _shown(page, "elevation=-2")
        assert "dataset=1" in page.evaluate("window.wideskyShown.A.state")
        assert _canvas_rgb(page).max() > 0
        _input(page, "#dataset", 0)
        _input(page, "input[name=elevation]", 20)
        _shown(page, "elevation=20")

        # pin as B, then save a PNG under a chosen name at 2048 pixels
        page.click("#pin")
        page.wait_for_function("!!window.wideskyShown.B", timeout=30000)
        page.fill("#savename", "from-browser")
        page.fill("#saveres", "2048")
        page.click("#savepng")
        page.wait_for_function("document.getElementById('saved').textContent.includes('from-browser.png')",
                               timeout=60000)
        with Image.open(out / "from-browser.png") as im:
            assert im.size == (2048, 2048)
        # a name with a folder is refused in the page (and by the server), nothing written
        page.fill("#savename", "../escape")
        page.click("#savepng")
        page.wait_for_function("document.getElementById('status').className === 'error'", timeout=30000)
        assert not (out.parent / "escape.png").exists() and not list(out.parent.glob("**/escape*"))

        # another web page (another local origin) cannot make the explorer write, with or without a token
        # header (a custom header needs a CORS preflight, which the explorer does not grant), nor read it
        evil_url = _other_origin_page(_other_origin_folder(out))
        evil = browser.new_page()
        evil.goto(evil_url)
        codes = evil.evaluate("""async (target) => {
          const out = [];
          for (const opts of [{method: 'POST', mode: 'no-cors'},
                              {method: 'POST', headers: {'X-Widesky-Token': 'guess'}},
                              {method: 'GET'}]) {
            try { const r = await fetch(target + (opts.method === 'GET' ? 'api/info' : 'api/save?name=csrf&format=png&resolution=32'), opts);
                  out.push(r.type === 'opaque' ? 'opaque' : r.status); }
            catch (e) { out.push('blocked'); }
          }
          return out;
        }""", url)
        assert codes[1] == "blocked" and codes[2] == "blocked", codes        # preflight refused; no CORS read
        assert not list(out.glob("csrf*")), list(out.iterdir())               # the no-cors POST wrote nothing
        evil.close()
        browser.close()
    assert not errors, errors
    assert requests and all(r.startswith(url) or r.startswith("blob:") for r in requests), \
        [r for r in requests if not r.startswith(url)]
