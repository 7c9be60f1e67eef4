"""The yield model fused into the integrator's stream (``simulate``, pvsim.stream) against the unfused
path: the POA run with every response's three parts (the per-part products) saved, then ``pv_yield``
reading it back in float64 (what ``simulate`` did before the fusion).

Tolerance: the fused run differs by float32 rounding only -- the fused sky + reflected product (sums
of about 200 float32 terms, relative 1e-6) and the kernel's float32 per-face arithmetic with double
sums (a few float32 roundings per value) -- so every series column and waterfall stage agrees to
rtol 1e-5 (absolute floor 1e-6 of the column's maximum).
"""

import numpy as np
import pandas as pd
import pytest
import trimesh

from widesky import pvsim
from widesky.irradiance import RunOptions, SkyStates, make_scene, poa_irradiance
from widesky.irradiance.skies import AnalyticSky
from widesky.pvsim.stream import simulate
from widesky.pvsim.system import SystemSpec, pv_yield, technology_responses

TECHS = ["perc", "shj", "cdte", "a_si", "perovskite", "tandem_2t", "tandem_4t"]


def _quad(tilt, azimuth, centre, size=1.0, n=2):
    t, a = np.radians(tilt), np.radians(azimuth)
    nrm = np.array([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), np.cos(t)])
    u = np.cross([0, 0, 1.0], nrm)
    u /= np.linalg.norm(u)
    v = np.cross(nrm, u)
    g = np.linspace(-size / 2, size / 2, n + 1)
    pts = np.array([np.asarray(centre) + x * u + y * v for y in g for x in g])
    faces = []
    for i in range(n):
        for j in range(n):
            p = i * (n + 1) + j
            faces += [[p, p + 1, p + n + 2], [p, p + n + 2, p + n + 1]]
    return trimesh.Trimesh(pts, faces, process=False)


@pytest.fixture(scope="module")
def runs():
    times = pd.date_range("2021-06-21 03:00", periods=12, freq="90min", tz="Europe/Prague")
    el = np.array([-6, -1, 9, 22, 38, 52, 60, 55, 41, 26, 12, 1.0])
    states = SkyStates.create(el, np.linspace(50, 310, 12), 40.0, 0.2, times=times)
    # a two-sided roof (bifacial rear), a wall in another group and an occluder that shades the roof
    scene = make_scene([_quad(30, 180, (0, 0, 0), 2.0), _quad(90, 90, (3, 0, 0.5))], [trimesh.creation.box(
        (0.6, 0.6, 2.0)).apply_translation((0.0, -1.6, 0.5))], groups=["roof", "wall"], ground_z=-1.0,
        two_sided=True)
    temp = np.linspace(12, 31, 12)
    wind = np.linspace(0.3, 5, 12)
    sky = AnalyticSky()
    resp, src = technology_responses(TECHS)
    full = poa_irradiance(scene, sky, states, responses=resp, run=RunOptions(n_jobs=1))
    out = {}
    for model in ("faiman", "pvsyst"):
        spec = SystemSpec(temperature_model=model)
        ref = pv_yield(full, TECHS, temp, wind, sources=src, system=spec)
        res, fused = simulate(scene, sky, states, TECHS, temp, wind, system=spec,
                              keep_currents=model == "pvsyst", run=RunOptions(n_jobs=1))
        out[model] = (ref, fused, res)
    return out


@pytest.mark.parametrize("model", ["faiman", "pvsyst"])
def test_fused_yield_equals_the_unfused_path(runs, model):
    ref, fused, _ = runs[model]
    assert fused.groups == ref.groups
    for name in TECHS:
        a, b = ref.technologies[name], fused.technologies[name]
        for g in ref.groups:
            sa, sb = a.series[g], b.series[g]
            assert list(sa.columns) == list(sb.columns)
            for col in sa.columns:
                x, y = sa[col].to_numpy(float), sb[col].to_numpy(float)
                np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=f"{name} {g} {col}")
                ok = np.isfinite(x)
                np.testing.assert_allclose(y[ok], x[ok], rtol=1e-5,
                                           atol=1e-6 * max(np.abs(x[ok]).max(initial=0), 1e-12),
                                           err_msg=f"{name} {g} {col}")
            for stage, v in a.waterfall[g].items():
                assert b.waterfall[g][stage] == pytest.approx(v, rel=1e-5, abs=1e-9), (name, g, stage)
            assert b.current_mismatch_loss[g] == pytest.approx(a.current_mismatch_loss[g], rel=1e-4, abs=1e-9)
            assert b.specific_yield(g) == pytest.approx(a.specific_yield(g), rel=1e-5)
    # the comparison is not vacuous: light, a rear gain, shading and a 2T mismatch
    s = ref.technologies["perc"].series["roof"]
    assert s["poa_global"].max() > 300
    assert (s["effective_irradiance"] - s["effective_irradiance_front"]).max() > 1
    w = ref.technologies["perc"].waterfall["roof"]
    assert w["unshaded"] > w["poa"] * 1.001
    assert ref.technologies["tandem_2t"].current_mismatch_loss["roof"] > 0


def test_currents_kept_only_when_asked(runs):
    res_kept, res_not = runs["pvsyst"][2], runs["faiman"][2]
    assert "perc" in res_kept.responses and "perc" not in res_not.responses
    assert set(res_not.responses) == {"broadband", "cover"}
    assert res_not.stored_parts["cover"] == ("global",) and res_kept.available_parts("cover")[0] == "direct"
    # the kept currents re-read by pv_yield give the fused numbers
    again = pv_yield(res_kept, TECHS, np.linspace(12, 31, 12), np.linspace(0.3, 5, 12),
                     system=SystemSpec(temperature_model="pvsyst"))
    fused = runs["pvsyst"][1]
    for name in TECHS:
        assert again.technologies[name].specific_yield("roof") == pytest.approx(
            fused.technologies[name].specific_yield("roof"), rel=1e-5)
    with pytest.raises(ValueError, match="lacks response"):
        pv_yield(res_not, ["perc"])
