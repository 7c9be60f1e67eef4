"""The one pipeline (:mod:`widesky.irradiance.simulation`): one defaults table, one sky-state function, one
Simulation behind every front end.

References and tolerances:
* closure with the measurements: under a weather file an unobstructed horizontal face receives the file's
  ``DNI sin(elevation) + DHI`` (the all-sky model and the clear-sky scaling both keep the measured broadband
  DNI and DHI, docs/all-sky.md) within 2e-3 relative wherever the sun is above 5 deg (float32 products);
* the same weather file gives the same sky input through ``widesky poa``, ``widesky pv``, a case and the API
  (identical arrays, no tolerance);
* the defaults of every command-line option and case key equal :data:`SKY_DEFAULTS` (exact).
"""

import argparse
import ast
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import trimesh

import widesky
from widesky.core.spectral import in_band_share
from widesky import cases
from widesky.commands import poa as poa_cmd
from widesky.commands import pv as pv_cmd
from widesky.commands import sky_args
from widesky.irradiance import (SKY_DEFAULTS, AllSkyWeather, Simulation, Site, SkyOptions, make_scene,
                                sky_input)

SAMPLE = Path(str(resources.files("widesky.irradiance.data") / "sample_golden_june.epw"))
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    d = tmp_path_factory.mktemp("sim")
    v = np.array([[0, 0, 0.0], [4, 0, 0.0], [4, 3, 0.0], [0, 3, 0.0]])
    path = d / "plate.obj"
    trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False).export(path)
    return path


def test_the_top_level_names_are_the_pipeline():
    assert widesky.Simulation is Simulation and widesky.SkyOptions is SkyOptions
    assert widesky.SKY_DEFAULTS is SKY_DEFAULTS


def test_defaults_allsky_under_weather():
    assert SKY_DEFAULTS.spectral_model == "allsky" and SKY_DEFAULTS.use_measured
    got = sky_input(SAMPLE)
    assert isinstance(got.measured, AllSkyWeather) and got.spectral_model == "allsky"
    assert "all-sky spectra" in got.description and got.sky_model == "all-sky"
    clear = sky_input(SAMPLE, options=SKY_DEFAULTS.replace(spectral_model="clear"))
    assert clear.spectral_model == "clear" and isinstance(clear.measured, tuple)
    assert "clear-sky spectra" in clear.description
    bound = sky_input(SAMPLE, options=SKY_DEFAULTS.replace(use_measured=False))
    assert bound.measured is None and "upper bound" in bound.description


def test_a_site_period_is_the_clear_sky_labelled_an_upper_bound():
    got = sky_input(Site(50.08, 14.42, tz="Europe/Prague", name="Prague"), "2023-06-21", "2023-06-22", "1h")
    assert len(got.states) == 24 and got.measured is None and got.spectral_model == "clear"
    assert got.description.startswith("clear sky (Prague)") and "upper bound" in got.description


@pytest.mark.parametrize("bad, msg", [(dict(spectral_model="cloudy"), "spectral_model='cloudy'"),
                                      (dict(aerosol="dust"), "aerosol='dust'"),
                                      (dict(visibility=0.0), r"visibility=0.0 km outside"),
                                      (dict(albedo=1.5), r"albedo=1.5 outside the valid range \[0, 1\]"),
                                      (dict(ground_spectrum="snow"), "ground_spectrum='snow'")])
def test_bad_sky_options_name_the_option_and_range(bad, msg):
    with pytest.raises(ValueError, match=msg):
        SkyOptions(**bad)


def test_simulation_needs_one_source(plate):
    scene = make_scene([str(plate)])
    with pytest.raises(ValueError, match="exactly one of site= .* and weather="):
        Simulation(scene)
    with pytest.raises(ValueError, match="exactly one of"):
        Simulation(scene, site=Site(0, 0), weather=SAMPLE)
    with pytest.raises(ValueError, match="start= and end="):
        Simulation(scene, site=Site(0, 0))
    with pytest.raises(TypeError, match="SkyOptions"):
        Simulation(scene, weather=SAMPLE, sky={"spectral_model": "clear"})


@pytest.mark.parametrize("model", ["allsky", "clear"])
def test_a_horizontal_face_receives_the_measured_global(plate, model):
    scene = make_scene([str(plate)])
    sim = Simulation(scene, weather=SAMPLE, start="2021-06-14", end="2021-06-17",
                     sky=SKY_DEFAULTS.replace(spectral_model=model), n_jobs=1)
    res = sim.run()
    rows = sim.input.weather
    el = sim.states.sun_elevation
    expected = rows["dni"].to_numpy() * np.sin(np.radians(np.clip(el, 0, None))) + rows["dhi"].to_numpy()
    expected = expected * in_band_share(280.0, 2480.0)        # the file's broadband in 280-2480 nm (issue 35)
    got = res.aggregate()["broadband:global"][:, 0]
    lit = el > 5.0
    assert lit.sum() > 20
    np.testing.assert_allclose(got[lit], expected[lit], rtol=2e-3)
    res.close()


