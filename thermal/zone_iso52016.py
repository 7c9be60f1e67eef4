"""Hourly zone loads by the ISO 52016-1:2017 method: a heat balance per element and surface.

The 5R1C network of ISO 13790 (:mod:`widesky.thermal.zone`) lumps every surface into one star node
coupled to the air through ``h_is A_t`` *in series* with the envelope's U-values, so a zone held at an air
set-point loses less than its ``U A`` (10 % for the ASHRAE 140 room, tests/test_thermal_bestest_balance.py).
ISO 52016-1 (section 6.5) instead keeps one set of nodes per construction element and solves, each hour,

* per element, the conduction between its nodes (implicit Euler on each node's heat capacity);
* on each outside surface, convection and long-wave exchange with the outdoor air and the sky
  (``h_ce``, ``h_re``, the sky's share ``F_sky = (1 + cos tilt) / 2``; sky temperature from the weather
  file's horizontal infrared) and the absorbed solar ``alpha I``;
* on each inside surface, convection to the air (``h_ci``: 2.5 W m-2 K-1 walls and windows, 5.0 roofs
  (heat upward), 0.7 floors (downward): ISO 52016-1 Table 25 / ISO 6946's R_si less its radiative part)
  and long-wave exchange with the other surfaces through the area-weighted mean inside surface temperature
  (``h_ri = 5.13`` W m-2 K-1, 52016-1 6.5.6.3);
* the air node: convection from the surfaces, ventilation, the convective share of the gains and the
  ideal heating or cooling that holds it at its set-point.

The radiative share of the internal gains and the transmitted solar are spread over the inside surfaces by
area (the solar over the opaque ones: the share that leaves through the glass again is taken off by the
caller). Node layout: where an element's layers are known (ASHRAE 140: the detailed models' x, k, c, rho),
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

__all__ = ["Layer", "Element", "H_RI", "H_CI", "simulate_iso52016", "element_nodes"]

H_RI = 5.13
"""Inside radiative coefficient h_ri [W m-2 K-1] (ISO 52016-1 Table 25; ISO 6946 Annex C at 20 degC)."""
H_CI = {"wall": 2.5, "window": 2.5, "roof": 5.0, "floor": 0.7}
"""Inside convective coefficient h_ci [W m-2 K-1] by element kind (ISO 52016-1 Table 25: horizontal, upward
and downward heat flow; with H_RI they give ISO 6946's R_si 0.13, 0.10, 0.17)."""
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
        Surface-to-surface resistance of a window [m2 K W-1] (``1/U - R_si - R_se`` of its rating).
    absorptance : float
        Outside solar absorptance [1] (opaque elements; windows' absorbed solar is in their g).
    emissivity : float
        Outside long-wave emissivity [1].
    exposed : bool
        False: the outside surface faces outdoor air without sun or sky (e.g. a raised floor).
    """

    name: str
    kind: str
    area: float
    tilt: float
    layers: tuple = field(default_factory=tuple)
    resistance: float = 0.0
    absorptance: float = 0.6
    emissivity: float = 0.9
    exposed: bool = True

    def __post_init__(self):
        if self.kind not in H_CI:
            raise ValueError(f"element {self.name!r}: kind={self.kind!r} not one of {tuple(H_CI)}")
        if not self.area > 0:
            raise ValueError(f"element {self.name!r}: area={self.area!r} m2 must be > 0")
        if self.kind == "window" and not self.resistance > 0:
            raise ValueError(f"window {self.name!r}: resistance={self.resistance!r} m2 K W-1 must be > 0")
        if self.kind != "window" and not self.layers:
            raise ValueError(f"element {self.name!r}: give its layers (outside first)")


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
        return np.array([1.0 / element.resistance]), np.zeros(2)
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
                      air_capacity_per_volume=1200.0, timestep=3600.0, warmup_steps=0, temp_start=20.0):
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
        (T,) solar heat gain through the windows that stays in the zone [W], spread over the opaque
        inside surfaces by area.
    phi_int : array_like
        (T,) or scalar internal sensible gains [W].
    h_ve : array_like
        (T,) or scalar ventilation conductance [W K-1] (air at the outdoor temperature).
    heating_setpoint, cooling_setpoint : array_like
        (T,) or scalar air set-points [degC]; -inf / inf: off.
    volume : float
        Air volume [m3] (the air node's capacity: ``air_capacity_per_volume`` times it).
    internal_radiative_fraction : float
        Share of ``phi_int`` spread over the inside surfaces [1]; the rest reaches the air.
    warmup_steps : int
        Steps run once before the period (from its start), results discarded.

    Returns
    -------
    dict of numpy.ndarray
        (T,): ``temp_air``, ``temp_surface`` (area-weighted inside surface mean) [degC], ``heating``,
        ``cooling`` (>= 0) [W].
    """
    elements = list(elements)
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
    hs, cs = steps(heating_setpoint, "heating_setpoint"), steps(cooling_setpoint, "cooling_setpoint")
    if np.any(hs > cs):
        raise ValueError("heating_setpoint must be <= cooling_setpoint")

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
    for i, el in enumerate(elements):
        K[inside[i], inside] -= H_RI * el.area * area / a_tot
        K[inside[i], inside[i]] += H_RI * el.area
    f_sky = np.array([0.5 * (1 + np.cos(np.radians(el.tilt))) for el in elements])
    exposed = np.array([el.exposed for el in elements])
    alpha = np.array([0.0 if el.kind == "window" or not el.exposed else el.absorptance for el in elements])
    opaque = np.array([el.kind != "window" for el in elements])

    # per step: outside coefficients and ventilation on the diagonal; the right-hand side
    h_out = (hce + hre) * area                                          # (T, E) [W K-1]
    M = np.broadcast_to(K + np.diag(cap / timestep), (T, N, N)).copy()
    M[:, outside, outside] += h_out
    M[:, 0, 0] += hve
    rhs = np.zeros((T, N))
    sky = np.where(exposed, f_sky, 0.0)
    rhs[:, outside] += (hce * area * te[:, None] + hre * area * (sky * ts[:, None] + (1 - sky) * te[:, None])
                        + alpha * area * sol_out)
    rhs[:, 0] += hve * te + (1 - internal_radiative_fraction) * pint
    rhs[:, inside] += (internal_radiative_fraction * pint)[:, None] * area / a_tot
    a_op = np.where(opaque, area, 0.0)
    rhs[:, inside] += sol_in[:, None] * a_op / a_op.sum()
    Minv = np.linalg.inv(M)                                                 # (T, N, N)
    unit = Minv[:, :, 0]                                                    # response to 1 W at the air
    cdt = cap / timestep
    base = np.einsum("tij,tj->ti", Minv, rhs)                               # (T, N)

    order = list(range(min(warmup_steps, T))) + list(range(T))
    n_warm = len(order) - T
    x = np.full(N, float(temp_start))
    ta, tsurf, need = np.empty(T), np.empty(T), np.empty(T)
    for i, t in enumerate(order):
        free = base[t] + Minv[t] @ (cdt * x)
        q = 0.0
        if free[0] < hs[t]:
            q = (hs[t] - free[0]) / unit[t, 0]
        elif free[0] > cs[t]:
            q = (cs[t] - free[0]) / unit[t, 0]
        x = free + q * unit[t]
        if i >= n_warm:
            ta[t], tsurf[t], need[t] = x[0], area @ x[inside] / a_tot, q
    return {"temp_air": ta, "temp_surface": tsurf, "heating": np.maximum(need, 0.0),
            "cooling": np.maximum(-need, 0.0)}
