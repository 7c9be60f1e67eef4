"""The sky explorer's HTTP API (skymodel.explorer), driven over a real socket on 127.0.0.1.

References: the images and spectra must equal the library's own renderer and evaluator (exact); the
horizontal irradiance must match an independent brute-force hemisphere integral of the sky model's
radiance (0.25 deg x 0.5 deg midpoint grid, converged: halving the steps changes it by < 1e-5) within
0.5 % global and 1 % diffuse (measured: 0.27 % / 0.6 % at 10 deg sun, less higher up).
"""

import http.client
import io
import json
import subprocess
import sys
import threading
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


def request(server, path, method="GET", host=None):
    srv, _ = server
    port = srv.server_address[1]
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    c.putrequest(method, path, skip_host=True)
    c.putheader("Host", host or f"127.0.0.1:{port}")
    c.putheader("Content-Length", "0")
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


def test_cli_errors_are_one_line():
    p = subprocess.run([sys.executable, "-m", "widesky.cli", "gui", "--port", "70000", "--no-browser"],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and p.stderr.strip().count("\n") == 0 and "--port 70000" in p.stderr


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
