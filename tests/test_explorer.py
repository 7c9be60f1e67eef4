"""The sky explorer's HTTP API (skymodel.explorer), driven over a real socket on 127.0.0.1.

References: the images and spectra must equal the library's own renderer and evaluator (exact); the
horizontal irradiance must match an independent brute-force hemisphere integral of the sky model's
radiance (0.25 deg x 0.5 deg midpoint grid, converged: halving the steps changes it by < 1e-5) within
0.5 % global and 1 % diffuse (measured: 0.27 % / 0.6 % at 10 deg sun, less higher up).
"""

import http.client
import io
import json
import re
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from widesky import skymodel
import widesky.explorer
from widesky.explorer import Explorer, make_server
from widesky.skymodel.render import _display, render_sky

STATIC = Path(widesky.explorer.__file__).parent / "static"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    out = tmp_path_factory.mktemp("explorer-out")
    ex = Explorer(output_dir=out, threads=1)
    srv = make_server(ex, port=0)
    th = threading.Thread(target=srv.serve_forever, daemon=True)
    th.start()
    yield srv, out
    srv.shutdown()
    srv.server_close()


def page_token(srv):
    """The session token, read from the page as the page's script does."""
    port = srv.server_address[1]
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    c.request("GET", "/", headers={"Host": f"127.0.0.1:{port}"})
    html = c.getresponse().read().decode()
    c.close()
    return re.search(r'<meta name="widesky-token" content="([^"]+)">', html).group(1)


def request(server, path, method="GET", host=None, headers=None, token=True):
    """One request over a socket; POSTs carry the page's token unless ``token`` is False (or a string)."""
    srv = server[0] if isinstance(server, tuple) else server
    port = srv.server_address[1]
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    c.putrequest(method, path, skip_host=True)
    c.putheader("Host", host or f"127.0.0.1:{port}")
    c.putheader("Content-Length", "0")
    if method == "POST" and token:
        c.putheader("X-Widesky-Token", token if isinstance(token, str) else page_token(srv))
    for k, v in (headers or {}).items():
        c.putheader(k, v)
    c.endheaders()
    r = c.getresponse()
    body = r.read()
    c.close()
    return r.status, dict(r.getheaders()), body


def get_json(server, path, method="GET"):
    status, _, body = request(server, path, method)
    return status, json.loads(body)


def png(body):
    return np.asarray(Image.open(io.BytesIO(body)).convert("RGB"))


def test_page_is_self_contained(server):
    status, headers, body = request(server, "/")
    assert status == 200 and headers["Content-Type"].startswith("text/html")
    html = body.decode()
    for ref in ("app.js", "style.css"):
        assert ref in html
        assert request(server, "/" + ref)[0] == 200
    # nothing is fetched from another origin: no absolute URLs in the page, its script or its style
    for f in STATIC.iterdir():
        text = f.read_text()
        assert "http://" not in text and "https://" not in text and "//cdn" not in text, f.name
    assert "default-src 'self'" in headers["Content-Security-Policy"]


def test_info_lists_the_dataset(server):
    status, info = get_json(server, "/api/info")
    assert status == 200
    d = info["datasets"][0]
    m = skymodel.load_dataset()
    assert d["wavelength_nm"] == m.wavelengths.tolist()
    assert d["channels"][0] == "rgb" and len(d["channels"]) == m.n_channels + 1
    assert min(d["visibility_km"]) == pytest.approx(20.0) and max(d["visibility_km"]) == pytest.approx(131.8)
    assert {"broadband", "illuminance"} <= set(info["responses"])


def test_render_equals_the_library_renderer_and_follows_the_sliders(server):
    q = "elevation=25&azimuth=120&visibility=40&albedo=0.3&resolution=128"
    status, headers, body = request(server, "/api/render?" + q)
    assert status == 200 and headers["Content-Type"] == "image/png"
    assert float(headers["X-Render-Seconds"]) > 0
    img = png(body)
    assert img.shape == (128, 128, 3)
    m = skymodel.load_dataset()
    vis = np.nonzero((m.channel_lower + m.channel_width > 380) & (m.channel_lower < 780))[0]
    ref = render_sky(m, sun_elevation=25, sun_azimuth=120, visibility=40, albedo=0.3, resolution=128, channels=vis)
    np.testing.assert_array_equal(img, _display(ref, True, 0.0))
    # a slider move changes the image; the same state gives the same image
    moved = png(request(server, "/api/render?" + q.replace("elevation=25", "elevation=6"))[2])
    assert np.abs(moved.astype(int) - img).mean() > 2.0
    np.testing.assert_array_equal(png(request(server, "/api/render?" + q)[2]), img)
    # one channel is grey; the side view differs from the up view
    grey = png(request(server, "/api/render?" + q + "&channel=540nm")[2])
    assert np.array_equal(grey[..., 0], grey[..., 1]) and grey.max() > 0
    side = png(request(server, "/api/render?" + q + "&view=side")[2])
    assert not np.array_equal(side, img)


