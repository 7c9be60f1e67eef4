"""Building input (labels, generator, errors), per-surface gains and zone loads, and the
integrator wiring of glazing as a spectral-angular Response."""

import numpy as np
import pandas as pd
import pytest

from widesky.thermal.building import ZoneSpec, box_building, building_from_meshes, parse_label
from widesky.thermal.glazing import Gap, GlazingUnit, layer_from_broadband
from widesky.thermal.loads import Construction, building_loads, opaque_gains, window_gains, zone_parameters
from widesky.thermal.surface import surface_irradiance

GLASS = layer_from_broadband("clear", 0.834, 0.075, 0.075, 3.048)
UNIT = GlazingUnit("dbl", [GLASS, GLASS], [Gap(12.0)])
CONS = {"wall": Construction("wall", 0.3), "roof": Construction("roof", 0.2),
        "floor": Construction("floor", 0.3, b=0.5), "window": Construction("window", glazing=UNIT)}


def test_generator_areas_and_orientations():
    b = box_building(20, 12, 3.5, floors=2, wwr={"south": 0.4, "north": 0.2}, overhang=1.0, fins=0.5)
    assert len(b.zones) == 8
    win = {s.zone: s for s in b.surfaces_of("window")}
    assert win["f0_south"].area == pytest.approx(0.4 * 20 * 3.5)
    assert win["f1_north"].azimuth == pytest.approx(0.0) and win["f0_south"].azimuth == pytest.approx(180)
    walls = b.surfaces_of("wall", "f0_south")
    assert sum(s.area for s in walls) + win["f0_south"].area == pytest.approx(20 * 3.5)
    assert {s.kind for s in b.surfaces} == {"wall", "window", "roof", "floor", "shading"}
    assert b.zones["f0_east"].floor_area == pytest.approx(20 * 12 / 4)
    r = box_building(rotation=90.0, wwr={"south": 0.3}, perimeter_zones=False)
    assert r.surfaces_of("window")[0].azimuth == pytest.approx(270.0)


def test_label_errors():
    with pytest.raises(ValueError, match="kind 'door'"):
        parse_label("door:z1:c")
    with pytest.raises(ValueError, match="expected 'kind:zone:construction'"):
        parse_label("wall-z1")
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1], [0, 5, 0], [1, 5, 0], [1, 5, 1.0]])
    f = np.array([[0, 1, 2], [0, 2, 3], [4, 6, 5]])
    with pytest.raises(ValueError, match="window 'window:z1:w' lies on no wall"):
        building_from_meshes(v, f, ["wall:z1:c", "wall:z1:c", "window:z1:w"])
    with pytest.raises(ValueError, match="zone 'z2' has no surfaces"):
        building_from_meshes(v, f[:2], ["wall:z1:c"] * 2, zones=[ZoneSpec("z2")])
    with pytest.raises(ValueError, match="zone 'z1' has no wall or roof"):
        building_from_meshes(v, f[:2], ["floor:z1:c"] * 2)
    with pytest.raises(ValueError, match="wwr"):
        box_building(wwr={"up": 0.3})


def test_zone_parameters_by_hand():
    b = box_building(10, 10, 3.0, wwr=0.25, perimeter_zones=False)
    p = zone_parameters(b, CONS, "heavy")
    u_w = UNIT.u_value()
    assert p.h_tr_w[0] == pytest.approx(u_w * 0.25 * 4 * 30)
    assert p.h_tr_op[0] == pytest.approx(0.3 * 0.75 * 120 + 0.2 * 100 + 0.5 * 0.3 * 100)
    assert p.heat_capacity[0] == pytest.approx(260000 * 100)
    with pytest.raises(ValueError, match="construction 'wall'"):
        zone_parameters(b, {"roof": CONS["roof"]})


def test_rotation_symmetry_without_sun():
    """A symmetric building (same WWR all round, one zone per floor) under a sunless sky: the
    loads do not change when it is rotated."""
    T = 24 * 20
    times = pd.date_range("2021-01-01", periods=T, freq="h", tz="UTC")
    ta = 5 + 5 * np.sin(np.arange(T) / 24 * 2 * np.pi)
    out = []
    for rot in (0.0, 37.0, 90.0):
        b = box_building(12, 12, 3.0, wwr=0.3, perimeter_zones=False, rotation=rot,
                         zone_use=ZoneSpec("u", internal_gains=500.0))
        surf = [s for s in b.surfaces if s.kind != "shading"]
        irr = surface_irradiance([s.tilt for s in surf], [s.azimuth for s in surf],
                                 np.full(T, 60.0), np.linspace(100, 260, T), np.zeros(T),
                                 np.full(T, 120.0), np.full(T, 120.0), np.full(T, 1361.0),
                                 transposition="hay-davies")       # isotropic without beam
        r = building_loads(b, CONS, times, ta, irr, temp_sky=ta - 15)
        out.append(r.summary().loc["total", ["heating_kWh", "cooling_kWh", "solar_kWh"]].astype(float))
    for o in out[1:]:
        assert o.to_numpy() == pytest.approx(out[0].to_numpy(), rel=1e-9)


