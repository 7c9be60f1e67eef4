"""The case runner (cases/): configuration validation, the report folder, and its numbers.

Physics reference: an unobstructed horizontal roof must receive the sky model's own global horizontal
irradiance (irradiance.model_irradiance, the integrator's quadrature: DNI sin(elevation) + DHI) at every
step, to 0.5 % (the integrator's measured error on an unobstructed plane is 0.13 % annually; the test
checks the runner's wiring of sites, interval labels, times and units, which would shift whole hours).
"""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from widesky import cases
from widesky.cases.config import ConfigError, validate

SHIPPED = Path(cases.__file__).parent

BASE = {
    "case": {"title": "t"},
    "site": {"latitude": 50.08, "longitude": 14.42, "tz": "Europe/Prague"},
    "period": {"start": "2024-06-20", "end": "2024-06-22"},
    "scene": {"geometry": "geometry.py"},
    "report": {"sky_time": "2024-06-21T12:00"},
}


def cfg(**changes):
    d = {k: dict(v) for k, v in BASE.items()}
    for path, value in changes.items():
        section, key = path.split("__")
        d.setdefault(section, {})[key] = value
    return d


@pytest.fixture
def folder(tmp_path):
    shutil.copy(SHIPPED / "solar_potential" / "geometry.py", tmp_path / "geometry.py")
    return tmp_path


@pytest.mark.parametrize("changes, words", [
    ({"sky__visiblity": 40}, ["sky.visiblity", "did you mean 'visibility'", "valid keys in [sky]"]),
    ({"sky__visibility": "40 m"}, ["sky.visibility", "'m'", "expected km"]),
    ({"sky__visibility": 5}, ["sky.visibility = 5", "[20, 131.8] km"]),
    ({"sky__visibility": "150 km"}, ["sky.visibility = '150 km'", "[20, 131.8] km"]),
    ({"sky__albedo": "0.3 km"}, ["sky.albedo", "'km'", "dimensionless"]),
    ({"site__latitude": 95}, ["site.latitude = 95", "[-90, 90] deg"]),
    ({"site__latitude": "50 rad"}, ["site.latitude", "'rad'", "expected deg"]),
    ({"period__step": "2h"}, ["period.step = '2h'", "10min, 15min, 30min, 1h"]),
    ({"period__end": "2024-06-19"}, ["period.end", "must be after period.start"]),
    ({"period__start": "midsummer"}, ["period.start = 'midsummer'", "ISO 8601"]),
    ({"scene__two_sided": "yes"}, ["scene.two_sided = 'yes'", "true or false"]),
    ({"scene__samples_per_face": 3}, ["scene.samples_per_face = 3", "square number"]),
    ({"scene__samples_per_face": 2.5}, ["scene.samples_per_face = 2.5", "integer"]),
    ({"scene__geometry": "nothere.py"}, ["scene.geometry = 'nothere.py'", "no such file"]),
    ({"report__views": ["south-west", "up"]}, ["report.views", "'up'", "south-east", "top"]),
    ({"accuracy__tolerance": 0.001}, ["accuracy.tolerance = 0.001", "[0.006, 0.5]"]),
    ({"skies__visibility": 40}, ["unknown section [skies]", "did you mean 'sky'", "valid sections"]),
])
def test_config_errors_name_the_key_and_the_valid_values(folder, changes, words):
    with pytest.raises(ConfigError) as e:
        validate(cfg(**changes), folder, source="case.toml")
    for w in words:
        assert w in str(e.value), str(e.value)


def test_config_required_keys_and_defaults(folder):
    d = cfg()
    del d["site"]["latitude"]
    with pytest.raises(ConfigError, match=r"site.latitude is required"):
        validate(d, folder)
    ok = validate(cfg(sky__visibility="35.5 km", sky__albedo="0.25"), folder)
    assert ok["sky"]["visibility"] == 35.5 and ok["sky"]["albedo"] == 0.25
    assert ok["period"]["step"] == "1h" and ok["accuracy"]["tolerance"] == 0.02 and ok["sky"]["dataset"] is None
    assert ok["scene"]["geometry"] == (folder / "geometry.py").resolve()


def test_shipped_cases_validate():
    assert "solar_potential" in cases.list_cases()
    for name in cases.list_cases():
        c = cases.load_config(SHIPPED / name)
        assert c["case"]["title"]
        assert (SHIPPED / name / "README.md").is_file()


def _write_case(folder, toml):
    (folder / "case.toml").write_text(toml, encoding="utf-8")
    return folder