@pytest.mark.parametrize("query, words", [
    ("elevation=120", ["elevation=120", "[-90, 90]"]),
    ("elevation=-5", ["elevation=-5", "dataset's range", "[0, 90]"]),
    ("visibility=5", ["visibility=5", "[20, 131.8]"]),
    ("albedo=abc", ["albedo='abc'", "not a number"]),
    ("quantity=radiance", ["quantity='radiance'", "sky, sun", "transmittance"]),
    ("quantity=polarisation", ["quantity='polarisation'"]),      # the embedded dataset has no polarisation
    ("channel=555nm", ["channel='555nm'", "rgb", "540nm"]),
    ("view=down", ["view='down'", "up, side"]),
    ("dataset=3", ["dataset=3", "[0, 0]"]),
    ("resolution=5000", ["resolution=5000 pixels", "[16, 1024]"]),
])
def test_bad_parameters_are_named_with_their_range(server, query, words):
    status, body = get_json(server, "/api/render?" + query)
    assert status == 400
    for w in words:
        assert w in body["error"], body["error"]


def test_spectrum_of_a_clicked_direction(server):
    state = "elevation=35&azimuth=200&visibility=60&albedo=0.2&resolution=256"
    status, s = get_json(server, "/api/spectrum?" + state + "&u=0.5&v=0.5")
    assert status == 200
    m = skymodel.load_dataset()
    zen = skymodel.directions_from_angles([s["zenith_deg"]], [s["azimuth_deg"]])
    ref = skymodel.sky_radiance(m, zen, 35, 200, 60, 0.2)[0]
    np.testing.assert_allclose(s["sky_radiance"], ref, rtol=1e-6)
    assert s["zenith_deg"] < 1.0          # the image centre of the up view (a pixel at 256 px spans ~0.9 deg)
    assert s["gamma_deg"] == pytest.approx(90 - 35, abs=1.0)
    # the sun's pixel (south-south-west, 35 deg up; up view: north at the top, east on the left)
    rho = np.tan(np.radians(90 - 35) / 2)
    a = np.radians(200)
    u, v = 0.5 + 0.5 * (-rho * np.sin(a)), 0.5 - 0.5 * rho * np.cos(a)
    fine = state.replace("resolution=256", "resolution=1024")        # pixels of 0.18 deg there: the disc is 0.27 deg
    status, sun = get_json(server, f"/api/spectrum?{fine}&u={u}&v={v}")
    assert sun["gamma_deg"] < 0.2667
    # inside the disc: sun radiance x the disc's solid angle is the direct normal spectrum (to 0.5 %: the
    # radiance's transmittance is taken along the clicked direction, 0.06 deg from the sun's centre)
    dni = np.ravel(skymodel.solar_direct_normal(m, 35, 200, 60, 0.2))
    np.testing.assert_allclose(np.array(sun["sun_radiance"]) * skymodel.SUN_SOLID_ANGLE, dni, rtol=5e-3)
    assert max(s["sun_radiance"]) == 0.0                                # the zenith is not in the sun
    status, err = get_json(server, f"/api/spectrum?{state}&u=0.01&v=0.01")
    assert status == 400 and "outside the fisheye disc" in err["error"]


def _brute_force_horizontal(m, el, az, vis, alb, n=360):
    zen = (np.arange(n) + 0.5) / n * 90.0
    azi = (np.arange(2 * n) + 0.5) / (2 * n) * 360.0
    Z, A = np.meshgrid(zen, azi, indexing="ij")
    L = skymodel.sky_radiance(m, skymodel.directions_from_angles(Z.ravel(), A.ravel()), el, az, vis, alb)
    dw = np.sin(np.radians(Z.ravel())) * np.radians(90.0 / n) * np.radians(180.0 / n)
    dhi = float((L * (np.cos(np.radians(Z.ravel())) * dw)[:, None]).sum() * m.channel_width)
    dni = float(np.sum(skymodel.solar_direct_normal(m, el, az, vis, alb)) * m.channel_width)
    return dhi, dhi + dni * np.sin(np.radians(el))