def _args(command_register, argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    command_register(sub)
    return parser.parse_args(argv)


def test_every_command_reads_the_same_sky_input(plate, tmp_path):
    """poa and pv give the same options and the same sky input for one weather file; so does a case."""
    a = _args(poa_cmd.register, ["poa", str(plate), "--weather", str(SAMPLE), "-o", str(tmp_path / "x.h5")])
    b = _args(pv_cmd.register, ["pv", "compare", str(plate), "--weather", str(SAMPLE), "-o", str(tmp_path)])
    assert sky_args.sky_options(a) == sky_args.sky_options(b) == SKY_DEFAULTS
    scene = make_scene([str(plate)])
    sa, sb = (sky_args.simulation(x, scene, None).input for x in (a, b))
    (tmp_path / "case").mkdir()
    (tmp_path / "case" / "case.toml").write_text(
        f'[case]\ntitle = "t"\n[site]\nlatitude = 39.7\nlongitude = -105.2\n[period]\nstart = "2021-06-01"\n'
        f'end = "2021-07-01"\n[sky]\nweather = "{SAMPLE}"\n[scene]\ngeometry = "{plate}"\n'
        f'[report]\nsky_time = "2021-06-15T12:00"\n')
    cfg = cases.load_config(tmp_path / "case")
    sc = cases.runner.simulation(cfg, scene, None).input
    api = sky_input(SAMPLE)
    for other in (sb, sc, api):
        assert other.spectral_model == sa.spectral_model == "allsky"
        np.testing.assert_array_equal(other.states.visibility, sa.states.visibility)
        np.testing.assert_array_equal(other.states.sun_elevation, sa.states.sun_elevation)
        np.testing.assert_array_equal(other.measured.dni, sa.measured.dni)


def test_case_schema_defaults_are_the_sky_defaults():
    sky = cases.SCHEMA["sky"]
    for key in ("spectral_model", "aerosol", "visibility", "albedo", "ground_spectrum", "use_measured"):
        assert sky[key].default == getattr(SKY_DEFAULTS, key), key


def test_command_line_sky_options_default_to_none():
    """An option the user does not give takes SKY_DEFAULTS' value: no command carries its own default."""
    parser = argparse.ArgumentParser()
    sky_args.add_sky_arguments(parser)
    ns = parser.parse_args([])
    for name in ("spectral_model", "aerosol", "visibility", "albedo", "ground_spectrum", "dataset"):
        assert getattr(ns, name) is None, name


def _calls(name):
    """(file, line) of every call of ``name`` in the installed runtime and front-end sources."""
    out = []
    for folder in ("skymodel", "irradiance", "pvsim", "thermal", "cases", "src/widesky"):
        for path in (ROOT / folder).rglob("*.py"):
            if "generator" in path.parts:
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Call):
                    f = node.func
                    called = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
                    if called == name:
                        out.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return out


@pytest.mark.parametrize("name", ["sky_states_for", "weather_measurements"])
def test_one_function_turns_weather_into_sky_states(name):
    """Only the pipeline (irradiance/simulation.py) turns a site or a weather file into sky states."""
    assert [c for c in _calls(name) if not c.startswith("irradiance/simulation.py")] == []


def test_one_reference_spectrum_and_one_jobs_default():
    """The STC reference spectrum defaults to pvsim.DEFAULT_REFERENCE in `widesky pv` and in a case file; every
    simulating command's --jobs defaults to all cores (None)."""
    from widesky import pvsim
    from widesky.commands import run as run_cmd
    from widesky.commands import thermal as thermal_cmd
    b = _args(pv_cmd.register, ["pv", "compare", "x.obj", "-o", "out"])
    assert b.reference == cases.SCHEMA["pv"]["reference"].default == pvsim.DEFAULT_REFERENCE == "g173"
    assert b.jobs is None
    assert _args(poa_cmd.register, ["poa", "x.obj", "-o", "x.h5"]).jobs is None
    assert _args(run_cmd.register, ["run", "case"]).jobs is None
    for argv in (["thermal", "loads", "--weather", "w.epw", "--output", "o.csv"],
                 ["thermal", "study", "--weather", "w.epw", "--output", "o"], ["thermal", "bestest"]):
        assert _args(thermal_cmd.register, argv).jobs is None, argv


def test_ctrl_c_is_one_line_and_status_130(monkeypatch, capsys):
    """Issue 34: an interrupt anywhere in a command prints one line and exits 130 (128 + SIGINT), no traceback."""
    from widesky import cli

    def interrupted(args):
        raise KeyboardInterrupt
    monkeypatch.setattr(sky_args, "simulation", lambda *a, **k: interrupted(None))
    monkeypatch.setattr(poa_cmd, "simulation", lambda *a, **k: interrupted(None))
    code = cli.main(["poa", str(ROOT / "docs" / "example-data" / "roof.obj"), "--lat", "50", "--lon", "14",
                     "--start", "2023-06-01", "--end", "2023-06-02", "-o", "/tmp/never-written.h5"])
    err = capsys.readouterr().err
    assert code == 130 and err == "widesky: interrupted\n"
    assert not Path("/tmp/never-written.h5").exists()


def test_a_typical_year_runs_all_its_8760_hours():
    """The shipped Denver TMY3 year (EPW hours labelled with their end, 1 Jan 01:00 .. 31 Dec 24:00) moved to
    2023 gives 8760 steps for the period [2023-01-01, 2024-01-01): the hour ending at 24:00 on 31 Dec (labelled
    2024-01-01 00:00) is the year's last, not outside it; and a day is its 24 hours ending 01:00 .. 24:00."""
    path = "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"
    year = sky_input(path, "2023-01-01", "2024-01-01", coerce_year=2023, warn=False)
    assert len(year.states) == len(year.weather) == 8760
    assert str(year.states.times[0]) == "2023-01-01 01:00:00-07:00"
    assert str(year.states.times[-1]) == "2024-01-01 00:00:00-07:00"
    day = sky_input(path, "2023-06-21", "2023-06-22", coerce_year=2023, warn=False).states.times
    assert len(day) == 24 and day[0].hour == 1 and str(day[-1]) == "2023-06-22 00:00:00-07:00"