SMALL = """
[case]
title = "small"
[site]
latitude = 50.08
longitude = 14.42
tz = "Europe/Prague"
[period]
start = "2024-06-20"
end = "2024-06-22"
step = "1h"
[sky]
visibility = "40 km"
albedo = 0.2
[scene]
geometry = "geometry.py"
[scene.parameters]
cell = 6.0
{extra}
[report]
sky_time = "2024-06-21T12:30"
views = ["south-west"]
render_size = 200
"""


def _run_small(tmp_path_factory, shipped, toml, edit_geometry=None):
    """Copy a shipped case's geometry beside ``toml``, run it, return (report folder, case folder)."""
    folder = tmp_path_factory.mktemp(shipped)
    geo = (SHIPPED / shipped / "geometry.py").read_text()
    (folder / "geometry.py").write_text(edit_geometry(geo) if edit_geometry else geo)
    _write_case(folder, toml)
    out = tmp_path_factory.mktemp("reports") / "rep"
    return cases.run_case(folder, out, n_jobs=1, progress=False, log=lambda m: None), folder


@pytest.fixture(scope="module")
def small_report(tmp_path_factory):
    # no context: the roof is an unobstructed horizontal plane
    return _run_small(tmp_path_factory, "solar_potential", SMALL.format(extra="alone = true"),
                      lambda g: g.replace('    context = {', '    context = {} if parameters.get("alone") else {'))


def test_report_folder_contents(small_report):
    rep, _ = small_report
    names = {p.name for p in rep.iterdir()}
    assert {"index.html", "timeseries.csv", "timeseries.parquet", "faces.csv", "poa.h5", "spectral_hour.h5",
            "provenance.json",
            "case.toml", "sky.exr", "sky.png", "scene_south-west.png", "scene.ply", "scene.glb"} <= names
    assert not [p for p in rep.parent.iterdir() if p.name.startswith(".")]          # no temporary folder left
    html = (rep / "index.html").read_text()
    # self-contained: no script, no stylesheet link, no image or link to another origin
    assert "<script" not in html and "<link" not in html
    assert not re.search(r'(src|href)="(https?:)?//', html)
    assert html.count("data:image/png;base64,") == 2                                 # one render and the sky
    assert "Accuracy and limits" in html and "tolerance 0.02" in html
    import trimesh
    m = trimesh.load(rep / "scene.ply", process=False)
    assert len(m.faces) > 0 and m.visual.face_colors.shape[0] == len(m.faces)
    g = trimesh.load(rep / "scene.glb", force="mesh")               # the same colours per triangle as the PLY
    assert len(g.faces) == len(m.faces)
    np.testing.assert_array_equal(g.visual.vertex_colors[g.faces[:, 0]], m.visual.face_colors)
    pq = pd.read_parquet(rep / "timeseries.parquet")
    csv = pd.read_csv(rep / "timeseries.csv", index_col=0)
    np.testing.assert_allclose(csv.to_numpy(), pq.to_numpy(), rtol=1e-3, atol=1e-3)  # CSV keeps 4 digits


def test_roof_alone_receives_the_model_global_horizontal(small_report):
    import widesky.irradiance as ir

    rep, _ = small_report
    ts = pd.read_csv(rep / "timeseries.csv", index_col=0)
    roof = ts["roof:poa_global [W m-2]"].to_numpy()
    site = ir.Site(50.08, 14.42, tz="Europe/Prague")
    times = ir.time_range("2024-06-20", "2024-06-22", "1h", tz=site.tz, label="left")
    assert list(ts.index) == [str(t) for t in times]
    sp = site.solar_position(times, label="left")
    el = sp["apparent_elevation"].to_numpy()
    # the sun and the sky scale with the Earth-Sun distance (SPA, 1.016 AU in June: 3.2 % below 1 AU)
    st = ir.SkyStates.create(el, sp["azimuth"].to_numpy(), 40.0, 0.2,
                             earth_sun_distance=sp["earth_sun_distance"].to_numpy())
    dni, dhi = ir.model_irradiance(ir.PragueSky(), st)
    ghi = dni * np.sin(np.radians(np.maximum(el, 0))) + dhi
    day = ghi > 20
    np.testing.assert_allclose(roof[day], ghi[day], rtol=5e-3)
    assert np.all(roof[~day] < 25)
    # a period's insolation per face equals the time series summed (faces.csv vs timeseries.csv)
    faces = pd.read_csv(rep / "faces.csv")
    r = faces[faces.label == "roof"]
    assert np.average(r.insolation_kwh_m2, weights=r.area_m2) == pytest.approx(roof.sum() / 1000, rel=1e-3)
    # the saved result holds the same numbers per face
    res = ir.POAResult.load(rep / "poa.h5", groups=["roof"])
    got = res.to_pvlib(group="roof")["poa_global"].to_numpy()
    np.testing.assert_allclose(got, roof, rtol=1e-3, atol=0.05)
    hour = ir.POAResult.load(rep / "spectral_hour.h5")
    assert hour.spectral is not None and len(hour.times) == 1 and str(hour.times[0]) == "2024-06-21 12:00:00+02:00"