@pytest.mark.parametrize("el", [10.0, 45.0])
def test_irradiance_matches_a_brute_force_hemisphere_integral(server, el):
    status, r = get_json(server, f"/api/irradiance?elevation={el}&azimuth=150&visibility=30&albedo=0.5"
                                 "&surface_tilt=0&surface_azimuth=180")
    assert status == 200
    dhi, ghi = _brute_force_horizontal(skymodel.load_dataset(), el, 150, 30, 0.5)
    h = r["horizontal"]
    assert h["integrated"]["broadband"] == pytest.approx(ghi, rel=5e-3)
    assert h["broadband"]["sky_diffuse"] == pytest.approx(dhi, rel=1e-2)
    # a plane at tilt 0 is the horizontal plane
    np.testing.assert_allclose(r["tilted"]["global"], h["global"], rtol=1e-9)
    # illuminance: 683 lm/W x the CIE y-weighted spectrum; daylight efficacy of clear skies ~ 100-120 lm/W
    assert 95 < h["integrated"]["illuminance"] / h["integrated"]["broadband"] < 125


def test_tilted_plane_parts(server):
    status, r = get_json(server, "/api/irradiance?elevation=40&azimuth=180&visibility=50&albedo=0.4"
                                 "&surface_tilt=90&surface_azimuth=0")
    t, h = r["tilted"], r["horizontal"]
    # a north-facing wall with the sun in the south: no beam, ground light = albedo x GHI x (1 - cos 90) / 2
    assert r["aoi_deg"] == pytest.approx(180.0 - 40.0, abs=1e-6)
    assert t["broadband"]["direct"] == 0.0
    np.testing.assert_allclose(t["ground_diffuse"], 0.4 * np.array(h["global"]) / 2, rtol=1e-9)
    status, s = get_json(server, "/api/irradiance?elevation=40&azimuth=180&visibility=50&albedo=0.4"
                                 "&surface_tilt=90&surface_azimuth=180")
    assert s["tilted"]["broadband"]["sky_diffuse"] > t["broadband"]["sky_diffuse"]     # the sunny side's sky is brighter
    assert s["tilted"]["broadband"]["direct"] == pytest.approx(
        r["horizontal"]["broadband"]["direct"] / np.sin(np.radians(40)) * np.cos(np.radians(40)), rel=1e-9)


def test_site_and_time_drive_the_sun(server):
    q = "lat=50.08&lon=14.42&tz=Europe/Prague&time=2024-06-21T13:00"
    status, sun = get_json(server, "/api/sun?" + q)
    import widesky.irradiance as ir
    import pandas as pd
    ref = ir.Site(50.08, 14.42, tz="Europe/Prague").solar_position(
        pd.DatetimeIndex([pd.Timestamp("2024-06-21T13:00")]), label="center", step="1h")
    assert sun["elevation"] == pytest.approx(float(ref["apparent_elevation"].iloc[0]), abs=1e-9)
    assert 60 < sun["elevation"] < 64              # solar noon near midsummer at 50 N: 90 - 50.08 + 23.44
    by_site = request(server, "/api/render?resolution=64&sun=site&" + q)[2]
    by_angles = request(server, f"/api/render?resolution=64&elevation={sun['elevation']!r}"
                                f"&azimuth={sun['azimuth']!r}")[2]
    np.testing.assert_array_equal(png(by_site), png(by_angles))
    status, night = get_json(server, "/api/render?sun=site&lat=50&lon=14&tz=Europe/Prague&time=2024-06-21T01:00")
    assert status == 400 and "time='2024-06-21T01:00'" in night["error"]
    status, bad = get_json(server, "/api/sun?lat=50&lon=14&time=tomorrow")
    assert status == 400 and "time='tomorrow'" in bad["error"]


def test_save_writes_png_and_spectral_exr(server):
    srv, out = server
    status, r = get_json(server, "/api/save?elevation=20&resolution=64&name=dusk-1&format=png,exr", method="POST")
    assert status == 200 and r["written"] == ["dusk-1.png", "dusk-1.exr"]
    assert sorted(p.name for p in out.iterdir()) == ["dusk-1.exr", "dusk-1.png"]     # no temporary files left
    import OpenEXR
    with OpenEXR.File(str(out / "dusk-1.exr")) as f:
        names = set(f.channels())
    assert len([n for n in names if n.startswith("S0.")]) == skymodel.load_dataset().n_channels
    status, headers, body = request(server, "/files/dusk-1.png")
    assert status == 200 and png(body).shape == (64, 64, 3)


@pytest.mark.parametrize("path", ["/files/../server.py", "/files/..%2Fserver.py", "/files/%2e%2e/x",
                                  "/files//etc/passwd", "/static/../server.py", "/../../etc/passwd",
                                  "/server.py", "/files/missing.png"])
def test_paths_outside_the_allowed_folders_are_refused(server, path):
    status, _, body = request(server, path)
    assert status == 404 and b"root:" not in body


def test_save_names_cannot_leave_the_output_folder(server):
    for name in ("../evil", "a/b", "/tmp/x", ".hidden"):
        status, body = get_json(server, f"/api/save?resolution=32&format=png&name={name}", method="POST")
        assert status == 400 and "name=" in body["error"]


