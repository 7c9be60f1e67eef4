"""Glazing units of the cases that need no data files: clear, low-e and solar-control double glazing.

The glass is modelled, not measured: clear float glass as a Fresnel slab with Rubin's soda-lime index
(:func:`widesky.pvsim.rubin_soda_lime_index`) and an absorption coefficient of 4 m-1 in the visible rising to 80 m-1
at the ferrous-iron band (a Gaussian centred at 1050 nm, 250 nm wide), which gives a 6 mm pane a light
transmittance of 0.88 and a solar transmittance of 0.81 (g 0.84, U 5.7), typical of 6 mm clear float. The two
coatings are *idealised* spectrally selective layers on that glass, each defined by a few scalars (normal
transmittance in the visible and beyond a cut-off wavelength, the width of the step between them, the coated
layer's absorptance and the coating's emissivity):

* ``low-e``: a soft low-e coating on surface 3 (the inner pane's gap side) of the kind sold for heating
  climates: visible 0.92, beyond 1400 nm 0.25, step 250 nm wide, absorptance 0.06, emissivity 0.04;
* ``solar-control``: a solar-control coating on surface 2 (the outer pane's gap side): visible 0.80,
  beyond 760 nm 0.10 (the near infrared reflected), step 70 nm wide, absorptance 0.10, emissivity 0.03.

They are not products. Their computed values (weighted by the sky model's AM1.5 global spectrum, printed in
every report, :func:`unit_summary`; ``tests/test_cases_buildings.py`` holds them): clear U 2.72, g 0.74, light
transmittance 0.79; low-e U 1.09, g 0.62, 0.73; solar control U 1.06, g 0.42, 0.64 -- where double glazing of
those kinds lies (argon-filled low-e: U about 1.0-1.4 and g about 0.55-0.65; solar control: g about 0.3-0.45 with
a light transmittance well above g).
With the IGDB samples shipped in the
package, ``igdb:clear``, ``igdb:low-e`` and ``igdb:low-e #2`` are the measured units of
:func:`widesky.thermal.study.standard_units` instead.

Units: wavelength [nm], thickness [mm], gap [mm], optics [1], U [W m-2 K-1].
"""

from __future__ import annotations

import numpy as np

from widesky.core.fresnel import slab
from widesky.pvsim import rubin_soda_lime_index
from widesky.skymodel.colour import cie1931_xyz
from widesky.thermal import Gap, GlazingLayer, GlazingUnit, layer_from_nk
from widesky.thermal.study import standard_units

__all__ = ["BUILTIN_UNITS", "IGDB_UNITS", "GLAZING_CHOICES", "glazing_units", "unit_summary"]

BUILTIN_UNITS = ("clear", "low-e", "solar-control")
IGDB_UNITS = ("igdb:clear", "igdb:low-e", "igdb:low-e #2")
GLAZING_CHOICES = BUILTIN_UNITS + IGDB_UNITS

_GLASS_MM = 6.0        # pane thickness [mm]
_GAP_MM = 16.0         # gap width [mm]


def clear_glass_nk(wavelength):
    """(n, k) [1] of the modelled clear float glass at ``wavelength`` [nm] (see the module text)."""
    wl = np.asarray(wavelength, float)
    alpha = 4.0 + 76.0 * np.exp(-(((wl - 1050.0) / 250.0) ** 2))          # absorption coefficient [m-1]
    return rubin_soda_lime_index(wl), alpha * wl * 1e-9 / (4.0 * np.pi)


def _step(wl, t_vis, t_ir, cut, width):
    """Logistic step from ``t_vis`` below to ``t_ir`` above ``cut`` [nm], ``width`` [nm] wide (10-90 %)."""
    return t_ir + (t_vis - t_ir) / (1.0 + np.exp((wl - cut) / (width / 4.4)))