def test_spectral_split_sums_to_the_total(small_report):
    rep, _ = small_report
    ts = pd.read_csv(rep / "timeseries.csv", index_col=0)
    for lab in ("roof", "facade_south", "facade_north"):
        bands = sum(ts[f"{lab}:{b} [W m-2]"] for b in cases.BANDS)
        np.testing.assert_allclose(bands, ts[f"{lab}:poa_global [W m-2]"], rtol=2e-3, atol=0.05)


def test_a_failed_run_leaves_the_previous_report_untouched(small_report, monkeypatch):
    rep, folder = small_report
    before = sorted(p.name for p in rep.iterdir())
    stamp = (rep / "index.html").stat().st_mtime_ns
    import widesky.cases.runner
    def boom(run, tmp, provenance, others=None, progress=False):
        (Path(tmp) / "index.html").write_text("half")
        raise KeyboardInterrupt                           # as if interrupted while writing
    monkeypatch.setattr(cases.runner, "write_report", boom)
    with pytest.raises(KeyboardInterrupt):
        cases.run_case(folder, rep, n_jobs=1, progress=False, log=lambda m: None)
    assert sorted(p.name for p in rep.iterdir()) == before and (rep / "index.html").stat().st_mtime_ns == stamp
    assert not [p for p in rep.parent.iterdir() if p.name.startswith(".")]


