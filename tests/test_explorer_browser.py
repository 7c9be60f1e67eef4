"""The sky explorer end to end in headless Chromium (Debian's chromium, driven by Playwright).

Load the page, move a slider (the image and the irradiance spectrum change), click a direction (its
spectrum appears and matches the evaluator), pin a state for comparison, save a PNG (the file appears in
the output folder), and check that the page made no request to another origin. Skips cleanly when
Playwright or a Chromium executable is missing (``.ci/run`` installs both).
"""

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

    out = tmp_path_factory.mktemp("explorer-browser")
    srv = make_server(Explorer(output_dir=out, threads=1), port=0)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{srv.server_address[1]}/", out
    srv.shutdown()
    srv.server_close()


def test_explorer_in_a_browser(page_url):
    import numpy as np

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
        page.wait_for_function("document.getElementById('imgA').naturalWidth === 512", timeout=30000)
        page.wait_for_function("document.querySelector('#readout tbody').rows.length > 0", timeout=30000)
        first = page.evaluate("document.getElementById('imgA').src")
        ghi0 = page.evaluate("document.querySelector('#readout tbody').rows[0].cells[1].textContent")
        assert "render" in page.inner_text("#timeA")

        # move the elevation slider: a new image and new irradiance readouts
        page.eval_on_selector("input[name=elevation]",
                              "el => { el.value = 8; el.dispatchEvent(new Event('input', {bubbles: true})); }")
        page.wait_for_function(f"document.getElementById('imgA').src !== {first!r} && "
                               "document.getElementById('imgA').dataset.state.includes('elevation=8')", timeout=30000)
        page.wait_for_function(f"document.querySelector('#readout tbody').rows[0].cells[1].textContent !== {ghi0!r}",
                               timeout=30000)
        ghi1 = float(page.evaluate("document.querySelector('#readout tbody').rows[0].cells[1].textContent"))
        assert ghi1 < float(ghi0)                      # a lower sun gives less global horizontal irradiance

        # click the image centre: the zenith's spectrum, equal to the evaluator's
        box = page.locator("#imgA").bounding_box()
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.wait_for_function("document.getElementById('dirinfo').textContent.includes('zenith')", timeout=30000)
        zen = float(page.evaluate("document.getElementById('dirinfo').textContent.match(/zenith ([0-9.]+)/)[1]"))
        assert zen < 1.0
        spec = page.evaluate("fetch('/api/spectrum?' + new URLSearchParams({elevation: 8, u: 0.5, v: 0.5})"
                             ".toString()).then(r => r.json())")
        m = skymodel.load_dataset()
        ref = skymodel.sky_radiance(m, skymodel.directions_from_angles([spec["zenith_deg"]], [spec["azimuth_deg"]]),
                                    8, 180, 50, 0.2)[0]
        np.testing.assert_allclose(spec["sky_radiance"], ref, rtol=1e-6)
        # the spectrum canvas was drawn (not blank)
        drawn = page.evaluate("(() => { const c = document.getElementById('spectrum'); const d = c.getContext('2d')"
                              ".getImageData(0, 0, c.width, c.height).data; let n = 0;"
                              " for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n; })()")
        assert drawn > 1000

        # pin as B, then save a PNG
        page.click("#pin")
        page.wait_for_function("document.getElementById('imgB').naturalWidth === 512", timeout=30000)
        page.fill("#savename", "from-browser")
        page.click("#savepng")
        page.wait_for_function("document.getElementById('saved').textContent.includes('from-browser.png')",
                               timeout=30000)
        assert (out / "from-browser.png").is_file()
        browser.close()
    assert not errors, errors
    assert requests and all(r.startswith(url) or r.startswith("blob:") for r in requests), \
        [r for r in requests if not r.startswith(url)]