def _coated(name, wl, n, k, t_vis, t_ir, cut, width, absorptance, emissivity, coating_side):
    """A coated pane: the coating's normal T, the rest reflected apart from ``absorptance``; the clear glass
    substrate gives the angular shape (thermal's scaled-substrate rule). ``coating_side``: "front" or "back"."""
    T_sub, R_sub = (a[0] for a in slab(n, k, _GLASS_MM, wl, [0.0]))
    T = _step(wl, t_vis, t_ir, cut, width) * T_sub
    R_coat = np.clip(1.0 - T - absorptance, 0.0, 1.0)
    R_glass = np.clip(np.minimum(R_sub, 1.0 - T - 1e-3), 0.0, 1.0)
    Rf, Rb = (R_coat, R_glass) if coating_side == "front" else (R_glass, R_coat)
    ef, eb = (emissivity, 0.84) if coating_side == "front" else (0.84, emissivity)
    return GlazingLayer(name, wl, T, Rf, Rb, _GLASS_MM, ef, eb, 1.0, True, n, k)


def glazing_units(names, data_dir=None):
    """The glazing units ``names`` (items of :data:`GLAZING_CHOICES`) as ``{name: thermal.GlazingUnit}``.

    Raises
    ------
    ValueError
        For an unknown name (listing the valid ones); ``FileNotFoundError`` for an ``igdb:`` unit with a
        ``data_dir`` that lacks the sample.
    """
    bad = [n for n in names if n not in GLAZING_CHOICES]
    if bad:
        raise ValueError(f"glazing {bad[0]!r} is not valid; expected items from {', '.join(GLAZING_CHOICES)}")
    wl = np.arange(280.0, 2500.1, 10.0)
    n, k = clear_glass_nk(wl)
    clear = layer_from_nk("modelled clear float 6 mm", wl, n, k, _GLASS_MM)
    gap = Gap(_GAP_MM, "argon")
    out = {}
    igdb = None
    for name in names:
        if name == "clear":
            out[name] = GlazingUnit(name, [clear, clear], [Gap(_GAP_MM, "air")])
        elif name == "low-e":
            le = _coated("idealised low-e (#3)", wl, n, k, 0.92, 0.25, 1400.0, 250.0, 0.06, 0.04, "front")
            out[name] = GlazingUnit(name, [clear, le], [gap])
        elif name == "solar-control":
            sc = _coated("idealised solar control (#2)", wl, n, k, 0.80, 0.10, 760.0, 70.0, 0.10, 0.03, "back")
            out[name] = GlazingUnit(name, [sc, clear], [gap])
        else:
            if igdb is None:
                igdb = standard_units(data_dir)
            u = igdb[name.split(":", 1)[1]]
            out[name] = GlazingUnit(name, u.layers, u.gaps)
    return out


def unit_summary(unit, channel_edges, spectrum):
    """Rated values of a unit under a band-mean ``spectrum`` (C,) [W m-2 nm-1] on ``channel_edges`` (C+1,)
    [nm] (e.g. the sky model's AM1.5 global): ``u_value`` [W m-2 K-1] (EN 673), ``g_normal``, ``g_diffuse``,
    ``t_solar`` [1] and ``t_visible`` [1] (normal transmittance weighted by the CIE 1931 photopic curve under
    that spectrum), evaluated on a 10 nm grid."""
    edges = np.asarray(channel_edges, float)
    wl = np.arange(edges[0] + 5.0, edges[-1], 10.0)
    e = np.asarray(spectrum, float)[np.clip(np.searchsorted(edges, wl) - 1, 0, len(edges) - 2)]
    o = unit.optics([0.0], wl)
    sol = lambda v: float(np.sum(v * e) / np.sum(e))  # noqa: E731  (channel means: a plain weighted mean)
    vis = cie1931_xyz(wl)[:, 1] * e
    g_d = unit.hemispherical("shgc", wl)
    return {"u_value": float(unit.u_value()), "g_normal": sol(o["shgc"][0]), "g_diffuse": sol(g_d),
            "t_solar": sol(o["transmittance"][0]),
            "t_visible": float(np.sum(o["transmittance"][0] * vis) / np.sum(vis))}
