"""``widesky poa``: a mesh, a site and a period (clear sky), or a weather file (measured DNI/DHI).

References and tolerances:
* a horizontal roof under a weather file: the group's poa_global equals the file's
  ``DNI sin(elevation) + DHI`` (the measured weather the sky is scaled to; elevation mid-interval
  by NREL SPA) within 2e-3 wherever the sun is above 5 deg (the integrator's float32 products; the
  roof sees no ground);
* a flat response of 1 over 200-3000 nm: its global part = poa_global (same contraction);
* night steps are 0; bad input gives exit status 2 and a one-line message naming the problem,
  before any computation (no output file is left behind).
"""

import numpy as np
import pandas as pd
import pytest
import trimesh

from widesky.core.spectral import in_band_share
from widesky.irradiance.location import Site
from widesky.irradiance.weather import read_weather, write_epw
from widesky.cli import main


@pytest.fixture(scope="module")
def roof(tmp_path_factory):
    d = tmp_path_factory.mktemp("poa_cli")
    v = np.array([[0, 0, 0.0], [4, 0, 0.0], [4, 3, 0.0], [0, 3, 0.0]])
    path = d / "roof.obj"
    trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False).export(path)
    return path


@pytest.fixture(scope="module")
def epw(tmp_path_factory):
    """Three June days at 48 N: overcast, broken cloud, clear (plausible hourly DNI / DHI)."""
    site = Site(48.0, 11.0, 500.0, tz=1.0, name="test")
    idx = pd.date_range("2021-06-20 01:00", periods=72, freq="1h", tz=site.tz)
    el = site.solar_position(idx, label="right", step="1h")["apparent_elevation"].to_numpy()
    s = np.clip(np.sin(np.radians(el)), 0.0, None)
    day = np.repeat([0, 1, 2], 24)
    dni = np.where(day == 0, 0.0, np.where(day == 1, 350.0, 800.0)) * s ** 0.3 * (s > 0)
    dhi = np.where(day == 0, 180.0, np.where(day == 1, 220.0, 90.0)) * s ** 0.8
    data = pd.DataFrame({"ghi": dni * s + dhi, "dni": dni, "dhi": dhi, "temp_air": 20.0,
                         "wind_speed": 2.0, "visibility": 30.0, "albedo": 0.2}, index=idx)
    path = tmp_path_factory.mktemp("weather") / "test.epw"
    write_epw(path, data, site)
    return path


def test_weather_file_reproduces_measured_irradiance(roof, epw, tmp_path, capsys):
    flat = tmp_path / "flat.csv"
    flat.write_text("wavelength_nm,sr\n200,1\n3000,1\n")
    out = tmp_path / "poa.csv"
    assert main(["poa", str(roof), "--weather", str(epw), "--response", f"flat:weight={flat}",
                 "--jobs", "1", "-o", str(out)]) == 0
    assert "scaled to measured DNI/DHI" in capsys.readouterr().out
    res = pd.read_csv(out, index_col=0)
    g = res.filter(like=":broadband:poa_global").iloc[:, 0].to_numpy()
    eff = res.filter(like=":flat:poa_global").iloc[:, 0].to_numpy()
    wd = read_weather(epw)
    el = wd.solar_position()["apparent_elevation"].to_numpy()
    want = wd.data["dni"].to_numpy() * np.sin(np.radians(el)) + wd.data["dhi"].to_numpy()
    want = want * in_band_share(280.0, 2480.0)                 # the file's broadband in 280-2480 nm (issue 35)
    up = el > 5.0
    assert up.sum() > 30
    np.testing.assert_allclose(g[up], want[up], rtol=2e-3)
    assert np.all(g[el <= 0] == 0)
    np.testing.assert_allclose(eff, g, rtol=1e-5, atol=1e-3)


def test_clear_sky_period_h5(roof, tmp_path):
    from widesky.irradiance import POAResult
    out = tmp_path / "poa.h5"
    assert main(["poa", str(roof), "--lat", "48", "--lon", "11", "--tz", "Europe/Berlin",
                 "--start", "2021-06-21", "--end", "2021-06-22", "--jobs", "1", "-o", str(out)]) == 0
    with POAResult.load(out) as z:
        assert z.poa_global.shape == (24, 2)
        noon = list(z.times.astype(str)).index("2021-06-21 13:00:00+02:00")
        # clear June noon at 48 N on a horizontal plane: about 900-1000 W m-2 (ASTM G173's global
        # tilted is 1000 W m-2 at 48 deg zenith; here the sun is at 65 deg elevation)
        assert 850 < z.poa_global[noon, 0] < 1100
        assert z.poa_global[2, 0] == 0
        np.testing.assert_allclose(z.faces.area, [6.0, 6.0])
        assert z.states.earth_sun_distance[0] == pytest.approx(1.0163, abs=2e-4)
        assert "widesky poa" in z.provenance["command"]


