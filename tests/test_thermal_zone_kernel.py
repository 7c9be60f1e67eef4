"""The compiled ISO 52016-1 step loop (thermal/_iso52016.c) against the numpy loop it replaces.

The two solve the same equations each step: numpy.linalg.solve on the zone's whole node matrix, and the kernel's
sweep along each element's chain of nodes followed by a dense solve on the air and the inside surfaces. A year of
steps of a zone with every kind of element (layered walls, a roof, an unexposed floor, windows whose gaps conduct
at their own temperature), set-points that switch between heating, cooling and free floating, and each inside
convection model must agree to rounding: 1e-9 K and 1e-6 W (the loads are a few kW), far below anything a figure
shows, while a wrong coefficient or a wrong sweep moves them by 1e-3 or more (the perturbation test below).
"""

import numpy as np
import pytest

from widesky.thermal import zone_iso52016
from widesky.thermal.zone_iso52016 import CONVECTION, Element, Layer, simulate_iso52016


def _zone():
    wall = (Layer(0.012, 0.16, 840.0, 950.0), Layer(0.066, 0.04, 840.0, 12.0), Layer(0.1, 1.13, 1000.0, 1400.0))
    return [Element("north", "wall", 21.6, 90.0, wall),
            Element("south", "wall", 9.6, 90.0, wall),
            Element("roof", "roof", 48.0, 0.0, (Layer(0.019, 0.14, 900.0, 530.0), Layer(0.1118, 0.04, 840.0, 12.0))),
            Element("floor", "floor", 48.0, 180.0, (Layer(0.08, 1.13, 1000.0, 1400.0), Layer(1.007, 0.04, 0.0, 0.0)),
                    exposed=False),
            Element("glass", "window", 12.0, 90.0, resistance=0.006, gaps=((2.08, 0.724),), height=2.0),
            Element("skylight", "window", 2.0, 0.0, resistance=0.3, height=1.0)]


def _inputs(T=24 * 60, seed=3):
    rng = np.random.default_rng(seed)
    h = np.arange(T)
    te = 5.0 + 12.0 * np.sin(2 * np.pi * (h - 9) / 24.0) + rng.normal(0.0, 1.0, T)
    sun = np.maximum(0.0, np.sin(2 * np.pi * (h - 6) / 24.0))
    return dict(temp_air_out=te, temp_sky=te - 15.0, h_ce=8.0 + 3.0 * rng.random(T), h_re=4.5,
                solar_out=np.outer(600.0 * sun, [0.3, 1.0, 1.0, 0.0, 0.0, 0.0]), solar_in=2500.0 * sun,
                phi_int=200.0, h_ve=20.0 + 150.0 * (sun == 0), heating_setpoint=np.where(h % 24 < 7, 10.0, 20.0),
                cooling_setpoint=np.where(h % 48 < 24, 25.0, 1e9), volume=129.6, air_pressure=83000.0,
                warmup_steps=24 * 5, temp_start=15.0)


def _close(a, b):
    for k in ("temp_air", "temp_surface"):
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-9, err_msg=k)
    for k in ("heating", "cooling"):
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-6, err_msg=k)


@pytest.mark.parametrize("convection", CONVECTION)
def test_kernel_equals_the_numpy_loop(convection):
    """Every inside convection model, the ISO 52016-1 long-wave star and the rooms' view factors, hourly and in
    4 sub-steps: the kernel's loads and temperatures are the numpy loop's to 1e-9 K and 1e-6 W, with heating,
    cooling and free-floating hours all present."""
    els, kw = _zone(), _inputs()
    area = np.array([e.area for e in els])
    # view-factor-like exchange: symmetric conductances A_i A_j h / A_tot between different surfaces, rows sum 0
    view = -5.13 * np.outer(area, area) / area.sum()
    np.fill_diagonal(view, 0.0)
    view -= np.diag(view.sum(1))
    for extra in ({}, {"substeps": 4}, {"longwave": view}):
        args = {**kw, **extra}
        fast = simulate_iso52016(els, convection=convection, **args)
        ref = simulate_iso52016(els, convection=convection, engine="python", **args)
        _close(fast, ref)
        assert (ref["heating"] > 0).any() and (ref["cooling"] > 0).any()
        assert ((ref["heating"] == 0) & (ref["cooling"] == 0)).any()


def test_kernel_runs_where_it_applies(monkeypatch):
    """``engine="auto"`` calls the kernel for the default options and the numpy loop where the kernel does not
    apply (``iterate``, EnergyPlus's outside long-wave); a perturbed input moves the result beyond the tolerance
    the equality test uses (so that test can fail)."""
    calls = []
    real = zone_iso52016._iso52016.run
    monkeypatch.setattr(zone_iso52016._iso52016, "run", lambda *a: calls.append(1) or real(*a))
    els, kw = _zone(), _inputs(T=24 * 10)
    base = simulate_iso52016(els, convection="tarp-iso15099", **kw)
    assert len(calls) == 1
    simulate_iso52016(els, convection="tarp-iso15099", iterate=2, **kw)
    simulate_iso52016(els, exterior_longwave="energyplus", **kw)
    assert len(calls) == 1
    moved = simulate_iso52016(els, convection="tarp-iso15099", **{**kw, "phi_int": 200.001})
    assert np.abs(moved["temp_air"] - base["temp_air"]).max() > 1e-7
    with pytest.raises(ValueError, match="engine="):
        simulate_iso52016(els, engine="fortran", **kw)
    te = kw["temp_air_out"].copy()
    te[30] = np.nan
    with pytest.raises(ValueError, match="temp_air_out is not finite at 1 step.*index 30"):
        simulate_iso52016(els, **{**kw, "temp_air_out": te})
    with pytest.raises(ValueError, match="at least one Element"):
        simulate_iso52016([], **{**kw, "solar_out": np.zeros((len(kw["solar_in"]), 0))})


def test_chain_pattern_check():
    """The kernel takes a matrix whose elements couple only along their chains and through the air and the inside
    surfaces; anything else (here a coupling between two elements' middle nodes) is left to the numpy loop."""
    outside, inside = np.array([1, 4]), np.array([3, 5])
    base = np.eye(6) * 10.0
    for a, b in ((1, 2), (2, 3), (4, 5), (0, 3), (0, 5), (3, 5)):
        base[a, b] = base[b, a] = -1.0
    assert zone_iso52016._chains_only(base, outside, inside)
    bad = base.copy()
    bad[2, 4] = bad[4, 2] = -0.5
    assert not zone_iso52016._chains_only(bad, outside, inside)
    skew = base.copy()
    skew[1, 2] = -2.0
    assert not zone_iso52016._chains_only(skew, outside, inside)
