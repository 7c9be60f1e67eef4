"""Thin-film optics of the solar-control coating: analytic single-film and Drude limits, energy
balance and reciprocity, a bare stack reproducing the substrate, and the coated unit's spectral
selectivity."""

import numpy as np
import pytest

from widesky.thermal.thinfilm import (DOUBLE_SILVER, SILVER_ORDAL, Film, coated_layer_from_stack,
                              drude_index, stack_optics)


def test_quarter_wave_film_analytic():
    """A quarter-wave film of index n1 between n0 and ns reflects ((n0 ns - n1^2)/(n0 ns + n1^2))^2
    at its design wavelength; a half-wave film is absent (R of the bare interface)."""
    n0, n1, ns, wl = 1.0, 1.38, 1.52, 550.0
    T, R, R2 = stack_optics([Film(n1, wl / 4 / n1)], [wl], n0, ns)
    assert R[0] == pytest.approx(((n0 * ns - n1 ** 2) / (n0 * ns + n1 ** 2)) ** 2, rel=1e-12)
    assert T[0] + R[0] == pytest.approx(1.0, abs=1e-12) and R2[0] == pytest.approx(R[0], rel=1e-12)
    _, Rh, _ = stack_optics([Film(2.0, wl / 2 / 2.0)], [wl], n0, ns)
    assert Rh[0] == pytest.approx(((ns - n0) / (ns + n0)) ** 2, rel=1e-12)


def test_drude_identity_ordal():
    """Ordal et al. 1983: at the damping frequency, -eps1 = eps2 = wp^2 / (2 w_tau^2) exactly for
    the Drude form with eps_inf = 0 (with eps_inf = 1, eps1 is shifted by 1)."""
    wp, wt = SILVER_ORDAL["plasma_cm"], SILVER_ORDAL["damping_cm"]
    n = drude_index([1e7 / wt], wp, wt, eps_inf=0.0)[0]
    eps = n ** 2
    assert -eps.real == pytest.approx(wp ** 2 / (2 * wt ** 2), rel=1e-9)
    assert eps.imag == pytest.approx(wp ** 2 / (2 * wt ** 2), rel=1e-9)
    assert n.imag > 0


def test_silver_stack_balance_and_reciprocity():
    wl = np.linspace(300.0, 2500.0, 45)
    T, R, R2 = stack_optics(DOUBLE_SILVER, wl, 1.0, 1.52)
    Tb, Rb, _ = stack_optics(list(reversed(DOUBLE_SILVER)), wl, 1.52, 1.0)
    assert T == pytest.approx(Tb, abs=1e-12)                     # reciprocity
    assert Rb == pytest.approx(R2, abs=1e-12)
    assert np.all(T + R <= 1 + 1e-12) and np.all(T + R2 <= 1 + 1e-12)
    assert np.all(1 - T - R > 0)                                  # the silver absorbs


def test_bare_stack_reproduces_the_substrate():
    """Films of zero thickness: the coated layer's T and R equal the uncoated pane's (its n, k are
    inverted from T and the mean of the file's Rf and Rb, which differ by up to 0.002)."""
    from widesky.core.paths import runtime_file
    from widesky.thermal.glazing import read_igdb
    c6 = read_igdb(runtime_file("glazing/CLEAR_6.DAT"))
    bare = coated_layer_from_stack("bare", [Film(2.0, 0.0), Film("silver", 0.0)], c6)
    assert bare.T == pytest.approx(c6.T, abs=1e-9)
    r = 0.5 * (c6.Rf + c6.Rb)
    assert bare.Rf == pytest.approx(r, abs=1e-9) and bare.Rb == pytest.approx(r, abs=1e-9)


def test_solar_control_unit_is_spectrally_selective():
    """The double-silver unit passes the visible and rejects the near infrared: T > 0.4 over
    450-650 nm, < 0.05 beyond 1200 nm, g_n (AM1.5) < 0.40 with visible transmittance (380-780 nm,
    AM1.5 weighted) above 1.25 g (the US DOE definition of spectrally selective glazing, light-to-
    solar-gain ratio >= 1.25, with AM1.5 weighting standing in for the photopic curve), U < 1.3
    W m-2 K-1 with argon (coating emissivity < 0.08)."""
    from widesky.thermal.glazing import read_solar_spectrum, solar_weighted
    from widesky.thermal.study import standard_units
    u = standard_units(solar_control=True)["solar-control"]
    wl, e = read_solar_spectrum()
    o = u.optics([0.0], wl)
    t = o["transmittance"][0]
    vis = (wl >= 450) & (wl <= 650)
    assert t[vis].min() > 0.4 and t[wl >= 1200].max() < 0.05
    g = u.rated(wl, e)["shgc"]
    v = (wl >= 380) & (wl <= 780)
    t_vis = solar_weighted(wl[v], t[v], e[v])
    assert g < 0.40 and t_vis / g > 1.25
    assert u.layers[0].emissivity_back < 0.08 and u.u_value() < 1.3
