"""``widesky poa --weather FILE --spectral-model allsky`` (issue 16).

A horizontal roof under three synthetic June days (overcast, broken cloud, clear; the fixture of
tests/test_cli_poa.py rebuilt here) receives the measured GHI with the all-sky model as with the plain
path (2e-3, the integrator's float32 products), while a blue-weighted response sees less light under
overcast than the plain path gives (the plain path scales the Rayleigh-blue clear diffuse); bad
combinations are one-line errors with exit code 2.
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
    v = np.array([[0, 0, 0.0], [4, 0, 0.0], [4, 3, 0.0], [0, 3, 0.0]])
    path = tmp_path_factory.mktemp("allsky_cli") / "roof.obj"
    trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False).export(path)
    return path


@pytest.fixture(scope="module")
def epw(tmp_path_factory):
    site = Site(48.0, 11.0, 500.0, tz=1.0, name="test")
    idx = pd.date_range("2021-06-20 01:00", periods=72, freq="1h", tz=site.tz)
    el = site.solar_position(idx, label="right", step="1h")["apparent_elevation"].to_numpy()
    s = np.clip(np.sin(np.radians(el)), 0.0, None)
    day = np.repeat([0, 1, 2], 24)
    dni = np.where(day == 0, 0.0, np.where(day == 1, 350.0, 800.0)) * s ** 0.3 * (s > 0)
    dhi = np.where(day == 0, 180.0, np.where(day == 1, 220.0, 90.0)) * s ** 0.8
    data = pd.DataFrame({"ghi": dni * s + dhi, "dni": dni, "dhi": dhi, "temp_air": 20.0,
                         "temp_dew": 12.0, "wind_speed": 2.0, "visibility": 12.0, "albedo": 0.2},
                        index=idx)
    path = tmp_path_factory.mktemp("allsky_weather") / "test.epw"
    write_epw(path, data, site)
    return path


@pytest.mark.slow
def test_allsky_cli_keeps_measured_ghi_and_reddens_overcast(roof, epw, tmp_path, capsys):
    blue = tmp_path / "blue.csv"
    blue.write_text("wavelength_nm,value\n280,1\n500,1\n520,0\n3000,0\n")
    out = {}
    for model in ("clear", "allsky"):
        path = tmp_path / f"{model}.csv"
        assert main(["poa", str(roof), "--weather", str(epw), "--response", f"blue={blue}",
                     "--response-unit", "weight", "--spectral-model", model, "--jobs", "1",
                     "-o", str(path)]) == 0
        out[model] = pd.read_csv(path, index_col=0)
    assert "all-sky spectra" in capsys.readouterr().out
    wd = read_weather(epw)
    el = wd.solar_position()["apparent_elevation"].to_numpy()
    want = wd.data["dni"].to_numpy() * np.sin(np.radians(el)) + wd.data["dhi"].to_numpy()
    want = want * in_band_share(280.0, 2480.0)                 # the file's broadband in 280-2480 nm (issue 35)
    up = el > 5.0
    g = out["allsky"].filter(like=":broadband:poa_global").iloc[:, 0].to_numpy()
    np.testing.assert_allclose(g[up], want[up], rtol=2e-3)
    b = {m: out[m].filter(like=":blue:poa_global").iloc[:, 0].to_numpy() for m in out}
    overcast = up & (np.arange(72) < 24)
    assert np.all(b["allsky"][overcast] < 0.85 * b["clear"][overcast])


def test_allsky_cli_needs_weather(roof, epw, tmp_path, capsys):
    assert main(["poa", str(roof), "--lat", "48", "--lon", "11", "--start", "2021-06-21", "--end",
                 "2021-06-22", "--spectral-model", "allsky", "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--spectral-model allsky" in err[0]
    assert main(["poa", str(roof), "--weather", str(epw), "--clear-sky", "--spectral-model", "allsky",
                 "-o", str(tmp_path / "x.csv")]) == 2