def test_one_step_period_with_a_step(roof, tmp_path):
    out = tmp_path / "one.csv"
    assert main(["poa", str(roof), "--lat", "50", "--lon", "14", "--tz", "1", "--start",
                 "2023-01-03T11:30", "--end", "2023-01-03T12:30", "--step", "1h", "--jobs", "1",
                 "-o", str(out)]) == 0
    assert len(pd.read_csv(out, index_col=0)) == 1


def test_bad_input_is_a_clear_error(roof, tmp_path, capsys):
    assert main(["poa", str(roof), "--start", "2021-06-21", "--end", "2021-06-22",
                 "-o", str(tmp_path / "x.h5")]) == 2
    assert "--lat, --lon" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    bad.write_text("wavelength,sr\n300,1\n400,oops\n")
    assert main(["poa", str(roof), "--lat", "48", "--lon", "11", "--start", "2021-06-21",
                 "--end", "2021-06-22", "--response", f"x={bad}", "-o", str(tmp_path / "x.h5")]) == 2
    assert "line 3" in capsys.readouterr().err


CLEAR = ["--lat", "48", "--lon", "11", "--start", "2021-06-21", "--end", "2021-06-22"]


@pytest.mark.parametrize("extra, out, msg", [
    (["--jobs", "0"], "x.h5", "--jobs 0: must be >= 1"),
    (["--ground-z", "nan"], "x.h5", "--ground-z nan"),
    ([], "p.txt", "unknown suffix; valid: .h5, .hdf5, .csv"),
    ([], "missing/dir/x.h5", "does not exist"),
    (["--visibility", "-3"], "x.h5", "--visibility -3.0"),
    (["--end", "2221-06-22", "--step", "1min"], "x.h5", "split the period"),
])
def test_bad_options_refused_first(roof, tmp_path, capsys, extra, out, msg):
    assert main(["poa", str(roof), *CLEAR, *extra, "-o", str(tmp_path / out)]) == 2
    err = capsys.readouterr().err
    assert msg in err and err.count("\n") == 1 and "Traceback" not in err
    assert not any(p.name.startswith((".tmp-", "x.")) for p in tmp_path.iterdir())


def test_weather_with_lat_lon_and_repeated_response(roof, epw, tmp_path, capsys):
    flat = tmp_path / "flat.csv"
    flat.write_text("wavelength_nm,value\n200,1\n3000,1\n")
    assert main(["poa", str(roof), "--weather", str(epw), "--lat", "48", "-o",
                 str(tmp_path / "x.h5")]) == 2
    assert "--weather gives the site: remove --lat" in capsys.readouterr().err
    assert main(["poa", str(roof), *CLEAR, "--response", f"a:weight={flat}", "--response", f"a:weight={flat}",
                 "-o", str(tmp_path / "x.h5")]) == 2
    assert "given twice" in capsys.readouterr().err


def test_mesh_indexing_a_missing_vertex(tmp_path, capsys):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n")
    assert main(["poa", str(bad), *CLEAR, "-o", str(tmp_path / "x.h5")]) == 2
    assert "indexes a vertex" in capsys.readouterr().err


def test_each_response_may_carry_its_unit(roof, tmp_path, capsys):
    """``NAME:UNIT=FILE`` overrides --response-unit for that response: a flat transmittance of 1 is the broadband
    irradiance [W m-2] (same contraction), where the sr default refuses the same file (1 A W-1 is above the
    physical limit below 1240 nm); an unknown unit is refused, naming it."""
    flat = tmp_path / "flat.csv"
    flat.write_text("wavelength_nm,value\n200,1\n3000,1\n")
    out = tmp_path / "u.h5"
    assert main(["poa", str(roof), *CLEAR, "--response", f"glass:transmittance={flat}", "--response",
                 f"cell:weight={flat}", "-o", str(out)]) == 0
    from widesky.irradiance import POAResult
    res = POAResult.load(out)
    assert res.units["glass"] == res.units["broadband"] == res.units["cell"] == "W m-2"
    np.testing.assert_allclose(res.get("glass", "global"), res.get("broadband", "global"), rtol=1e-6, atol=1e-6)
    res.close()
    assert main(["poa", str(roof), *CLEAR, "--response", f"cell={flat}", "-o", str(tmp_path / "w.h5")]) == 2
    assert "above the physical limit" in capsys.readouterr().err
    assert main(["poa", str(roof), *CLEAR, "--response", f"g:tvis={flat}", "-o", str(tmp_path / "v.h5")]) == 2
    assert "unit 'tvis' is not one of sr, qe, transmittance, weight" in capsys.readouterr().err


def test_a_typical_year_outside_the_period_suggests_coerce_year(roof, tmp_path, capsys):
    from widesky.core.paths import runtime_file
    tmy = runtime_file("weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")
    args = ["poa", str(roof), "--weather", str(tmy), "--start", "2023-06-01", "--end", "2023-06-02"]
    assert main([*args, "-o", str(tmp_path / "x.h5")]) == 2
    assert "--coerce-year" in capsys.readouterr().err
    assert main([*args, "--coerce-year", "2023", "-o", str(tmp_path / "x.h5")]) == 0