def test_zero_solar_limit_and_gain_formulas():
    b = box_building(10, 8, 3.0, wwr=0.3, perimeter_zones=False)
    surf = [s for s in b.surfaces if s.kind != "shading"]
    T = 48
    times = pd.date_range("2021-01-01", periods=T, freq="h", tz="UTC")
    zero = {k: np.zeros((T, len(surf))) for k in ("poa_direct", "poa_sky_diffuse",
                                                   "poa_ground_diffuse")}
    zero["aoi"] = np.full((T, len(surf)), 90.0)
    r = building_loads(b, CONS, times, np.full(T, 0.0), zero)
    assert r.zone_solar.to_numpy().max() == 0.0
    # ISO 13790 opaque share and the window's g at normal incidence, by hand
    assert opaque_gains(10.0, 0.5, 0.6, 500.0) == pytest.approx(0.6 * 0.04 * 0.5 * 10 * 500)
    o = UNIT.optics([0.0], [1000.0])
    g = window_gains([2.0], [[400.0]], [[0.0]], [[0.0]], [0.0, 90.0], [o["shgc"][0, 0], 0.0], 0.0)
    assert g[0, 0] == pytest.approx(2.0 * 400.0 * o["shgc"][0, 0])


def test_shading_kept_up_while_the_zone_heats():
    """A January fortnight, sunny days at -5 to 5 degC: blinds requested on every sunlit window in the day. With the
    rule "solar-not-heating" each window's blinds are down exactly where requested and its zone did not heat in the
    previous hour; the transmitted gains follow that state; the energy balance still closes; and the heating lies
    between that with the blinds down wherever requested and that with no blinds (more of the sun's heat kept)."""
    T = 24 * 14
    times = pd.date_range("2021-01-04", periods=T, freq="h", tz="UTC")
    hour = np.arange(T) % 24
    b = box_building(20, 12, 3.5, wwr=0.4, zone_use=ZoneSpec("u", internal_gains=2000.0))
    surf = [s for s in b.surfaces if s.kind != "shading"]
    el = np.clip(30.0 * np.sin(np.pi * (hour - 6) / 12), -10, None)
    irr = surface_irradiance([s.tilt for s in surf], [s.azimuth for s in surf], 90.0 - el,
                             90.0 + 180.0 * np.clip((hour - 6) / 12, 0, 1), np.where(el > 0, 800.0, 0.0),
                             np.where(el > 0, 80.0, 0.0), np.where(el > 0, 800.0 * np.sin(np.radians(el)) + 80, 0),
                             np.full(T, 1361.0), transposition="hay-davies")
    ta = 5.0 * np.cos(2 * np.pi * (hour - 15) / 24)
    wins = [j for j, s in enumerate(surf) if s.kind == "window"]
    glob = (irr["poa_direct"] + irr["poa_sky_diffuse"] + irr["poa_ground_diffuse"])[:, wins]
    shade = np.where((glob > 200.0) & ((hour >= 8) & (hour < 18))[:, None], 0.15, 1.0)
    run = {rule: building_loads(b, CONS, times, ta, irr, shading=shade, shading_rule=rule)
           for rule in ("solar", "solar-not-heating")}
    none = building_loads(b, CONS, times, ta, irr)
    r = run["solar-not-heating"]
    state = r.shading_state.to_numpy()
    heated = r.heating[[surf[j].zone for j in wins]].to_numpy() > 0
    want = (shade < 1)
    want[1:] &= ~heated[:-1]
    np.testing.assert_array_equal(state, want)
    assert state.any() and (state != (shade < 1)).any()
    assert np.array_equal(run["solar"].shading_state.to_numpy(), shade < 1)
    bare = none.parts["transmitted"].to_numpy()[:, wins]
    np.testing.assert_allclose(r.parts["transmitted"].to_numpy()[:, wins], bare * np.where(state, shade, 1.0),
                               rtol=1e-12)
    bal = r.balance()
    assert abs(bal.loc["total", "residual"]) < 1e-6 * (bal.loc["total", "heating"] + bal.loc["total", "internal"])
    h = {k: v.heating.to_numpy().sum() for k, v in {**run, "none": none}.items()}
    assert h["none"] < h["solar-not-heating"] < h["solar"], h
    with pytest.raises(ValueError, match="shading_rule='night' not one of"):
        building_loads(b, CONS, times, ta, irr, shading=shade, shading_rule="night")


@pytest.mark.slow
def test_glazing_response_through_integrator():
    """The integrator with the glazing as a SpectralAngularTable under a uniform (isotropic,
    spectrally flat) sky: the gain per m2 of glass on an unobstructed vertical window is the
    hemispherical g times the sky irradiance (the ground reflects the same radiance), within the
    integrator's sky quadrature (1 %)."""
    import widesky.irradiance as irr
    from widesky.thermal.gains import building_scene, glazing_response, window_gain_by_surface
    b = box_building(6, 6, 3.0, wwr={"south": 0.4}, perimeter_zones=False)
    scene, labels = building_scene(b, ground_albedo=1.0, analysis_reflectance=0.0)
    sky = irr.UniformSky(radiance=1.0)
    states = irr.SkyStates.create([-10.0, -10.0], [180.0, 180.0], 50.0, 1.0)
    cons = {"window": Construction("window", glazing=UNIT)}
    res = irr.poa_irradiance(scene, sky, states, responses=[glazing_response(UNIT, "window:spectral")],
                             run=irr.RunOptions(n_jobs=1))
    wg = window_gain_by_surface(res, labels, b, cons, "spectral")
    gd = UNIT.hemispherical("shgc", [1000.0])[0]
    j = labels.index(b.surfaces_of("window")[0].label)
    e = res.get("broadband", "global")[:, res.faces.group == j].mean()
    assert wg[0, 0] == pytest.approx(gd * e, rel=0.01)
