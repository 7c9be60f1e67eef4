"""Hourly zone loads by the ISO 52016-1:2017 method: a heat balance per element and surface.

The 5R1C network of ISO 13790 (:mod:`widesky.thermal.zone`) lumps every surface into one star node
coupled to the air through ``h_is A_t`` *in series* with the envelope's U-values, so a zone held at an air
set-point loses less than its ``U A`` (10 % for the ASHRAE 140 room, tests/test_thermal_bestest_balance.py).
ISO 52016-1 (section 6.5) instead keeps one set of nodes per construction element and solves, each hour,

* per element, the conduction between its nodes (implicit Euler on each node's heat capacity);
* on each outside surface, convection and long-wave exchange with the outdoor air and the sky
  (``h_ce``, ``h_re``, the sky's share ``F_sky = (1 + cos tilt) / 2``; sky temperature from the weather
  file's horizontal infrared) and the absorbed solar ``alpha I`` (or, with ``exterior_convection="doe2"`` and
  ``exterior_longwave="energyplus"``, EnergyPlus's DOE-2 convection and sky/air/ground long-wave split, evaluated
  each step at the previous step's outside surface temperatures, :mod:`widesky.thermal.exterior`);
* on each inside surface, convection to the air (``h_ci``: 2.5 W m-2 K-1 walls and windows; horizontal
  surfaces 5.0 with the heat flowing upward, 0.7 downward: ISO 52016-1 Table 25 / ISO 6946's R_si less its
  radiative part; ``convection="fixed"`` takes roofs as upward and floors as downward, ``"direction"`` the
  direction of each step, ``"tarp"`` Walton's correlations instead, ``"tarp-iso15099"`` Walton's on the opaque
  surfaces and ISO 15099's on the windows, EnergyPlus's default, :data:`CONVECTION`; evaluated at the previous
  step's temperatures, or with ``iterate`` at the step's own, the step re-solved until they agree)
  and long-wave exchange with the other surfaces through the area-weighted mean inside surface temperature
  (``h_ri = 5.13`` W m-2 K-1, 52016-1 6.5.6.3), or (``longwave``) by view factors and grey script-F
  (:func:`box_view_factors`, :func:`radiant_exchange`);
* the air node: convection from the surfaces, ventilation, the convective share of the gains and the
  ideal heating or cooling that holds it at its set-point.

The radiative share of the internal gains is spread over the inside surfaces by area, the transmitted solar by
``solar_distribution`` (default: the opaque surfaces by area; the share that leaves through the glass again is
taken off by the caller). A window's gaps may conduct at their own temperature (``Element.gaps``). Node layout: where an element's layers are known (ASHRAE 140: the detailed models' x, k, c, rho),
nodes sit at the layer boundaries, with layers of more than 5 cm split; each sub-layer's capacity goes half to
either node. This is the standard's structure with the nodes in the real layers; its five-node lumping with a
mass-distribution class (Annex B) is what a user without layer data would enter. Windows are two massless
nodes (outer and inner pane surface) with the glazing's resistance between them.

Units: temperatures [degC], heat flows [W], areas [m2], coefficients [W m-2 K-1], layer thickness [m],
conductivity [W m-1 K-1], specific heat [J kg-1 K-1], density [kg m-3].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _iso52016
from .exterior import doe2_convection, energyplus_longwave

__all__ = ["Layer", "Element", "H_RI", "H_CI", "H_CI_UP", "H_CI_DOWN", "CONVECTION", "EXTERIOR_CONVECTION",
           "EXTERIOR_LONGWAVE", "ENGINES", "simulate_iso52016",
           "element_nodes", "window_resistance", "radiant_exchange", "box_view_factors", "iso15099_window_convection"]

SIGMA = 5.670374419e-8

H_RI = 5.13
"""Inside radiative coefficient h_ri [W m-2 K-1] (ISO 52016-1 Table 25; ISO 6946 Annex C at 20 degC)."""
H_CI = {"wall": 2.5, "window": 2.5, "roof": 5.0, "floor": 0.7}
"""Inside convective coefficient h_ci [W m-2 K-1] by element kind (ISO 52016-1 Table 25: horizontal, upward
and downward heat flow; with H_RI they give ISO 6946's R_si 0.13, 0.10, 0.17)."""
H_CI_UP, H_CI_DOWN = 5.0, 0.7
"""Inside convective coefficient [W m-2 K-1] of a horizontal surface with the heat flowing upward (a floor warmer
than the air, a ceiling colder than it) and downward (ISO 52016-1 Table 25; ISO 6946:2017 Table 7's R_si 0.10 and
0.17 less the radiative part)."""
CONVECTION = ("direction", "fixed", "tarp", "tarp-iso15099")
"""Inside convection: ``"direction"`` takes h_ci of floors and ceilings by the direction of the heat flow each step
(H_CI_UP / H_CI_DOWN; walls and windows H_CI), ``"fixed"`` the element kind's :data:`H_CI` (floor downward, roof
upward), ``"tarp"`` Walton's (1983) natural-convection correlations of every surface from the previous step's
surface-air difference dT [K] (TARP, EnergyPlus's default inside algorithm): vertical ``1.31 |dT|^(1/3)``,
unstable horizontal ``9.482 |dT|^(1/3) / (7.238 - |cos tilt|)``, stable ``1.810 |dT|^(1/3) / (1.382 + |cos tilt|)``
[W m-2 K-1]; ``"tarp-iso15099"`` EnergyPlus's default inside algorithm as EnergyPlus applies it: TARP on the opaque
surfaces and ISO 15099:2003 8.3.2.2's natural convection on the windows (:func:`iso15099_window_convection`; the
window's ``Element.height`` and the air's pressure)."""
EXTERIOR_CONVECTION = ("given", "doe2")
"""Outside convection: ``"given"`` the caller's ``h_ce``; ``"doe2"`` EnergyPlus's default DOE-2 model evaluated each
step (:func:`widesky.thermal.exterior.doe2_convection`), ``h_ce`` being the smooth surface's forced part."""
EXTERIOR_LONGWAVE = ("given", "energyplus")
"""Outside long-wave: ``"given"`` the caller's ``h_re`` (sky share ``F_sky``, the rest at the air temperature);
``"energyplus"`` EnergyPlus's sky/air/ground split linearised at the surface each step
(:func:`widesky.thermal.exterior.energyplus_longwave`)."""
EN673_MEAN_TEMPERATURE = 283.0
"""Mean gap temperature of EN 673's rating [K]."""
MAX_SUBLAYER = 0.05
"""Thickest sub-layer between two nodes [m]."""


@dataclass(frozen=True)
class Layer:
    """One layer: thickness [m], conductivity [W m-1 K-1], specific heat [J kg-1 K-1], density [kg m-3]."""

    thickness: float
    conductivity: float
    specific_heat: float = 0.0
    density: float = 0.0


@dataclass(frozen=True)
class Element:
    """A construction element of the zone.

    Attributes
    ----------
    name : str
    kind : {"wall", "roof", "floor", "window"}
    area : float
        [m2].
    tilt : float
        [deg] of the outward normal (90 walls, 0 roof, 180 floor).
    layers : tuple of Layer
        Outside first (opaque elements); empty for windows.
    resistance : float
        Surface-to-surface resistance of a window [m2 K W-1] (``1/U - R_si - R_se`` of its rating); with
        ``gaps``, only the part outside the gaps (the panes' conduction).
    gaps : tuple of (float, float)
        A window's gas gaps as (gas conductance ``h_g`` [W m-2 K-1], effective emissivity
        ``1 / (1/eps_1 + 1/eps_2 - 1)`` [1]): the gap conducts ``h_g + 4 sigma eps T_m^3`` (EN 673 eq. 3-4) at the
        mean of the window's two surface temperatures ``T_m`` of the previous step, rather than at EN 673's 283 K.
    absorptance : float
        Outside solar absorptance [1] (opaque elements; windows' absorbed solar is in their g).
    emissivity : float
        Outside long-wave emissivity [1].
    exposed : bool
        False: the outside surface faces outdoor air without sun or sky (e.g. a raised floor).
    height : float
        A window's height [m] (the length of ISO 15099's inside convection, ``convection="tarp-iso15099"``);
        0: not given.
    """

    name: str
    kind: str
    area: float
    tilt: float
    layers: tuple = field(default_factory=tuple)
    resistance: float = 0.0
    gaps: tuple = field(default_factory=tuple)
    absorptance: float = 0.6
    emissivity: float = 0.9
    exposed: bool = True
    height: float = 0.0

    def __post_init__(self):
        if self.kind not in H_CI:
            raise ValueError(f"element {self.name!r}: kind={self.kind!r} not one of {tuple(H_CI)}")
        if not self.area > 0:
            raise ValueError(f"element {self.name!r}: area={self.area!r} m2 must be > 0")
        if self.kind == "window" and not (self.resistance > 0 or self.gaps):
            raise ValueError(f"window {self.name!r}: resistance={self.resistance!r} m2 K W-1 must be > 0")
        if self.kind != "window" and not self.layers:
            raise ValueError(f"element {self.name!r}: give its layers (outside first)")


def _tarp(dt, tilt):
    """Natural convection of an inside surface [W m-2 K-1] (Walton 1983, TARP; EnergyPlus's default inside
    algorithm): ``dt`` surface minus air [K], ``tilt`` of the element's outward normal [deg] (the inside surface
    faces the other way)."""
    return _tarp_cos(dt, _inside_cos(tilt))


def _inside_cos(tilt):
    """The cosine of an inside surface's normal from the vertical, upward positive [1], for ``tilt`` [deg] of the
    element's outward normal."""
    return -np.cos(np.radians(tilt))


def _tarp_cos(dt, cos_s):
    """:func:`_tarp` with the inside surface's normal given as its cosine ``cos_s`` (:func:`_inside_cos`)."""
    a = abs(dt) ** (1.0 / 3.0)
    if abs(cos_s) < 1e-6:
        return max(1.31 * a, 0.1)
    unstable = (dt > 0) == (cos_s > 0)         # a warm surface facing up or a cold one facing down
    if unstable:
        return max(9.482 * a / (7.238 - abs(cos_s)), 0.1)
    return max(1.810 * a / (1.382 + abs(cos_s)), 0.1)


AIR_MOLAR_MASS = 28.97
"""Molar mass of air [kg kmol-1] (ISO 15099:2003 Annex B, Table B.1)."""
GAS_CONSTANT = 8314.462
"""Universal gas constant [J kmol-1 K-1]."""


def iso15099_window_convection(dt, tilt, height, temp_air, pressure=101325.0):
    """Natural convection on a window's inside surface [W m-2 K-1] by ISO 15099:2003 8.3.2.2, as EnergyPlus's TARP
    inside algorithm (its default) applies it to windows: EnergyPlus's ConvectionCoefficients.cc computes a surface
    under TARP by Walton's correlations (``CalcASHRAEDetailedIntConvCoeff``, :func:`_tarp`) unless its
    construction is a window, which gets this (``CalcISO15099WindowIntConvCoeff``).

    ``dt`` surface minus air [K], ``tilt`` of the window's outward normal [deg] (90 vertical), ``height`` the
    window's height H [m], ``temp_air`` the room air [degC], ``pressure`` the air's [Pa]. With the mean film
    temperature ``T_f = T_air + dt / 4`` [K] and ISO 15099 Annex B's air at it (conductivity
    ``k = 2.873e-3 + 7.76e-5 T_f`` W m-1 K-1, viscosity ``mu = 3.723e-6 + 4.94e-8 T_f`` Pa s, specific heat
    ``c_p = 1002.7376 + 1.2324e-2 T_f`` J kg-1 K-1, density ``rho = p M / (R T_f)``)::

        Ra = rho^2 H^3 g c_p |dt| / (T_f mu k),   h = Nu k / H

    where the inside surface's tilt ``theta`` is the window's (``180 - tilt`` when the glass is warmer than the air)
    and ``Nu`` is ``0.13 Ra^(1/3)`` for ``theta < 15``; ``0.56 (Ra sin theta)^(1/4)`` for ``15 <= theta <= 90`` up
    to ``Ra_cv = 2.5e5 (exp(0.72 theta) / sin theta)^(1/5)`` (theta in degrees), beyond it
    ``0.13 (Ra^(1/3) - Ra_cv^(1/3)) + 0.56 (Ra_cv sin theta)^(1/4)``; ``0.56 (Ra sin theta)^(1/4)`` with
    ``Ra sin theta`` held within 1e5-1e11 for ``90 < theta <= 179``; ``0.58 Ra^(1/5)`` (Ra up to 1e11) above 179.
    A vertical window is laminar (Ra_cv 1.1e11): h about 2.2 W m-2 K-1 for a 2 m pane 10 K from the air at
    sea level. EnergyPlus's lower limit 0.1 W m-2 K-1 applies, as to its TARP surfaces.
    """
    g = 9.81
    t_f = temp_air + 273.15 + 0.25 * dt
    k = 2.873e-3 + 7.76e-5 * t_f
    mu = 3.723e-6 + 4.94e-8 * t_f
    cp = 1002.7376 + 1.2324e-2 * t_f
    rho = pressure * AIR_MOLAR_MASS / (GAS_CONSTANT * t_f)
    ra = rho ** 2 * height ** 3 * g * cp * abs(dt) / (t_f * mu * k)
    theta = 180.0 - tilt if dt > 0 else tilt
    s = np.sin(np.radians(tilt))
    if theta < 15.0:
        nu = 0.13 * ra ** (1.0 / 3.0)
    elif theta <= 90.0:
        ra_cv = 2.5e5 * (np.exp(0.72 * theta) / s) ** 0.2
        nu = (0.56 * (ra * s) ** 0.25 if ra <= ra_cv
              else 0.13 * (ra ** (1.0 / 3.0) - ra_cv ** (1.0 / 3.0)) + 0.56 * (ra_cv * s) ** 0.25)
    elif theta <= 179.0:
        nu = 0.56 * min(max(ra * s, 1e5), 1e11) ** 0.25
    else:
        nu = 0.58 * min(ra, 1e11) ** 0.2
    return max(nu * k / height, 0.1)


_FIXED, _TARP, _ISO15099, _DIR_ROOF, _DIR_FLOOR = range(5)
"""The compiled loop's inside convection per element (thermal/_iso52016.c)."""
ENGINES = ("auto", "python")
"""Step loops of :func:`simulate_iso52016`: ``"auto"`` the compiled one where it applies, ``"python"`` numpy's."""


def _chains_only(base, outside, inside):
    """True when the conductance matrix ``base`` (N, N) couples each element's nodes (``outside[i]`` to
    ``inside[i]``, consecutive from node 1) only along their chain, symmetrically, and otherwise only the air
    (node 0) and the inside surfaces: the pattern thermal/_iso52016.c solves."""
    N = len(base)
    if outside[0] != 1 or inside[-1] != N - 1 or np.any(outside[1:] != inside[:-1] + 1):
        return False
    allowed = np.eye(N, dtype=bool)
    core = np.concatenate([[0], inside])
    allowed[np.ix_(core, core)] = True
    for f, l in zip(outside, inside):
        k = np.arange(f, l)
        allowed[k, k + 1] = allowed[k + 1, k] = True
        if not np.array_equal(base[k, k + 1], base[k + 1, k]):
            return False
    return not np.any(base[~allowed])


def window_resistance(element: Element, mean_temperature=EN673_MEAN_TEMPERATURE):
    """Surface-to-surface resistance of a window element [m2 K W-1] with its gaps at ``mean_temperature`` [K]."""
    return element.resistance + sum(1.0 / (hg + 4 * SIGMA * eps * mean_temperature ** 3) for hg, eps in element.gaps)


def _f_parallel(x, y, d):
    """View factor between two aligned parallel x-by-y rectangles at distance d [1] (Incropera, Table 13.2)."""
    x, y = x / d, y / d
    a, b = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
    return 2 / (np.pi * x * y) * (0.5 * np.log((1 + x * x) * (1 + y * y) / (1 + x * x + y * y))
                                  + x * b * np.arctan(x / b) + y * a * np.arctan(y / a)
                                  - x * np.arctan(x) - y * np.arctan(y))


def _f_perpendicular(x, y, z):
    """View factor from an x-by-y rectangle to a perpendicular x-by-z one sharing the edge x [1] (Incropera,
    Table 13.2)."""
    h, w = z / x, y / x
    s = h * h + w * w
    t = ((1 + w * w) * (1 + h * h) / (1 + s) * (w * w * (1 + s) / ((1 + w * w) * s)) ** (w * w)
         * (h * h * (1 + s) / ((1 + h * h) * s)) ** (h * h))
    return (w * np.arctan(1 / w) + h * np.arctan(1 / h) - np.sqrt(s) * np.arctan(1 / np.sqrt(s))
            + 0.25 * np.log(t)) / (np.pi * w)


def box_view_factors(width, depth, height):
    """(6, 6) view factors between the inside faces of a rectangular room [1], order floor, ceiling, north,
    east, south, west (``width`` along the north and south walls, ``depth`` along the east and west walls,
    ``height`` [m]); rows sum to 1."""
    dims = {"floor": (width, depth), "ceiling": (width, depth), "north": (width, height),
            "south": (width, height), "east": (depth, height), "west": (depth, height)}
    opposite = {"floor": "ceiling", "ceiling": "floor", "north": "south", "south": "north", "east": "west",
                "west": "east"}
    gap = {"floor": height, "ceiling": height, "north": depth, "south": depth, "east": width, "west": width}
    names = ("floor", "ceiling", "north", "east", "south", "west")
    F = np.zeros((6, 6))
    for i, a in enumerate(names):
        for j, b in enumerate(names):
            if a == b:
                continue
            if opposite[a] == b:
                F[i, j] = _f_parallel(*dims[a], gap[a])
            else:
                common = (set(_edges(a, width, depth, height)) & set(_edges(b, width, depth, height))).pop()
                other_a = dims[a][0] * dims[a][1] / common[1]
                other_b = dims[b][0] * dims[b][1] / common[1]
                F[i, j] = _f_perpendicular(common[1], other_a, other_b)
    return F


def _edges(face, width, depth, height):
    """The four edges of a box face as (name, length) (the name is the pair of faces meeting there)."""
    sides = {"floor": ("north", "south", "east", "west"), "ceiling": ("north", "south", "east", "west"),
             "north": ("floor", "ceiling", "east", "west"), "south": ("floor", "ceiling", "east", "west"),
             "east": ("floor", "ceiling", "north", "south"), "west": ("floor", "ceiling", "north", "south")}
    length = {frozenset(("floor", "north")): width, frozenset(("floor", "south")): width,
              frozenset(("ceiling", "north")): width, frozenset(("ceiling", "south")): width,
              frozenset(("floor", "east")): depth, frozenset(("floor", "west")): depth,
              frozenset(("ceiling", "east")): depth, frozenset(("ceiling", "west")): depth}
    return [(frozenset((face, o)), length.get(frozenset((face, o)), height)) for o in sides[face]]


def radiant_exchange(area, view_factors, emissivity, temperature=20.0):
    """(E, E) long-wave exchange conductances between inside surfaces [W K-1], grey and diffuse, by the radiosity
    method (Hottel's script-F), linearised at ``temperature`` [degC].

    ``area`` (E,) [m2], ``view_factors`` (E, E) [1] (rows summing to 1; zero between coplanar surfaces),
    ``emissivity`` (E,) [1]. The net long-wave flow out of surface i is ``sum_j G_ij theta_j`` [W] (rows of G sum to
    zero): ``G = 4 sigma T^3 diag(A eps) (I - F (I - diag(1 - eps) F)^-1 diag(eps))``.
    """
    a, F, eps = (np.asarray(v, float) for v in (area, view_factors, emissivity))
    E = len(a)
    if F.shape != (E, E) or not np.allclose(F.sum(1), 1.0, atol=1e-6):
        raise ValueError(f"view_factors must be ({E}, {E}) with rows summing to 1")
    if np.any((eps <= 0) | (eps > 1)):
        raise ValueError(f"emissivity must be in (0, 1], got {eps!r}")
    q = (a * eps)[:, None] * (np.eye(E) - F @ np.linalg.solve(np.eye(E) - (1 - eps)[:, None] * F, np.diag(eps)))
    return 4 * SIGMA * (temperature + 273.15) ** 3 * q


def element_nodes(element: Element):
    """Node conductances and capacities of one element, outside surface first.

    Returns
    -------
    g : numpy.ndarray
        (n - 1,) conductance between consecutive nodes per m2 [W m-2 K-1].
    c : numpy.ndarray
        (n,) heat capacity per m2 of each node [J m-2 K-1].
    """
    if element.kind == "window":
        return np.array([1.0 / window_resistance(element)]), np.zeros(2)
    g, c = [], [0.0]
    for lay in element.layers:
        n = max(1, int(np.ceil(lay.thickness / MAX_SUBLAYER - 1e-9))) if lay.specific_heat * lay.density else 1
        dx = lay.thickness / n
        cap = lay.specific_heat * lay.density * dx
        for _ in range(n):
            g.append(lay.conductivity / dx)
            c[-1] += cap / 2
            c.append(cap / 2)
    return np.array(g), np.array(c)


def simulate_iso52016(elements, temp_air_out, temp_sky, h_ce, h_re, solar_out, solar_in, phi_int,
                      h_ve, heating_setpoint, cooling_setpoint, *, volume, internal_radiative_fraction=0.5,
                      air_capacity_per_volume=1200.0, timestep=3600.0, warmup_steps=0, temp_start=20.0,
                      solar_distribution=None, convection="fixed", substeps=1, longwave=None,
                      surface_gains=None, air_pressure=101325.0, iterate=0, iterate_tol=1e-3,
                      exterior_convection="given", roughness=None, exterior_longwave="given", engine="auto"):
    """Run the ISO 52016-1 hourly balance of one zone (module doc).

    Parameters
    ----------
    elements : sequence of Element
        E elements.
    temp_air_out, temp_sky : array_like
        (T,) outdoor air and effective sky temperature [degC].
    h_ce, h_re : array_like
        (T,) or (T, E) outside convective and radiative coefficients [W m-2 K-1].
    solar_out : array_like
        (T, E) solar irradiance on each element's outside [W m-2] (absorbed: times its absorptance;
        windows and unexposed elements ignore it).
    solar_in : array_like
        (T,) solar heat gain through the windows that stays in the zone [W], spread over the inside
        surfaces by ``solar_distribution``.
    phi_int : array_like
        (T,) or scalar internal sensible gains [W].
    h_ve : array_like
        (T,) or scalar ventilation conductance [W K-1] (air at the outdoor temperature).
    heating_setpoint, cooling_setpoint : array_like
        (T,) or scalar air set-points [degC]; -inf / inf: off. With ``substeps`` > 1 also (T substeps,): the
        set-point of each sub-step (e.g. a ramp within the hour).
    volume : float
        Air volume [m3] (the air node's capacity: ``air_capacity_per_volume`` times it).
    internal_radiative_fraction : float
        Share of ``phi_int`` spread over the inside surfaces [1]; the rest reaches the air.
    warmup_steps : int
        Steps run once before the period (from its start), results discarded.
    solar_distribution : array_like, optional
        (E,) shares of ``solar_in`` landing on each element's inside surface [1] (normalised to sum 1;
        e.g. ASHRAE 140's table, most on the floor); default: the opaque elements by area.
    convection : str
        A key of :data:`CONVECTION`: ``"fixed"`` (default), ``"direction"`` (h_ci of floors and roofs by the
        heat flow's direction at the end of the previous step), ``"tarp"`` (Walton's correlations) or
        ``"tarp-iso15099"`` (Walton's on the opaque elements, ISO 15099's on the windows, whose ``height`` must be
        given: EnergyPlus's default).
    substeps : int
        Sub-steps per step (ISO 52016-1 6.5.1 allows steps shorter than the hour): each step of ``timestep`` is
        solved as ``substeps`` implicit-Euler steps. The weather's instantaneous values (``temp_air_out``,
        ``temp_sky``, ``h_ce``, ``h_re``: the weather file's values at the end of each hour) are interpolated
        linearly from the previous step's to this step's at each sub-step's end (the first step holds its own);
        the hour's integrals and schedules (``solar_out``, ``solar_in``, ``phi_int``, ``h_ve``, set-points) are
        held over the step. Results are the step's means over its sub-steps (``temp_air``, ``temp_surface``,
        ``heating``, ``cooling``). 1 (default): one implicit step per step, the results at its end.
    longwave : array_like, optional
        (E, E) long-wave exchange conductances between the inside surfaces [W K-1] (rows summing to zero, e.g.
        :func:`radiant_exchange` from the room's view factors); default: ISO 52016-1's exchange through the
        area-weighted mean inside surface temperature with ``H_RI``.
    surface_gains : array_like, optional
        (T, E, 2) heat [W] added at each element's outside (``[..., 0]``) and inside (``[..., 1]``) surface node,
        held over the step: e.g. the solar absorbed in a window's outer and inner pane.
    air_pressure : array_like
        (T,) or scalar air pressure [Pa] (ISO 15099's window convection, ``convection="tarp-iso15099"``; e.g. the
        weather file's station pressure), held over the step.

    iterate : int
        0 (default): each step's inside convective coefficients are those at the previous step's temperatures (a
        lag of one step). N > 0: they are then re-evaluated at the step's own solution and the step re-solved, up
        to N times or until no coefficient changes by more than ``iterate_tol`` [W m-2 K-1] (as EnergyPlus
        iterates its inside surface balance within the time step). Applies to ``"direction"``, ``"tarp"`` and
        ``"tarp-iso15099"``; ``"fixed"`` has nothing to iterate.
    iterate_tol : float
        Convergence tolerance of ``iterate`` [W m-2 K-1].
    exterior_convection : str
        A key of :data:`EXTERIOR_CONVECTION`. ``"given"`` (default): ``h_ce`` is the outside convective
        coefficient. ``"doe2"``: EnergyPlus's default outside model (:func:`widesky.thermal.exterior.doe2_convection`),
        ``h_ce`` then being the smooth surface's forced part ``h_f`` [W m-2 K-1] (MoWiTT's windward or leeward
        correlation at the surface's wind), each sub-step's coefficient ``h_n + R_f (sqrt(h_n^2 + h_f^2) - h_n)``
        with Walton's natural part ``h_n`` at the previous sub-step's outside surface-air difference (its outward
        normal's tilt decides stable or unstable) and ``R_f`` from ``roughness``.
    roughness : array_like, optional
        (E,) roughness multipliers R_f [1] of the outside surfaces for ``exterior_convection="doe2"``
        (:data:`widesky.thermal.exterior.ROUGHNESS_MULTIPLIER`); default 1 (very smooth).
    exterior_longwave : str
        A key of :data:`EXTERIOR_LONGWAVE`. ``"given"`` (default): ``h_re`` with the sky's share ``F_sky`` at the sky
        temperature and the rest at the air's. ``"energyplus"``: ``h_re`` is ignored and each sub-step takes
        EnergyPlus's coefficients linearised at the previous sub-step's outside surface temperature
        (:func:`widesky.thermal.exterior.energyplus_longwave`: sky ``F_sky beta``, air ``F_sky (1 - beta)``, ground
        ``F_gnd`` at the air temperature; the element's ``emissivity``; unexposed elements: all at the air's).
    engine : str
        A key of :data:`ENGINES`. ``"auto"`` (default): the compiled step loop (``widesky.thermal._iso52016``: each
        element's chain of nodes swept onto its inside surface, then a dense solve on the air and the inside
        surfaces; the same equations, the results equal to rounding) where it applies (``iterate`` 0, the
        ``"given"`` outside coefficients), else this module's loop around ``numpy.linalg.solve``; ``"python"``:
        always the latter (the reference the compiled loop is tested against).

    Returns
    -------
    dict of numpy.ndarray
        (T,): ``temp_air``, ``temp_surface`` (area-weighted inside surface mean) [degC], ``heating``,
        ``cooling`` (>= 0) [W]; ``h_ci_change``: (iterations + 1,) with ``iterate`` > 0 (else empty), per solve
        of a step the largest residual ``|h_ci(x) - h_ci used|`` [W m-2 K-1] over the reported steps and
        elements, ``x`` that solve's temperatures (entry 0: the lag of the one-solve scheme).
    """
    elements = list(elements)
    if not elements:
        raise ValueError("elements: give at least one Element (a zone needs an enclosure)")
    if convection not in CONVECTION:
        raise ValueError(f"convection={convection!r} not one of {CONVECTION}")
    if exterior_convection not in EXTERIOR_CONVECTION:
        raise ValueError(f"exterior_convection={exterior_convection!r} not one of {EXTERIOR_CONVECTION}")
    if exterior_longwave not in EXTERIOR_LONGWAVE:
        raise ValueError(f"exterior_longwave={exterior_longwave!r} not one of {EXTERIOR_LONGWAVE}")
    te = np.asarray(temp_air_out, float)
    T, E = len(te), len(elements)

    def steps(v, name, per_element=False):
        a = np.asarray(v, float)
        shape = (T, E) if per_element else (T,)
        if a.ndim == 1 and per_element:
            a = a[:, None]
        try:
            return np.broadcast_to(a, shape)
        except ValueError:
            raise ValueError(f"{name} has shape {a.shape}, expected {shape} or a scalar") from None
    ts, hce, hre = steps(temp_sky, "temp_sky"), steps(h_ce, "h_ce", True), steps(h_re, "h_re", True)
    sol_out, sol_in = steps(solar_out, "solar_out", True), steps(solar_in, "solar_in")
    pint, hve = steps(phi_int, "phi_int"), steps(h_ve, "h_ve")
    pres = steps(air_pressure, "air_pressure")
    if convection == "tarp-iso15099":
        for el in elements:
            if el.kind == "window" and not el.height > 0:
                raise ValueError(f"window {el.name!r}: height={el.height!r} m must be > 0 with "
                                 f"convection='tarp-iso15099'")
    sgain = np.zeros((T, E, 2)) if surface_gains is None else np.asarray(surface_gains, float)
    if sgain.shape != (T, E, 2):
        raise ValueError(f"surface_gains has shape {sgain.shape}, expected {(T, E, 2)}")
    for name, a in (("temp_air_out", te), ("temp_sky", ts), ("h_ce", hce), ("h_re", hre), ("solar_out", sol_out),
                    ("solar_in", sol_in), ("phi_int", pint), ("h_ve", hve), ("air_pressure", pres),
                    ("surface_gains", sgain)):
        if not np.all(np.isfinite(a)):
            bad = np.flatnonzero(~np.isfinite(np.reshape(a, (T, -1))).all(1))
            raise ValueError(f"{name} is not finite at {len(bad)} step(s), the first at index {bad[0]} "
                             "(fill the gaps in the weather or the inputs first)")
    sub_set = [np.asarray(a, float) for a in (heating_setpoint, cooling_setpoint)]
    per_sub = [isinstance(substeps, (int, np.integer)) and substeps > 1 and a.shape == (T * substeps,)
               for a in sub_set]
    hs, cs = (a if sub else steps(a, name) for a, sub, name in zip(sub_set, per_sub, ("heating_setpoint",
                                                                                      "cooling_setpoint")))
    if hs.shape == cs.shape and np.any(hs > cs):
        raise ValueError("heating_setpoint must be <= cooling_setpoint")
    if not (isinstance(iterate, (int, np.integer)) and iterate >= 0) or not iterate_tol >= 0:
        raise ValueError(f"iterate={iterate!r} must be an integer >= 0 and iterate_tol={iterate_tol!r} >= 0")
    if engine not in ENGINES:
        raise ValueError(f"engine={engine!r} not one of {ENGINES}")
    if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
        raise ValueError(f"substeps={substeps!r} must be an integer >= 1")
    n_sub = int(substeps)
    T_hours = T
    if n_sub > 1:
        frac = np.arange(1, n_sub + 1) / n_sub

        def interp(a):                        # (T, ...) end-of-step values -> (T n_sub, ...) at sub-step ends
            prev = np.concatenate([a[:1], a[:-1]])
            f = frac.reshape((1, n_sub) + (1,) * (a.ndim - 1))
            return (prev[:, None] + f * (a - prev)[:, None]).reshape((T * n_sub,) + a.shape[1:])

        def hold(a):
            return np.repeat(a, n_sub, axis=0)
        te, ts, hce, hre = interp(te), interp(ts), interp(np.asarray(hce)), interp(np.asarray(hre))
        sol_out, sol_in, pint, hve, sgain, pres = (hold(np.asarray(a))
                                                   for a in (sol_out, sol_in, pint, hve, sgain, pres))
        hs, cs = (a if sub else hold(np.asarray(a)) for a, sub in zip((hs, cs), per_sub))
        if np.any(hs > cs):
            raise ValueError("heating_setpoint must be <= cooling_setpoint")
        T = T * n_sub
        timestep = timestep / n_sub
        warmup_steps = warmup_steps * n_sub

    # node numbering: 0 air, then each element's nodes outside first
    first, nodes = [], 1
    gs, cs_ = [], []
    for el in elements:
        g, c = element_nodes(el)
        first.append(nodes)
        nodes += len(c)
        gs.append(g)
        cs_.append(c)
    N = nodes
    inside = np.array([f + len(c) - 1 for f, c in zip(first, cs_)])
    outside = np.array(first)
    area = np.array([el.area for el in elements])
    a_tot = area.sum()
    cap = np.zeros(N)
    cap[0] = air_capacity_per_volume * volume
    K = np.zeros((N, N))                      # constant part of the conductance matrix [W K-1]

    def couple(i, j, h):
        K[i, i] += h
        K[j, j] += h
        K[i, j] -= h
        K[j, i] -= h
    for i, (el, f, g, c) in enumerate(zip(elements, first, gs, cs_)):
        cap[f:f + len(c)] = c * el.area
        for k, gk in enumerate(g):
            couple(f + k, f + k + 1, gk * el.area)
        couple(inside[i], 0, H_CI[el.kind] * el.area)
    # long-wave exchange through the area-weighted mean inside surface temperature:
    # q_i = h_ri A_i (theta_i - sum_k A_k theta_k / A_tot)
    if longwave is None:
        for i, el in enumerate(elements):
            K[inside[i], inside] -= H_RI * el.area * area / a_tot
            K[inside[i], inside[i]] += H_RI * el.area
    else:
        lw = np.asarray(longwave, float)
        if lw.shape != (E, E) or not np.allclose(lw.sum(1), 0.0, atol=1e-6 * np.abs(lw).max()):
            raise ValueError(f"longwave must be ({E}, {E}) conductances with rows summing to zero")
        K[np.ix_(inside, inside)] += lw
    f_sky = np.array([0.5 * (1 + np.cos(np.radians(el.tilt))) for el in elements])
    exposed = np.array([el.exposed for el in elements])
    alpha = np.array([0.0 if el.kind == "window" or not el.exposed else el.absorptance for el in elements])
    opaque = np.array([el.kind != "window" for el in elements])

    # per step: outside coefficients and ventilation on the diagonal; the right-hand side
    rhs = np.zeros((T, N))
    sky = np.where(exposed, f_sky, 0.0)
    ext_var = exterior_convection == "doe2" or exterior_longwave == "energyplus"
    if not ext_var:
        h_out = (hce + hre) * area                                      # (T, E) [W K-1]
        rhs[:, outside] += (hce * area * te[:, None] + hre * area * (sky * ts[:, None] + (1 - sky) * te[:, None])
                            + alpha * area * sol_out)
    else:                       # outside coefficients from the previous step's outside surface temperatures
        rhs[:, outside] += alpha * area * sol_out
        rough = np.ones(E) if roughness is None else np.asarray(roughness, float)
        if rough.shape != (E,) or np.any(rough <= 0):
            raise ValueError(f"roughness must be {E} multipliers > 0, got {roughness!r}")
        tilt_out = np.array([el.tilt for el in elements])
        cos_out = np.cos(np.radians(tilt_out))
        emis = np.array([el.emissivity for el in elements])

        def outside_coefficients(xs, t):
            """(E,) [W m-2 K-1]: convective, long-wave to the sky, long-wave at the air temperature."""
            if exterior_convection == "doe2":
                dt = xs[outside] - te[t]
                hc = doe2_convection(dt, cos_out, hce[t], rough)
            else:
                hc = np.asarray(hce[t], float)
            if exterior_longwave == "energyplus":
                h_sk, h_am = energyplus_longwave(xs[outside], te[t], ts[t], tilt_out, emis, exposed)
            else:
                h_sk, h_am = hre[t] * sky, hre[t] * (1 - sky)
            return hc, h_sk, h_am
    rhs[:, 0] += hve * te + (1 - internal_radiative_fraction) * pint
    rhs[:, outside] += sgain[:, :, 0]
    rhs[:, inside] += sgain[:, :, 1]
    rhs[:, inside] += (internal_radiative_fraction * pint)[:, None] * area / a_tot
    if solar_distribution is None:
        share = np.where(opaque, area, 0.0) if opaque.any() else area
    else:
        share = np.asarray(solar_distribution, float)
        if share.shape != (E,) or np.any(share < 0) or not share.sum() > 0:
            raise ValueError(f"solar_distribution must be {E} shares >= 0 with a positive sum, got {share!r}")
    rhs[:, inside] += sol_in[:, None] * share / share.sum()
    cdt = cap / timestep
    base = K + np.diag(cdt)
    order = list(range(min(warmup_steps, T))) + list(range(T))
    n_warm = len(order) - T
    x = np.full(N, float(temp_start))
    ta, tsurf, need = np.empty(T), np.empty(T), np.empty(T)
    kinds = [el.kind for el in elements]
    horiz = [i for i, el in enumerate(elements) if convection == "direction" and el.kind in ("roof", "floor")]
    tarp = list(range(E)) if convection in ("tarp", "tarp-iso15099") else []
    iso15099 = convection == "tarp-iso15099"
    wins = [i for i, el in enumerate(elements) if el.kind == "window" and el.gaps]
    h_base = np.array([H_CI[k] for k in kinds])
    cos_in = [_inside_cos(el.tilt) for el in elements]     # once, not per step (the same values)
    r_window = {j: window_resistance(elements[j]) for j in wins}

    def h_conv(xs, t):
        """(E,) inside convective coefficients [W m-2 K-1] at the node temperatures ``xs``."""
        h = h_base.copy()
        xs = xs.tolist()                                    # scalar arithmetic on floats (the same values)
        for j in horiz:
            # ISO 52016-1 Table 25 by the direction of the heat flow: a ceiling (roof inside, facing down)
            # colder than the air or a floor warmer than it: upward
            hot = xs[inside[j]] > xs[0]
            up = (not hot) if kinds[j] == "roof" else hot
            h[j] = H_CI_UP if up else H_CI_DOWN
        for j in tarp:
            dt = xs[inside[j]] - xs[0]
            if iso15099 and kinds[j] == "window":
                h[j] = iso15099_window_convection(dt, elements[j].tilt, elements[j].height, xs[0], pres[t])
            else:
                h[j] = _tarp_cos(dt, cos_in[j])
        return h

    def with_convection(M0, h, in_place=False):
        M = M0 if in_place else M0.copy()
        dh = (h - h_base) * area
        M[inside, inside] += dh
        M[0, 0] += dh.sum()
        M[inside, 0] -= dh
        M[0, inside] -= dh
        return M
    variable = bool(horiz or tarp)
    n_iter = int(iterate) if variable else 0
    change = np.zeros(n_iter + 1 if n_iter else 0)  # per solve: the largest |h(x) - h_used| of the steps
    rhs_t = np.zeros((N, 2))                        # the step's right-hand side and the unit heat at the air
    rhs_t[0, 1] = 1.0
    native = engine == "auto" and not ext_var and not n_iter and _chains_only(base, outside, inside)
    if native:
        mode = np.array([(_ISO15099 if iso15099 and kinds[j] == "window" else _TARP) if j in tarp
                         else (_DIR_ROOF if kinds[j] == "roof" else _DIR_FLOOR) if j in horiz else _FIXED
                         for j in range(E)], dtype=np.int64)
        gaps = [elements[j].gaps for j in wins]
        f64 = np.ascontiguousarray
        _iso52016.run(N, E, T, n_warm, len(wins), float(temp_start), f64(base, float), f64(cdt, float),
                      f64(h_out, float), f64(hve, float), f64(rhs, float), f64(hs, float), f64(cs, float),
                      outside.astype(np.int64), inside.astype(np.int64), f64(area, float), f64(h_base, float), mode,
                      np.array(cos_in, float), np.array([el.tilt for el in elements], float),
                      np.array([el.height for el in elements], float), f64(pres, float),
                      np.array(wins, dtype=np.int64), np.array([elements[j].resistance for j in wins], float),
                      np.array([r_window[j] for j in wins], float),
                      np.cumsum([0] + [len(g) for g in gaps]).astype(np.int64),
                      np.array([hg for g in gaps for hg, _ in g], float),
                      np.array([eps for g in gaps for _, eps in g], float), ta, tsurf, need)
    for i, t in enumerate(order if not native else ()):
        M0 = base.copy()
        rhs_step = rhs[t]
        if ext_var:
            hc, h_sk, h_am = outside_coefficients(x, t)
            M0[outside, outside] += (hc + h_sk + h_am) * area
            rhs_step = rhs[t].copy()
            rhs_step[outside] += (hc + h_am) * area * te[t] + h_sk * area * ts[t]
        else:
            M0[outside, outside] += h_out[t]
        M0[0, 0] += hve[t]
        for j in wins:
            el = elements[j]
            tm = 0.5 * (x[outside[j]] + x[inside[j]]) + 273.15      # mean gap temperature [K]
            r = el.resistance + sum(1.0 / (hg + 4 * SIGMA * eps * tm ** 3) for hg, eps in el.gaps)
            dh = (1.0 / r - 1.0 / r_window[j]) * area[j]
            a, b = outside[j], inside[j]
            M0[a, a] += dh
            M0[b, b] += dh
            M0[a, b] -= dh
            M0[b, a] -= dh
        # the coefficients at the previous step's temperatures, then (iterate) at this step's own
        h = h_conv(x, t) if variable else h_base
        rhs_t[:, 0] = rhs_step + cdt * x
        for k in range(n_iter + 1):
            # the last solve of a step may take M0 itself (rebuilt each step); an iterated one needs it again
            sol = np.linalg.solve(with_convection(M0, h, in_place=not n_iter) if variable else M0, rhs_t)
            free, unit = sol[:, 0], sol[:, 1]
            q = 0.0
            if free[0] < hs[t]:
                q = (hs[t] - free[0]) / unit[0]
            elif free[0] > cs[t]:
                q = (cs[t] - free[0]) / unit[0]
            if not n_iter:
                break
            h_new = h_conv(free + q * unit, t)
            d = float(np.abs(h_new - h).max())          # the coefficients' residual of this solve
            if i >= n_warm:
                change[k] = max(change[k], d)
            if d <= iterate_tol or k == n_iter:
                break
            h = h_new
        x = free + q * unit
        if i >= n_warm:
            ta[t], tsurf[t], need[t] = x[0], area @ x[inside] / a_tot, q
    heat_, cool_ = np.maximum(need, 0.0), np.maximum(-need, 0.0)
    if n_sub > 1:
        ta, tsurf, heat_, cool_ = (a.reshape(T_hours, n_sub).mean(1) for a in (ta, tsurf, heat_, cool_))
    return {"temp_air": ta, "temp_surface": tsurf, "heating": heat_, "cooling": cool_, "h_ci_change": change}