@pytest.mark.parametrize("host", ["evil.example:80", "127.0.0.1:1", "localhost", "attacker.com"])
def test_foreign_host_headers_are_refused(server, host):
    status, _, body = request(server, "/api/info", host=host)
    assert status == 403 and b"refused" in body


@pytest.mark.parametrize("args, words", [(["--port", "70000"], "--port 70000"),
                                         (["--dataset-dir", "/nonexistent-folder"], "--dataset-dir /nonexistent-folder"),
                                         (["--save-budget", "-5"], "--save-budget -5")])
def test_cli_errors_are_one_line(args, words):
    p = subprocess.run([sys.executable, "-m", "widesky.cli", "gui", *args, "--no-browser"],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and p.stderr.strip().count("\n") == 0 and words in p.stderr, p.stderr


def test_a_user_response_is_integrated(tmp_path):
    """A glazing-like transmittance file: 0.6 over 400-760 nm, 0 elsewhere; its integral is 0.6 x the
    global irradiance of the channels inside that range (channel edges lie on 400 and 760 nm)."""
    from widesky.explorer.cli import parse_response

    f = tmp_path / "glass.csv"
    f.write_text("wavelength_nm,value\n400,0.6\n760,0.6\n")
    m = skymodel.load_dataset()
    name, (w, unit) = parse_response(f"glass:transmittance={f}", m)
    assert name == "glass" and unit == "W m-2"
    ex = Explorer(responses={name: (w, unit)}, output_dir=tmp_path, threads=1)
    r = ex.irradiance({"elevation": "40"})
    g = np.array(r["horizontal"]["global"])
    inside = (m.channel_lower >= 400) & (m.channel_lower + m.channel_width <= 760)
    assert inside.sum() == 9
    assert r["horizontal"]["integrated"]["glass"] == pytest.approx(0.6 * g[inside].sum() * m.channel_width, rel=1e-9)
    assert r["units"]["glass"] == "W m-2"
    with pytest.raises(ValueError, match="unit 'lux'"):
        parse_response(f"glass:lux={f}", m)


def test_part_of_a_dataset(tmp_path):
    """Loading part of a dataset: the channels and visibility slabs asked for, and the ranges follow."""
    ex = Explorer(output_dir=tmp_path, threads=1, load_options={"wavelength_range": (380.0, 780.0),
                                                                "visibility": (30.0, 60.0)})
    info = ex.info()["datasets"][0]
    assert min(info["wavelength_nm"]) >= 360 and max(info["wavelength_nm"]) <= 800
    assert min(info["visibility_km"]) <= 30 and max(info["visibility_km"]) >= 60 and max(info["visibility_km"]) < 131
    body, dt, total = ex.render({"elevation": "30", "visibility": "40", "resolution": "64"})
    assert body[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError, match=r"visibility=100 km outside \["):
        ex.render({"visibility": "100"})
    # a subset's sRGB render equals the full dataset's (the composite uses the visible channels only)
    full = Explorer(output_dir=tmp_path, threads=1).render({"elevation": "30", "visibility": "40", "resolution": "64"})
    np.testing.assert_array_equal(png(body), png(full[0]))


def test_concurrent_requests(server):
    """The page sends render, irradiance and spectrum requests at once: all answer, and the same state gives
    the same image whatever ran beside it."""
    from concurrent.futures import ThreadPoolExecutor

    q = "elevation=33&azimuth=140&visibility=45&resolution=96"
    paths = [f"/api/render?{q}", f"/api/irradiance?{q}", f"/api/spectrum?{q}&u=0.5&v=0.4"] * 3
    with ThreadPoolExecutor(6) as pool:
        answers = list(pool.map(lambda p: request(server, p), paths))
    assert all(a[0] == 200 for a in answers)
    images = [png(a[2]) for p, a in zip(paths, answers) if p.startswith("/api/render")]
    assert all(np.array_equal(images[0], im) for im in images[1:])


# --- issue 34: the server refuses what another page, a malformed request or an idle client could do ---------

def _own_server(tmp_path, **kwargs):
    """A server of its own (so its limits and budget do not touch the shared one); stop with .shutdown()."""
    server_kw = {k: kwargs.pop(k) for k in ("idle_timeout", "max_workers") if k in kwargs}
    srv = make_server(Explorer(output_dir=tmp_path / "out", threads=1, **kwargs), port=0, **server_kw)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    return srv


@pytest.mark.parametrize("headers, token", [
    ({"Origin": "http://evil.example"}, True),                  # another site's page, token or not
    ({"Origin": "null"}, True),                                 # a sandboxed frame or a file:// page
    ({"Origin": "http://127.0.0.1:1"}, True),                   # another local server (same site, other origin)
    ({"Sec-Fetch-Site": "cross-site"}, True),
    ({"Sec-Fetch-Site": "same-site"}, True),
    ({}, False),                                                # no token
    ({}, "x" * 43),                                             # a wrong token
])
def test_cross_origin_and_tokenless_writes_are_refused(server, headers, token):
    srv, out = server
    before = sorted(p.name for p in out.iterdir())
    status, _, body = request(server, "/api/save?name=csrf&format=png&resolution=32", "POST", headers=headers,
                              token=token)
    assert status == 403, body
    assert sorted(p.name for p in out.iterdir()) == before          # nothing written
    # the page's own request (its Origin, its token) is accepted
    port = srv.server_address[1]
    status, _, body = request(server, "/api/save?name=same-origin&format=png&resolution=32&overwrite=1", "POST",
                              headers={"Origin": f"http://127.0.0.1:{port}", "Sec-Fetch-Site": "same-origin"})
    assert status == 200, body


def test_other_origins_cannot_read_the_api(server):
    for path in ("/api/info", "/api/render?resolution=32", "/files/anything.png"):
        status, _, _ = request(server, path, headers={"Sec-Fetch-Site": "cross-site"})
        assert status == 403
        status, _, _ = request(server, path, headers={"Origin": "http://evil.example"})
        assert status == 403
    assert request(server, "/api/info", headers={"Sec-Fetch-Site": "same-origin"})[0] == 200
    assert request(server, "/api/info", headers={"Sec-Fetch-Site": "none"})[0] == 200   # a typed address


def test_the_token_is_per_session_and_only_in_the_page(tmp_path, server):
    other = _own_server(tmp_path)
    try:
        t1, t2 = page_token(server[0]), page_token(other)
        assert t1 != t2 and len(t1) >= 40                       # 256 random bits each, URL-safe base64
        assert t1 not in request(server, "/api/info")[2].decode()
        # one session's token does not open the other
        assert request(other, "/api/save?name=x&format=png&resolution=32", "POST", token=t1)[0] == 403
    finally:
        other.shutdown()
        other.server_close()


def test_save_budget_bounds_the_bytes_a_session_writes(tmp_path):
    srv = _own_server(tmp_path, save_budget=400_000)
    try:
        out = tmp_path / "out"
        status, r = get_json(srv, "/api/save?name=a&format=png&resolution=64", method="POST")
        assert status == 200 and 0 < r["saved_bytes"] == (out / "a.png").stat().st_size
        # 512 x 512 x 3 bytes is more than is left: 507, nothing written
        status, r = get_json(srv, "/api/save?name=b&format=png&resolution=64&save_resolution=512", method="POST")
        assert status == 507 and "save budget" in r["error"] and "--save-budget" in r["error"]
        assert sorted(p.name for p in out.iterdir()) == ["a.png"]
        # many small saves stop at the budget, never past it
        codes = [get_json(srv, f"/api/save?name=s{i}&format=png&resolution=128", method="POST")[0] for i in range(40)]
        assert 507 in codes
        written = sum(p.stat().st_size for p in out.iterdir())
        assert written <= 400_000
        assert get_json(srv, "/api/info")[1]["saved_bytes"] == written
    finally:
        srv.shutdown()
        srv.server_close()


def test_a_save_larger_than_memory_is_refused_with_413(server, monkeypatch):
    import widesky.skymodel.render as render_mod

    monkeypatch.setattr(render_mod, "available_memory_bytes", lambda: 50_000_000)
    srv, out = server
    status, r = get_json(server, "/api/save?name=huge&format=exr&save_resolution=4000", method="POST")
    assert status == 413 and "save_resolution 4000" in r["error"] and "GB" in r["error"]
    assert not (out / "huge.exr").exists()


@pytest.mark.parametrize("tz", ["dateutil//usr/share/zoneinfo/Europe/Prague", "/usr/share/zoneinfo/Europe/Prague",
                                "../../../etc/localtime", "file:/etc/localtime", "Europe/../Europe/Prague",
                                "Europe/Prague/", "posixrules/../UTC", "15", "1e3", "nan", ":Europe/Prague"])
def test_tz_accepts_iana_names_only(server, tz):
    from urllib.parse import quote

    status, body = get_json(server, f"/api/sun?time=2024-06-21T12:00&tz={quote(tz, safe='')}")
    assert status == 400 and "IANA time zone name" in body["error"], body


@pytest.mark.parametrize("tz", ["Europe/Prague", "UTC", "America/Denver", "-7", "5.5"])
def test_tz_names_and_offsets_work(server, tz):
    from urllib.parse import quote

    status, body = get_json(server, f"/api/sun?time=2024-06-21T12:00&tz={quote(tz, safe='')}")
    assert status == 200, body


def _raw(srv, data, timeout=5.0):
    """Send raw bytes on a new connection; return (first line of the answer, seconds until it came)."""
    s = socket.create_connection(("127.0.0.1", srv.server_address[1]), timeout=timeout)
    t0 = time.perf_counter()
    s.sendall(data)
    chunks = []
    try:
        while True:
            b = s.recv(65536)
            if not b:
                break
            chunks.append(b)
    except TimeoutError:
        pass
    s.close()
    answer = b"".join(chunks)
    return answer.split(b"\r\n", 1)[0].decode(errors="replace"), time.perf_counter() - t0, answer


@pytest.mark.parametrize("length, code", [("abc", 400), ("-1", 400), ("+5", 400), ("1e3", 400), (" ", 400),
                                          ("99999999999999999999999", 400), (str(1 << 20), 413),
                                          (str(10 ** 12), 413)])
def test_malformed_content_length_is_answered_at_once(server, length, code):
    srv, _ = server
    port = srv.server_address[1]
    line, dt, _ = _raw(srv, (f"POST /api/save?name=cl HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
                             f"Content-Length: {length}\r\n\r\n").encode())
    assert line.split()[1] == str(code), line
    assert dt < 2.0                                             # not waiting for a body that will not come


def test_idle_and_stalled_connections_are_closed(tmp_path):
    srv = _own_server(tmp_path, idle_timeout=1.0)
    try:
        port = srv.server_address[1]
        for data in (b"", b"GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:" + str(port).encode() + b"\r\n",
                     f"POST /api/save HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 10\r\n\r\nabc".encode()):
            s = socket.create_connection(("127.0.0.1", port), timeout=10)
            t0 = time.perf_counter()
            if data:
                s.sendall(data)
            b = s.recv(1024)                 # idle: the server closes it (b"" or a short error answer)
            while b and s.recv(1024):
                pass
            assert time.perf_counter() - t0 < 3.0
            s.close()
    finally:
        srv.shutdown()
        srv.server_close()


def test_worker_threads_are_bounded(tmp_path):
    srv = _own_server(tmp_path, idle_timeout=2.0, max_workers=3)
    port = srv.server_address[1]
    try:
        base = threading.active_count()
        idle = [socket.create_connection(("127.0.0.1", port), timeout=10) for _ in range(3)]
        time.sleep(0.3)
        assert threading.active_count() <= base + 3
        line, dt, _ = _raw(srv, f"GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
        assert " 503 " in line + " " and dt < 1.0                # refused at once, not queued behind idle ones
        many = [socket.create_connection(("127.0.0.1", port), timeout=10) for _ in range(30)]
        time.sleep(0.3)
        assert threading.active_count() <= base + 3
        for s in idle + many:
            s.close()
        time.sleep(2.5)                                          # the idle timeout frees the workers
        assert request(srv, "/api/info")[0] == 200
    finally:
        srv.shutdown()
        srv.server_close()


def test_answers_show_no_absolute_path_and_no_python_version(server):
    srv, out = server
    status, headers, body = request(server, "/api/info")
    assert status == 200 and str(out) not in body.decode() and str(Path.home()) not in body.decode()
    assert json.loads(body)["output_dir"] == out.name
    status, headers, body = request(server, "/api/save?name=nopath&format=png&resolution=32", "POST")
    assert status == 200 and str(out) not in body.decode()
    for path in ("/", "/api/info", "/missing"):
        server_header = request(server, path)[1]["Server"]
        assert server_header == "widesky-explorer", server_header
    line, _, answer = _raw(srv, b"BREW /\r\n\r\n")                 # http.server's own error page
    assert b"Python" not in answer


# --- issue 40: what the reference GUI has -------------------------------------------------------------------

@pytest.fixture(scope="module")
def twilight_dir(tmp_path_factory):
    """A folder with a small synthetic dataset whose elevation grid reaches -4.2 deg (twilight)."""
    from widesky.skymodel.synthetic import write_synthetic_dataset

    d = tmp_path_factory.mktemp("datasets")
    write_synthetic_dataset(d / "twilight.dat", n_channels=12, channel_start=360.0, channel_width=40.0,
                            visibilities=(20.0, 131.8), albedos=(0.0, 1.0))
    (d / "notes.txt").write_text("not a dataset")
    return d


def test_datasets_are_opened_at_run_time_from_allowed_folders_only(tmp_path, twilight_dir):
    srv = _own_server(tmp_path, dataset_dirs=[twilight_dir])
    try:
        status, av = get_json(srv, "/api/datasets")
        assert status == 200 and av["folders"] == [twilight_dir.name]
        assert [f["name"] for f in av["files"]] == ["twilight.dat"] and av["files"][0]["loaded"] is None
        assert str(twilight_dir) not in json.dumps(av)
        # opening is state-changing: token only
        assert request(srv, "/api/load?folder=0&name=twilight.dat", "POST", token=False)[0] == 403
        status, d = get_json(srv, "/api/load?folder=0&name=twilight.dat", method="POST")
        assert status == 200 and d["index"] == 1 and d["synthetic"] and min(d["elevation_deg"]) < 0
        assert get_json(srv, "/api/datasets")[1]["files"][0]["loaded"] == 1
        assert get_json(srv, "/api/load?folder=0&name=twilight.dat", method="POST")[1]["index"] == 1   # once
        # below the horizon: the sun at -2 deg renders, and the readouts follow
        status, headers, body = request(srv, "/api/render?dataset=1&elevation=-2&resolution=64")
        assert status == 200 and png(body).max() > 0
        status, irr = get_json(srv, "/api/irradiance?dataset=1&elevation=-2")
        assert status == 200 and irr["horizontal"]["broadband"]["direct"] == 0.0
        # never a path: traversal, absolute paths, other suffixes, other folders
        for name in ("../twilight.dat", str(twilight_dir / "twilight.dat"), "notes.txt", "%2e%2e%2fx.dat",
                     "twilight.dat/", ".twilight.dat"):
            status, body = get_json(srv, f"/api/load?folder=0&name={name}", method="POST")
            assert status == 400 and "not a dataset file" in body["error"]
            assert str(twilight_dir) not in body["error"].replace(name, "")        # only the name sent is echoed
        assert get_json(srv, "/api/load?folder=1&name=twilight.dat", method="POST")[0] == 400
    finally:
        srv.shutdown()
        srv.server_close()
    # without --dataset-dir nothing can be opened
    plain = _own_server(tmp_path / "plain")
    try:
        status, body = get_json(plain, "/api/load?folder=0&name=twilight.dat", method="POST")
        assert status == 403 and "--dataset-dir" in body["error"]
    finally:
        plain.shutdown()
        plain.server_close()


def test_saves_above_the_view_resolution_and_chosen_names(server):
    srv, out = server
    # the interactive image stays at most 1024 pixels; a save goes to 10000
    assert get_json(server, "/api/render?resolution=2048")[0] == 400
    status, r = get_json(server, "/api/save?name=big.png&format=png&resolution=256&save_resolution=2048",
                         method="POST")
    assert status == 200 and r["written"] == ["big.png"] and r["resolution"] == 2048
    assert png(request(server, "/files/big.png")[2]).shape == (2048, 2048, 3)
    status, r = get_json(server, "/api/save?name=big&format=png&save_resolution=64", method="POST")
    assert status == 409 and "overwrite" in r["error"]                      # never replaced silently
    assert png(request(server, "/files/big.png")[2]).shape == (2048, 2048, 3)
    status, r = get_json(server, "/api/save?name=big&format=png&save_resolution=64&overwrite=1", method="POST")
    assert status == 200 and png(request(server, "/files/big.png")[2]).shape == (64, 64, 3)
    status, r = get_json(server, "/api/save?name=x&format=png&save_resolution=10001", method="POST")
    assert status == 400 and "[16, 10000]" in r["error"]


def test_exposure_beyond_8_ev(server):
    dim = png(request(server, "/api/render?resolution=64&exposure=-16")[2])
    bright = png(request(server, "/api/render?resolution=64&exposure=16")[2])
    assert dim.max() <= 2 and np.median(bright[bright > 0]) == 255
    status, r = get_json(server, "/api/render?resolution=64&exposure=21")
    assert status == 400 and "[-20, 20]" in r["error"]


# --- issue 36: what a slider move costs ---------------------------------------------------------------------

def _display_from_raw(kind, data, n, exposure):
    """The page's display mapping (static/app.js paint) in numpy: half floats times 2**EV in float32, 16-bit
    levels, the sRGB table (polarisation: the diverging map)."""
    from widesky.skymodel.render import _srgb8_table, polarisation_colours

    v = np.frombuffer(data, "<f2").astype(np.float32).reshape(n, n, -1)
    nan = np.isnan(v[..., 0])
    gain = np.float32(2.0 ** exposure)
    if kind == "signed":
        out = polarisation_colours(v[..., 0] * gain)
    else:
        with np.errstate(invalid="ignore", over="ignore"):
            x = np.nan_to_num(np.clip(v * gain, 0, 1), nan=0.0).astype(np.float32)
        lv = _srgb8_table()[(x * np.float32(65535) + np.float32(0.5)).astype(np.uint16)]
        out = lv if kind == "rgb" else np.repeat(lv, 3, axis=-1)
    out[nan] = 0
    return out


@pytest.mark.parametrize("extra", ["", "&channel=540nm", "&quantity=transmittance&channel=540nm", "&view=side",
                                   "&quantity=sun", "&elevation=2&azimuth=250"])
def test_raw_images_map_to_the_png(server, extra):
    """The page's image equals the server's PNG within one 8-bit level (the half float's rounding, at most
    2^-11 relative: about 1 % of the values), for every exposure."""
    q = f"/api/render?elevation=21&azimuth=150&resolution=96{extra}"
    status, h, raw = request(server, q + "&format=raw")
    assert status == 200 and h["Content-Type"] == "application/octet-stream"
    n = int(h["X-Image-Size"])
    assert len(raw) == n * n * (3 if h["X-Image-Kind"] == "rgb" else 1) * 2        # half floats: 2 bytes a value
    for ev in (0.0, 2.5, -3.0, 12.0):
        ref_png = png(request(server, f"{q}&exposure={ev}")[2])
        diff = np.abs(_display_from_raw(h["X-Image-Kind"], raw, n, ev).astype(int) - ref_png)
        assert diff.max() <= 1 and (diff > 0).mean() < 0.02, (ev, diff.max(), (diff > 0).mean())


def test_an_exposure_or_plane_change_evaluates_no_sky(server, monkeypatch):
    import widesky.explorer.server as server_mod

    calls = {"render": 0, "sky": 0}
    real_render, real_sky = server_mod.render_view, server_mod.sky_patches

    def count(name, f):
        def wrapped(*a, **k):
            calls[name] += 1
            return f(*a, **k)
        return wrapped

    monkeypatch.setattr(server_mod, "render_view", count("render", real_render))
    monkeypatch.setattr(server_mod, "sky_patches", count("sky", real_sky))
    q = "elevation=47.3&azimuth=111&resolution=64"
    request(server, f"/api/render?{q}")
    for ev in (1, 2, -4):
        status, h, _ = request(server, f"/api/render?{q}&exposure={ev}&surface_tilt={10 * ev + 50}")
        assert status == 200 and float(h["X-Render-Seconds"]) == 0.0
    assert calls["render"] == 1
    first = get_json(server, f"/api/irradiance?{q}&surface_tilt=20")[1]
    for tilt in (30, 40, 50):
        r = get_json(server, f"/api/irradiance?{q}&surface_tilt={tilt}&surface_azimuth=140")[1]
    assert calls["sky"] == 1
    # the cached sky gives what a fresh evaluation gives
    from widesky.explorer.compute import plane_irradiance
    ex = server[0].RequestHandlerClass.explorer
    fresh = plane_irradiance(ex.model(0), ex.view({"elevation": "47.3", "azimuth": "111", "surface_tilt": "50",
                                                   "surface_azimuth": "140"}))
    np.testing.assert_array_equal(r["tilted"]["global"], fresh["tilted"]["global"])
    assert first["horizontal"]["global"] == r["horizontal"]["global"]


def test_a_request_abandoned_while_queued_is_not_evaluated(server, monkeypatch):
    """A slider state superseded while it waits (the page aborted its fetch) costs no evaluation."""
    import widesky.explorer.server as server_mod

    calls = []
    real = server_mod.render_view
    monkeypatch.setattr(server_mod, "render_view", lambda *a, **k: calls.append(1) or real(*a, **k))
    srv, _ = server
    ex = srv.RequestHandlerClass.explorer
    port = srv.server_address[1]
    with ex._eval:                            # another evaluation is running
        s = socket.create_connection(("127.0.0.1", port))
        s.sendall(f"GET /api/render?elevation=12.345&resolution=64 HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"
                  .encode())
        time.sleep(0.3)
        s.close()                             # the page's AbortController
        time.sleep(0.2)
    time.sleep(0.5)
    assert calls == []
    assert request(server, "/api/render?elevation=12.345&resolution=64")[0] == 200 and calls == [1]


def test_raw_polarisation_maps_to_the_png(tmp_path):
    """The signed degree of polarisation (the package's polarised dataset) on the diverging map, in the page
    as in the PNG, NaN (black) outside the disc."""
    path = Path(skymodel.__file__).parent / "data" / "polarised.dat"
    ex = Explorer(datasets=[path], output_dir=tmp_path, threads=1)
    q = {"quantity": "polarisation", "channel": "540nm", "elevation": "25", "resolution": "80"}
    data, headers = ex.render_linear(q)
    assert headers["X-Image-Kind"] == "signed"
    for ev in (0.0, 1.5):
        body, _, _ = ex.render({**q, "exposure": str(ev)})
        diff = np.abs(_display_from_raw("signed", data, 80, ev).astype(int) - png(body))
        assert diff.max() <= 1 and (diff > 0).mean() < 0.02