def test_cli_errors_are_one_line(tmp_path, folder):
    _write_case(folder, SMALL.format(extra="").replace('visibility = "40 km"', 'visibility = "40 m"'))
    p = subprocess.run([sys.executable, "-m", "widesky.cli", "run", str(folder), "-o", str(tmp_path / "r")],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip().count("\n") == 0 and "sky.visibility" in p.stderr and "expected km" in p.stderr
    assert not (tmp_path / "r").exists()
    p = subprocess.run([sys.executable, "-m", "widesky.cli", "run", "no_such_case"], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 2 and "solar_potential" in p.stderr


def test_unwritable_report_folder_is_refused_before_the_run(tmp_path, folder):
    """A file where the report folder should go, or a parent that cannot hold it, is a one-line error
    before any computation (no "computed in" line), and nothing is left behind."""
    _write_case(folder, SMALL.format(extra=""))
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    before = sorted(x.name for x in tmp_path.iterdir())
    for out, words in ((blocker, "is a file"), (blocker / "r", "cannot write a report folder")):
        p = subprocess.run([sys.executable, "-m", "widesky.cli", "run", str(folder), "-o", str(out)],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 2, p.stderr
        assert words in p.stderr and "computed in" not in p.stderr
        assert p.stderr.strip().count("\n") == 0
    assert sorted(x.name for x in tmp_path.iterdir()) == before


def test_a_report_never_replaces_what_widesky_did_not_write(tmp_path, folder, small_report):
    """Issue 34's data loss: a non-empty folder without a report marker, the current directory and a folder above it
    are refused before the run, and the user's files stay; an earlier report (marker, or a pre-marker report's
    provenance.json) is replaced."""
    _write_case(folder, SMALL.format(extra=""))
    mine = tmp_path / "myfolder"
    mine.mkdir()
    (mine / "thesis.tex").write_text("precious")
    work = tmp_path / "work"
    work.mkdir()
    (work / "notes.txt").write_text("mine")
    for out, cwd, words in ((mine, tmp_path, "holds no widesky report"), (".", work, "is the current directory"),
                            (str(tmp_path), work, "is the current directory or holds it")):
        p = subprocess.run([sys.executable, "-m", "widesky.cli", "run", str(folder), "-o", str(out)], cwd=cwd,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 2, p.stderr
        assert words in p.stderr and "computed in" not in p.stderr and p.stderr.strip().count("\n") == 0
    assert (mine / "thesis.tex").read_text() == "precious" and (work / "notes.txt").read_text() == "mine"
    rep, _ = small_report
    assert cases.runner.is_report_folder(rep) and (rep / cases.runner.REPORT_MARKER).is_file()
    legacy = tmp_path / "legacy"
    legacy.mkdir()
    (legacy / "index.html").write_text("<html></html>")
    (legacy / "provenance.json").write_text('{"case": "x", "dataset_sha1": "0", "versions": {}}')
    assert cases.runner.is_report_folder(legacy) and not cases.runner.is_report_folder(mine)
    cases.runner._check_output(legacy)                  # an earlier report: accepted for replacement
    with pytest.raises(ValueError, match="holds no widesky report"):
        cases.runner._check_output(mine)


PV = SMALL.split("[sky]")[0].replace('start = "2024-06-20"\nend = "2024-06-22"',
                                     'start = "2024-06-30"\nend = "2024-07-02"') + """
[sky]
visibility = 40
albedo = 0.25
[scene]
geometry = "geometry.py"
two_sided = true
[scene.parameters]
rows = 2
row_length = 8.0
cell = 4.0
[pv]
technologies = ["topcon", "cdte"]
temp_air = "15 degC"
[report]
sky_time = "2024-07-01T10:00"
views = ["south-west"]
render_size = 200
"""


@pytest.fixture(scope="module")
def pv_report(tmp_path_factory):
    return _run_small(tmp_path_factory, "pv_plant", PV)[0]


def test_pv_technologies_are_validated(folder):
    with pytest.raises(ConfigError) as e:
        validate(cfg(pv__technologies=["topcon", "silicon"]), folder)
    assert "'silicon'" in str(e.value) and "perc" in str(e.value) and "cdte" in str(e.value)
    with pytest.raises(ConfigError, match=r"pv.temp_air = '15 K': unit 'K' is not valid here; expected degC"):
        validate(cfg(pv__temp_air="15 K"), folder)
    assert validate(cfg(), folder)["pv"] is None                   # optional section: irradiance only


def test_pv_report_energy_bookkeeping(pv_report):
    """The report's AC energy per technology is the time series' plant AC power summed over the hours;
    AC < DC (energies and specific yields); a technology without bifaciality (CdTe) gets no rear gain, the bifacial one does."""
    html = (pv_report / "index.html").read_text()
    assert "PV yield per technology" in html and "Loss waterfall" in html
    ts = pd.read_csv(pv_report / "timeseries.csv", index_col=0)
    from widesky import pvsim
    labels = {n: pvsim.get_technology(n).label for n in ("topcon", "cdte")}
    rows = re.findall(r"<tr><td>([^<]+)</td><td>([\d.]+)</td><td>([\d.]+)</td><td>([\d.]+)</td><td>([\d.]+)</td>"
                      r"<td>([\d.]+)</td><td>(\d)</td><td>([\d.]+)</td><td>([-+\d.]+)</td><td>([-+\d.]+)</td></tr>",
                      html)
    table = {r[0]: r for r in rows}
    for name, label in labels.items():
        r = table[label]
        e_ac = ts[f"plant:{name}:ac [W]"].sum() / 1e6                # 1 h steps -> MWh
        e_dc = ts[f"plant:{name}:dc [W]"].sum() / 1e6
        assert float(r[4]) == pytest.approx(e_ac, abs=0.006)
        assert float(r[3]) == pytest.approx(e_dc, abs=0.006) and e_ac < e_dc
        assert float(r[5]) == pytest.approx(e_ac * 1000 / float(r[2]), rel=2e-2)   # kWh/kWp (rounded kWp)
        assert float(r[7]) == pytest.approx(e_dc * 1000 / float(r[2]), rel=2e-2) and float(r[7]) > float(r[5])
    assert float(table[labels["cdte"]][9]) == 0.0 and float(table[labels["topcon"]][9]) > 1.0


def test_the_report_hour_is_checked_before_the_run(folder):
    """A report hour outside the period or at night is refused before any ray is cast."""
    _write_case(folder, SMALL.format(extra="").replace('sky_time = "2024-06-21T12:30"', 'sky_time = "2024-07-01T12:00"'))
    with pytest.raises(ConfigError, match=r"report.sky_time = 2024-07-01 12:00:00 is not inside the period"):
        cases.runner.compute(folder, n_jobs=1, progress=False)
    _write_case(folder, SMALL.format(extra="").replace('sky_time = "2024-06-21T12:30"', 'sky_time = "2024-06-21T01:00"'))
    with pytest.raises(ConfigError, match=r"the sun is below the horizon"):
        cases.runner.compute(folder, n_jobs=1, progress=False)


def test_a_mesh_file_is_one_group(tmp_path):
    import trimesh
    from widesky.cases.runner import build_geometry
    trimesh.creation.box((2, 2, 2)).export(tmp_path / "hut.obj")
    geo = build_geometry(tmp_path / "hut.obj", {})
    assert list(geo["analysis"]) == ["hut"] and geo["context"] == {}
    (tmp_path / "bad.py").write_text("def build(p):\n    return {'context': {}}\n")
    with pytest.raises(ConfigError, match=r"build\(\) must return"):
        build_geometry(tmp_path / "bad.py", {})


def test_compare_sites_are_validated(folder):
    ok = validate(cfg(compare__sites=[{"name": "Madrid", "latitude": 40.4, "longitude": -3.7, "tz": "Europe/Madrid"}]),
                  folder)
    assert ok["compare"]["sites"][0]["latitude"] == 40.4 and ok["compare"]["sites"][0]["altitude"] == 0.0
    with pytest.raises(ConfigError, match=r"compare.sites\[0\]: unknown key lat \(did you mean 'latitude'\?\)"):
        validate(cfg(compare__sites=[{"lat": 40.4, "longitude": -3.7}]), folder)
    with pytest.raises(ConfigError, match=r"compare.sites\[1\].latitude = 91 outside the valid range \[-90, 90\] deg"):
        validate(cfg(compare__sites=[{"latitude": 40, "longitude": 0}, {"latitude": 91, "longitude": 0}]), folder)
    with pytest.raises(ConfigError, match=r"compare.sites: expected a list of tables"):
        validate(cfg(compare__sites="Madrid"), folder)


def test_compare_sites_report(tmp_path_factory):
    """Two sites, two June days: a "Sites compared" table and sites.csv; the first site's column holds the
    specific yield of its own yield table (wiring), and the other site's differs."""
    toml = (SMALL.split("[sky]")[0].replace('title = "small"', 'title = "two sites"') + """
[compare]
sites = [{ name = "Helsinki", latitude = 60.17, longitude = 24.94, tz = "Europe/Helsinki" }]
[sky]
visibility = 40
[scene]
geometry = "geometry.py"
[scene.parameters]
row_length = 6.0
cell = 3.0
[pv]
technologies = ["topcon", "a_si"]
[report]
sky_time = "2024-06-21T12:00"
views = ["south-west"]
render_size = 160
""")
    rep, _ = _run_small(tmp_path_factory, "compare_sites", toml)
    sites = pd.read_csv(rep / "sites.csv", index_col=0)
    assert list(sites.columns) == ["50.08, 14.42", "Helsinki"]        # an unnamed site is named by its position
    html = (rep / "index.html").read_text()
    assert "Sites compared" in html
    # the first site's own yield table holds the same TOPCon value as sites.csv's Prague column
    from widesky import pvsim
    label = pvsim.get_technology("topcon").label
    m = re.search(rf"<tr><td>{re.escape(label)}</td>(?:<td>[^<]*</td>){{4}}<td>([\d.]+)</td>", html)
    assert m and float(m.group(1)) == pytest.approx(sites.loc[label, "50.08, 14.42"], abs=0.06)
    assert sites.loc[label, "50.08, 14.42"] != sites.loc[label, "Helsinki"]
    assert "sites-compared" in check_charts(rep)
    assert "60.170 N, 24.940 E" in html and "and 1 more site:" in html


# --- every chart of a report against the result file it shows ------------------------------------------------------

_MONTHS = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"]


def _step_hours(index):
    t = pd.to_datetime(pd.Series(index), utc=True)
    return float(t.diff().dropna().dt.total_seconds().median() / 3600.0) if len(t) > 1 else 1.0


def check_charts(rep):
    """Recompute every chart of report ``rep`` from the result files (``timeseries.csv``, ``spectral_hour.h5`` with
    ``faces.csv``, ``sites.csv``) and compare it with the numbers the chart plots (``charts.json``, from which the
    page's pictures are drawn). Tolerances: the CSV keeps 4 significant digits (sums to 0.2 %); the spectrum is read
    from the HDF5 file itself (1e-6). Every chart on the page must be checked here: an unknown chart id fails.
    Returns the ids checked."""
    import json

    import widesky.irradiance as ir
    from widesky import pvsim

    html = (rep / "index.html").read_text(encoding="utf-8")
    charts = json.loads((rep / "charts.json").read_text(encoding="utf-8"))["charts"]
    ids = [c["id"] for c in charts]
    assert sorted(re.findall(r'<figure class="chart" id="chart-([^"]+)"', html)) == sorted(ids)
    ts = pd.read_csv(rep / "timeseries.csv", index_col=0)
    h = _step_hours(ts.index)
    # a step's month and day are its interval's start's: the time column says whether the stamps are starts or
    # ends (a weather file's hours, stamped with their end: the hour stamped 1 Feb 00:00 is January's)
    assert ts.index.name in ("time (interval start)", "time (interval end)"), ts.index.name
    shift = pd.Timedelta(hours=h if ts.index.name == "time (interval end)" else 0.0)
    stamps = pd.Index([str(pd.Timestamp(s) - shift) for s in ts.index])
    month = np.array([int(s[5:7]) for s in stamps])
    local_day = np.array([s[:10] for s in stamps])
    faces = pd.read_csv(rep / "faces.csv", index_col=0)

    def close(got, want, rtol=2e-3, atol=None, what=""):
        got, want = np.asarray(got, float), np.asarray(want, float)
        scale = np.nanmax(np.abs(want)) if want.size else 1.0
        np.testing.assert_allclose(got, want, rtol=rtol, atol=atol if atol is not None else 1e-3 * scale,
                                   err_msg=f"{rep.name}: chart {what}")

    for c in charts:
        cid, series = c["id"], c["series"]
        assert series, cid
        if cid == "monthly-insolation":
            months = [_MONTHS.index(m) + 1 for m in c["categories"]]
            for lab, vals in series.items():
                col = ts[f"{lab}:poa_global [W m-2]"].to_numpy()
                close(vals, [col[month == m].sum() * h / 1000.0 for m in months], what=f"{cid} {lab}")
        elif cid == "daily-insolation":
            days = [d[:10] for d in c["x"]]
            for lab, vals in series.items():
                col = ts[f"{lab}:poa_global [W m-2]"].to_numpy()
                close(vals, [col[local_day == d].sum() * h / 1000.0 for d in days], what=f"{cid} {lab}")
        elif cid == "spectral-split":
            for lab, vals in series.items():
                total = ts[f"{lab}:poa_global [W m-2]"].sum()          # 0 for a floor: shares 0
                close(vals, [100 * ts[f"{lab}:{b} [W m-2]"].sum() / total if total > 0 else 0.0
                             for b in c["categories"]], rtol=3e-3,
                      atol=0.02, what=f"{cid} {lab}")
        elif cid == "hour-spectrum":
            hour = ir.POAResult.load(rep / "spectral_hour.h5")
            glob = np.asarray(hour.spectral["global"][0], float)             # (F, C) [W m-2 nm-1]
            close(c["x"], hour.wavelengths, rtol=1e-9, what=cid)
            area = faces["area_m2"].to_numpy()
            for lab, vals in series.items():
                sel = (faces["label"] == lab).to_numpy()
                close(vals, area[sel] @ glob[sel] / area[sel].sum(), rtol=1e-6, atol=1e-9, what=f"{cid} {lab}")
            start = str(pd.Timestamp(str(hour.times[0])) - shift)                     # the hour's start
            assert start[:16].replace(" ", "T") in c["title"].replace(" ", "T"), c["title"]
        elif cid == "pv-monthly-specific-yield":
            months = [_MONTHS.index(m) + 1 for m in c["categories"]]
            names = [k.split(":")[1] for k in ts.columns if k.startswith("plant:") and k.endswith(":ac [W]")]
            by_label = {pvsim.get_technology(n).label: n for n in names}
            for label, vals in series.items():
                # the rating the page's yield table gives (2 decimals)
                kwp = float(re.search(rf"<tr><td>{re.escape(label)}</td><td>[\d.]+</td><td>([\d.]+)</td>",
                                      html).group(1))
                col = ts[f"plant:{by_label[label]}:ac [W]"].to_numpy()
                close(vals, [col[month == m].sum() * h / 1000.0 / kwp for m in months], rtol=6e-3,
                      what=f"{cid} {label}")
        elif cid == "sites-compared":
            sites = pd.read_csv(rep / "sites.csv", index_col=0)
            assert list(sites.index.astype(str)) == c["categories"] and list(sites.columns) == list(series)
            for name, vals in series.items():
                close(vals, sites[name].to_numpy(), rtol=1e-4, what=f"{cid} {name}")
        elif cid == "window-gain":
            import tomllib
            frame = tomllib.loads((rep / "case.toml").read_text()).get("thermal", {}).get("frame_fraction", 0.0)
            for unit, vals in series.items():
                want = []
                for o in c["categories"]:
                    glass = faces.loc[faces["label"] == f"window {o}", "area_m2"].sum() * (1.0 - frame)
                    want.append(ts[f"{unit}:window gain {o} [W]"].sum() * h / 1000.0 / glass)
                close(vals, want, what=f"{cid} {unit}")
        elif cid == "facade-balance":                      # cases/report_thermal.py, per facade [MWh]
            unit, sign = c["meta"]["unit"], {"long-wave loss": -1.0}
            for part, vals in series.items():
                close(vals, [sign.get(part, 1.0) * ts[f"{unit}:{part} {f} [W]"].sum() * h / 1e6
                             for f in c["categories"]], what=f"{cid} {part}")
        elif cid == "spectral-rated":
            months = [_MONTHS.index(m) + 1 for m in c["categories"]]
            for unit, vals in series.items():
                sp, ra = (ts[f"{unit}:window gain unshaded {r} [W]"].to_numpy() for r in ("spectral", "rated"))
                # the CSV's 4 digits per step: 0.05 percentage points on a monthly sum
                close(vals, [100 * (sp[month == m].sum() - ra[month == m].sum()) / ra[month == m].sum()
                             for m in months], rtol=0, atol=0.05, what=f"{cid} {unit}")
        elif cid == "loads-monthly":
            months = [_MONTHS.index(m) + 1 for m in c["categories"]]
            for name, vals in series.items():
                unit, load = name.rsplit(" ", 1)
                col = ts[f"{unit}:{load} [W]"].to_numpy()
                close(vals, [col[month == m].sum() * h / 1e6 for m in months], what=f"{cid} {name}")
        elif cid == "cooling-load":
            assert [x[:16] for x in c["x"]] == [s[:16].replace(" ", "T") for s in ts.index.astype(str)]   # labels
            for unit, vals in series.items():
                close(vals, ts[f"{unit}:cooling [W]"].to_numpy() / 1000.0, what=f"{cid} {unit}")
        elif cid == "cooling-daily":
            days = [d[:10] for d in c["x"]]
            for unit, vals in series.items():
                col = ts[f"{unit}:cooling [W]"].to_numpy()
                close(vals, [col[local_day == d].sum() * h / 1000.0 for d in days], what=f"{cid} {unit}")
        else:
            raise AssertionError(f"chart {cid!r} of {rep}: no check recomputes it from its result file")
    return ids


def test_every_chart_shows_its_result_file(small_report, pv_report):
    """Issue 40: the spectrum chart plotted twice the spectral_hour.h5 global spectrum (the global added to its own
    parts). Each chart of the irradiance and PV reports is recomputed from the files it claims to show."""
    assert {"daily-insolation", "spectral-split", "hour-spectrum"} <= set(check_charts(small_report[0]))
    assert {"monthly-insolation", "pv-monthly-specific-yield", "hour-spectrum"} <= set(check_charts(pv_report))


def test_report_first_screen_and_labels(pv_report, small_report):
    """The first screen names the site, the weather source, the sky model, the period and the energy and specific
    yield per technology (from the yield table), and what the figures are not; positions carry hemisphere letters;
    the inverter's clipping is its own waterfall stage."""
    html = (pv_report / "index.html").read_text(encoding="utf-8")
    glance = html[html.index('<div class="glance">'):html.index("</div>", html.index('<div class="glance">'))]
    assert html.index('<div class="glance">') < html.index("<h2>Run</h2>")
    for words in ("site", "weather source", "sky model", "period", "PV energy (AC)", "what it is not",
                  "50.080 N, 14.420 E", "clear sky", "upper bound", "2024-06-30 to 2024-07-02"):
        assert words in glance, words
    from widesky import pvsim
    for n in ("topcon", "cdte"):
        label = pvsim.get_technology(n).label
        row = re.search(rf"<tr><td>{re.escape(label)}</td>(?:<td>[^<]*</td>){{4}}<td>([\d.]+)</td>", html)
        shown = re.search(rf"{re.escape(label)}: <b>[\d.]+ MWh</b>, <b>([\d.]+) kWh/kWp</b>", glance)
        assert float(shown.group(1)) == pytest.approx(float(row.group(1)), abs=0.051)
    assert "AC before clipping (inverter efficiency)" in html and "AC (after inverter clipping)" in html
    assert " 1 groups" not in (small_report[0] / "index.html").read_text(encoding="utf-8")
    from widesky.cases.report import format_position
    assert format_position(40.42, -3.7) == "40.420 N, 3.700 W"
    assert format_position(-33.9, 151.2) == "33.900 S, 151.200 E"


def test_waterfall_splits_inverter_efficiency_and_clipping(pv_report):
    """The waterfall's "AC before clipping" stage is the PVWatts inverter's efficiency curve (Dobos 2014,
    NREL/TP-6A20-62641: eta = eta_nom / eta_ref (-0.0162 z - 0.0059 / z + 0.9858), z = P_dc / P_dc0, P_dc0 = rating /
    DC-AC ratio 1.2; pvsim's defaults eta_nom 0.96, eta_ref 0.9637) applied to the plant's DC without the AC limit,
    recomputed here from timeseries.csv (one inverter per module row of equal rating: the rows' DC taken equal, a
    second-order difference); the "AC" stage is the time series' AC; clipping can only lose. Tolerance 1 %: the table's
    one decimal on a two-day yield of about 14 kWh/kWp."""
    html = (pv_report / "index.html").read_text(encoding="utf-8")
    ts = pd.read_csv(pv_report / "timeseries.csv", index_col=0)
    from widesky import pvsim
    wf = html[html.index("Loss waterfall"):]

    def stage(name):
        m = re.search(rf"<tr><td>{re.escape(name)}</td>((?:<td>[^<]*</td>)+)</tr>", wf)
        return [float(v) for v in re.findall(r"<td>([-+\d.]+)</td>", m.group(1))[::2]]

    dc_row, inv_row, ac_row = (stage("DC (after DC losses)"), stage("AC before clipping (inverter efficiency)"),
                               stage("AC (after inverter clipping)"))
    for i, n in enumerate(("topcon", "cdte")):
        label = pvsim.get_technology(n).label
        kwp = float(re.search(rf"<tr><td>{re.escape(label)}</td><td>[\d.]+</td><td>([\d.]+)</td>", html).group(1))
        rows = 2                                                           # PV's [scene.parameters] rows
        p = ts[f"plant:{n}:dc [W]"].to_numpy() / rows                      # per row [W]
        p0 = kwp * 1000.0 / rows / 1.2
        z = np.where(p > 0, p / p0, 1.0)
        eta = 0.96 / 0.9637 * (-0.0162 * z - 0.0059 / z + 0.9858)
        unclipped = rows * np.where(p > 0, np.maximum(eta * p, 0.0), 0.0).sum() / 1000.0 / kwp     # 1 h steps
        assert inv_row[i] == pytest.approx(unclipped, rel=1e-2)
        assert ac_row[i] == pytest.approx(ts[f"plant:{n}:ac [W]"].sum() / 1000.0 / kwp, rel=1e-2)
        assert dc_row[i] > inv_row[i] >= ac_row[i]


def test_renders_scale_front_and_rear_apart(pv_report):
    """Issue 40: front and rear sides have their own colour range, so the front sides span the whole front colour map
    (the rear sides' much lower insolation no longer squeezes them into its top); a two-sided scene gets a render of
    the rear sides; the sky picture is larger than 256 px."""
    import base64
    import io

    import matplotlib
    import trimesh
    from PIL import Image

    faces = pd.read_csv(pv_report / "faces.csv", index_col=0)
    front = faces[faces.label.str.endswith(" front")].insolation_kwh_m2
    ply = trimesh.load(pv_report / "scene.ply", process=False)
    cols = ply.visual.face_colors[:, :3].astype(float) / 255.0
    viridis = matplotlib.colormaps["viridis"]
    coloured = cols[~np.all(np.isclose(cols, cols[:, :1], atol=0.01), axis=1)]          # not the grey context
    # the darkest and brightest front colours are the map's ends: the front range is the front faces' own
    for t in (0.0, 1.0):
        assert np.min(np.abs(coloured - np.asarray(viridis(t)[:3])).sum(axis=1)) < 0.02, t
    assert front.max() - front.min() < 0.5 * front.min()            # (the fronts' spread is small against the rears)
    assert (pv_report / "scene_rear.png").is_file()
    html = (pv_report / "index.html").read_text(encoding="utf-8")
    sky = re.search(r'<img class="sky" src="data:image/png;base64,([^"]+)"', html).group(1)
    assert Image.open(io.BytesIO(base64.b64decode(sky))).size[0] > 512
    with Image.open(pv_report / "sky.png") as im:
        assert im.size[0] > 256
