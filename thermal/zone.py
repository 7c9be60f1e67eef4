"""Hourly zone loads: the ISO 13790:2008 simple hourly method (5R1C network, Annex C).

Why 5R1C and not ISO 52016-1: the issue's users want annual and peak heating and cooling loads of
many zones from a building's areas, U-values and heat capacity, driven by detailed solar gains.
5R1C needs exactly those inputs (no layer-by-layer constructions), runs a zone-year in
milliseconds, and has a public ASHRAE 140 validation with published parameters (the ISO 13790 models
of the Modelica Buildings library, whose case files are in ``../shared/data/bestest``), so our
implementation can be checked against both the Standard 140 reference programs and an independent
5R1C code. ISO 52016-1 resolves each construction layer and surface, which the simple building
input here does not provide; its extra accuracy would be spent on guessed layer data.

Network (ISO 13790 C.2-C.3): air node ``theta_air``, surface (star) node ``theta_s``, mass node
``theta_m``; conductances ``H_ve`` (air - outside), ``H_tr_is = h_is A_t`` (air - surface),
``H_tr_w`` (surface - outside, windows), ``H_tr_ms = h_ms A_m`` (surface - mass), ``H_tr_em``
(mass - outside, opaque elements in series with ``H_tr_ms``). The mass node integrates with the
Crank-Nicolson step of C.3; gains split as C.2: ``Phi_ia`` (convective internal) at the air node,
``Phi_st`` and ``Phi_m`` (radiative internal + solar) by area ratios (the standard drops the share
``H_tr_w / (h_ms A_t)`` of these radiative gains as radiated straight out through the glazing; the
energy-balance test accounts for it). Heating and cooling are ideal
and convective at the air node: the air temperature is held at the set-point whenever the
free-floating temperature leaves the band (C.4; the zone is linear in the heat input, so the need
follows from two evaluations, exactly).

Units: temperatures [degC], heat flows [W], conductances [W K-1], capacity [J K-1], areas [m2],
time step [s].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ZoneParameters", "simulate_5r1c", "H_IS", "H_MS", "LAMBDA_AT"]

H_IS = 3.45
"""Air - surface coupling per internal area h_is [W m-2 K-1] (ISO 13790 7.2.2.2)."""
H_MS = 9.1
"""Surface - mass coupling per effective mass area h_ms [W m-2 K-1] (ISO 13790 12.2.2)."""
LAMBDA_AT = 4.5
"""Ratio of internal surface area to floor area A_t / A_f [1] (ISO 13790 7.2.2.2)."""


@dataclass(frozen=True)
class ZoneParameters:
    """5R1C parameters of one zone (arrays of shape (Z,) describe Z zones at once).

    Attributes
    ----------
    floor_area : float or array
        A_f [m2].
    h_tr_w : float or array
        Window transmission conductance [W K-1] (sum of U A of glazed elements), >= 0.
    h_tr_op : float or array
        Opaque transmission conductance [W K-1] (sum of b U A of walls, roof, floor ...).
    h_ve : float or array
        Ventilation and infiltration conductance [W K-1] (rho c V_dot).
    heat_capacity : float or array
        Internal heat capacity C_m [J K-1].
    mass_area : float or array
        Effective mass area A_m [m2].
    total_area : float or array, optional
        Internal surface area A_t [m2]; default ``LAMBDA_AT * floor_area``.
    """

    floor_area: object
    h_tr_w: object
    h_tr_op: object
    h_ve: object
    heat_capacity: object
    mass_area: object
    total_area: object = None

    def __post_init__(self):
        for name in ("floor_area", "h_tr_w", "h_tr_op", "h_ve", "heat_capacity", "mass_area"):
            v = np.asarray(getattr(self, name), dtype=float)
            if np.any(~np.isfinite(v)) or np.any(v < 0) or (name != "h_tr_w" and np.any(v == 0)):
                raise ValueError(f"{name}={v!r} must be finite and > 0"
                                 + (" (h_tr_w >= 0)" if name == "h_tr_w" else ""))
        if self.total_area is None:
            object.__setattr__(self, "total_area", LAMBDA_AT * np.asarray(self.floor_area, float))
        at = np.asarray(self.total_area, dtype=float)
        if np.any(at < np.asarray(self.mass_area, float)):
            raise ValueError(f"total_area={at!r} m2 must be >= mass_area={self.mass_area!r} m2")

    def conductances(self):
        """Dict of the network's conductances [W K-1]: h_ve, h_tr_is, h_tr_w, h_tr_ms, h_tr_em."""
        h_ms = H_MS * np.asarray(self.mass_area, float)
        h_op = np.asarray(self.h_tr_op, float)
        if np.any(h_op >= h_ms):
            raise ValueError(f"h_tr_op={h_op!r} W K-1 must be < h_ms A_m = {h_ms!r} W K-1")
        return {"h_ve": np.asarray(self.h_ve, float), "h_tr_is": H_IS * np.asarray(self.total_area, float),
                "h_tr_w": np.asarray(self.h_tr_w, float), "h_tr_ms": h_ms,
                "h_tr_em": 1.0 / (1.0 / h_op - 1.0 / h_ms)}


def simulate_5r1c(params: ZoneParameters, temp_air_out, phi_int, phi_sol, heating_setpoint=20.0,
                  cooling_setpoint=27.0, heating_max=np.inf, cooling_max=np.inf, *,
                  internal_convective_fraction=0.5, temp_supply=None, timestep=3600.0,
                  temp_mass_start=None, warmup_steps=0, h_tr_w=None, h_tr_op=None, h_ve=None,
                  phi_sol_shaded=None, shade_request=None):
    """Run the 5R1C zone model hour by hour.

    Parameters
    ----------
    params : ZoneParameters
        Z zones (scalars: Z = 1).
    temp_air_out : array_like
        (T,) or (T, Z) outdoor air temperature [degC].
    phi_int : array_like
        (T,) or (T, Z) internal sensible gains [W].
    phi_sol : array_like
        (T,) or (T, Z) solar gains [W] (through windows plus absorbed on opaque elements, less the
        long-wave loss to the sky, ISO 13790 11.3).
    heating_setpoint, cooling_setpoint : float or array_like
        [degC], scalars or (T,) / (T, Z) schedules; use -inf / inf to switch off.
    heating_max, cooling_max : float or array_like
        Plant limits [W] (>= 0).
    internal_convective_fraction : float
        Share of ``phi_int`` released to the air node [1] (ISO 13790: 0.5).
    temp_supply : array_like, optional
        (T,) or (T, Z) supply air temperature [degC]; default the outdoor air (infiltration).
    timestep : float
        [s].
    temp_mass_start : float, optional
        Initial mass temperature [degC]; default the heating set-point (or 20).
    warmup_steps : int
        Steps run once before the period (from its start) to reach a periodic state; their results
        are discarded.
    h_tr_w, h_tr_op : array_like, optional
        (T,) or (T, Z) window and opaque transmission conductances per step [W K-1], replacing
        the constants of ``params`` (e.g. U-values with an hourly, wind-dependent outside surface
        coefficient, :func:`widesky.thermal.exterior.hourly_u_value`). ``h_tr_op`` must stay below
        ``h_ms A_m`` at every step.
    h_ve : array_like, optional
        (T,) or (T, Z) ventilation conductance per step [W K-1] (> 0), replacing ``params.h_ve``
        (e.g. a night-ventilation fan on a schedule, ASHRAE 140 Case 650).
    phi_sol_shaded, shade_request : array_like, optional
        A shading device run by the zone's state: (T,) or (T, Z) the solar gains [W] with the device down where it
        is requested, and (T,) or (T, Z) bool, the steps it is requested (e.g. high irradiance on the windows in an
        occupied hour). The device goes down in a requested step unless the zone heated in the previous step (kept
        up for the sun's heat while the zone needs heat; one step behind, as a building controller reads the zone's
        state); ``phi_sol`` are then the gains with it up.

    Returns
    -------
    dict of numpy.ndarray
        (T, Z): ``temp_air``, ``temp_surface``, ``temp_mass`` (step means), ``temp_mass_end``
        (mass temperature at the end of each step) [degC]; ``heating`` (>= 0),
        ``cooling`` (>= 0) [W] (mean power over each step); with ``phi_sol_shaded``, ``shaded`` (bool): the
        steps the device was down.
    """
    g = params.conductances()
    Z = int(np.broadcast(*(np.atleast_1d(v) for v in g.values())).shape[0])

    def col(v, name):
        a = np.asarray(v, dtype=float)
        if a.ndim == 0:
            return np.full((1, Z), a)
        if a.ndim == 1:
            a = a[:, None]
        if a.shape[1] not in (1, Z):
            raise ValueError(f"{name} has {a.shape[1]} zones, the parameters {Z}")
        return a
    te = col(temp_air_out, "temp_air_out")
    T = te.shape[0]
    if not np.all(np.isfinite(te)):
        raise ValueError("temp_air_out has non-finite values")
    series = {"phi_int": col(phi_int, "phi_int"), "phi_sol": col(phi_sol, "phi_sol"),
              "heating_setpoint": col(heating_setpoint, "heating_setpoint"),
              "cooling_setpoint": col(cooling_setpoint, "cooling_setpoint")}
    if (phi_sol_shaded is None) != (shade_request is None):
        raise ValueError("give phi_sol_shaded and shade_request together")
    if phi_sol_shaded is not None:
        series["phi_sol_shaded"] = col(phi_sol_shaded, "phi_sol_shaded")
        req = np.asarray(shade_request)
        if req.dtype != bool:
            raise ValueError(f"shade_request must be bool, got {req.dtype}")
        series["shade_request"] = col(req, "shade_request") > 0.5
    for name, a in series.items():
        if a.shape[0] not in (1, T):
            raise ValueError(f"{name} has {a.shape[0]} steps, temp_air_out {T}")
    if np.any(series["heating_setpoint"] > series["cooling_setpoint"]):
        raise ValueError("heating_setpoint must be <= cooling_setpoint")
    hmax = np.broadcast_to(np.asarray(heating_max, float), (Z,))
    cmax = np.broadcast_to(np.asarray(cooling_max, float), (Z,))
    if np.any(hmax < 0) or np.any(cmax < 0):
        raise ValueError("heating_max and cooling_max must be >= 0 W")
    if not 0 <= internal_convective_fraction <= 1:
        raise ValueError(f"internal_convective_fraction={internal_convective_fraction!r} outside [0, 1]")
    tsup = te if temp_supply is None else col(temp_supply, "temp_supply")
    te = np.broadcast_to(te, (T, Z))
    tsup = np.broadcast_to(tsup, (T, Z))

    h_ve_steps = h_ve
    h_ve, h_is, h_w, h_ms, h_em = (np.broadcast_to(g[k], (Z,)).astype(float) for k in
                                   ("h_ve", "h_tr_is", "h_tr_w", "h_tr_ms", "h_tr_em"))
    if h_tr_w is not None:
        h_w = col(h_tr_w, "h_tr_w")
        if h_w.shape[0] != T or np.any(~np.isfinite(h_w)) or np.any(h_w < 0):
            raise ValueError(f"h_tr_w must be finite, >= 0 W K-1 with {T} steps, got shape "
                             f"{h_w.shape}")
        h_w = np.broadcast_to(h_w, (T, Z))
    if h_tr_op is not None:
        h_op = col(h_tr_op, "h_tr_op")
        if h_op.shape[0] != T:
            raise ValueError(f"h_tr_op needs {T} steps, got shape {h_op.shape}")
        if not np.all((h_op > 0) & (h_op < h_ms)):
            raise ValueError(f"h_tr_op must lie in (0, h_ms A_m = {h_ms!r}) W K-1 at every step")
        h_em = 1.0 / (1.0 / h_op - 1.0 / h_ms)
    if h_ve_steps is not None:
        h_v = col(h_ve_steps, "h_ve")
        if h_v.shape[0] != T or not np.all(np.isfinite(h_v) & (h_v > 0)):
            raise ValueError(f"h_ve must be finite, > 0 W K-1 with {T} steps, got shape {h_v.shape}")
        h_ve = np.broadcast_to(h_v, (T, Z))
    a_t = np.broadcast_to(np.asarray(params.total_area, float), (Z,))
    a_m = np.broadcast_to(np.asarray(params.mass_area, float), (Z,))
    cm = np.broadcast_to(np.asarray(params.heat_capacity, float), (Z,)) / timestep
    h1 = 1.0 / (1.0 / h_ve + 1.0 / h_is)
    h2 = h1 + h_w
    h3 = 1.0 / (1.0 / h2 + 1.0 / h_ms)
    f_m = a_m / a_t
    f_st = 1.0 - f_m - h_w / (H_MS * a_t)
    den_m = cm + 0.5 * (h3 + h_em)
    num_m = cm - 0.5 * (h3 + h_em)
    fc = internal_convective_fraction

    def step(tm_prev, phi_hc, phi_sol=series["phi_sol"]):
        """All steps at once for given previous mass temperatures and heat inputs, (T, Z)."""
        p_ia = fc * series["phi_int"] + phi_hc
        p_rad = (1.0 - fc) * series["phi_int"] + phi_sol
        p_m, p_st = f_m * p_rad, f_st * p_rad
        p_mtot = p_m + h_em * te + h3 * (p_st + h_w * te + h1 * (p_ia / h_ve + tsup)) / h2
        tm_t = (tm_prev * num_m + p_mtot) / den_m
        tm = 0.5 * (tm_t + tm_prev)
        ts = (h_ms * tm + p_st + h_w * te + h1 * (tsup + p_ia / h_ve)) / (h_ms + h_w + h1)
        ta = (h_is * ts + h_ve * tsup + p_ia) / (h_is + h_ve)
        return ta, ts, tm, tm_t

    # The network is linear in (previous mass temperature, heat input): evaluate the three basis
    # cases for all steps at once, then run only the scalar recursion step by step.
    zero = np.zeros((T, Z))
    ta_c, _, _, tm_c = step(zero, zero)
    ta_m, _, _, tm_m = (v - w for v, w in zip(step(zero + 1.0, zero), (ta_c, 0, 0, tm_c)))
    ta_q, _, _, tm_q = (v - w for v, w in zip(step(zero, zero + 1.0), (ta_c, 0, 0, tm_c)))
    hs = np.broadcast_to(series["heating_setpoint"], (T, Z))
    cs = np.broadcast_to(series["cooling_setpoint"], (T, Z))
    shading = "phi_sol_shaded" in series
    if shading:             # the device's effect on the air and the mass: another basis case, switched per step
        ta_s, _, _, tm_s = step(zero, zero, series["phi_sol_shaded"])
        ta_d, tm_d = ta_s - ta_c, tm_s - tm_c
        req_t = np.broadcast_to(series["shade_request"], (T, Z))
    else:
        ta_d = tm_d = np.zeros((1, Z))
        req_t = np.zeros((1, Z), bool)
    shaded = np.zeros((T, Z), bool)
    sp0 = float(np.nan_to_num(hs[0].min(), neginf=20.0, posinf=20.0))
    tm = np.full(Z, sp0 if temp_mass_start is None else float(temp_mass_start))
    order = list(range(min(warmup_steps, T))) + list(range(T))
    n_warm = len(order) - T
    tm_prev = np.empty((T, Z))
    need = np.empty((T, Z))
    if Z == 1 and not shading:       # plain floats: ~20x faster than numpy on 1-element arrays
        cols = [a[:, 0].tolist() for a in (ta_c, ta_m, ta_q, tm_c, tm_m, tm_q, hs, cs)]
        c0, c1, c2, m0, m1, m2, hs1, cs1 = cols
        x, hm, cm1 = float(tm[0]), float(hmax[0]), float(cmax[0])
        tp, nd = [0.0] * T, [0.0] * T
        for i, t in enumerate(order):
            ta0 = c0[t] + c1[t] * x
            q = 0.0
            if ta0 < hs1[t]:
                q = min((hs1[t] - ta0) / c2[t], hm)
            elif ta0 > cs1[t]:
                q = max((cs1[t] - ta0) / c2[t], -cm1)
            if i >= n_warm:
                tp[t], nd[t] = x, q
            x = m0[t] + m1[t] * x + m2[t] * q
        tm_prev[:, 0], need[:, 0] = tp, nd
    else:
        heated = np.zeros(Z, bool)
        for i, t in enumerate(order):
            down = req_t[t] & ~heated if shading else False
            ta0 = ta_c[t] + ta_m[t] * tm
            if shading:
                ta0 = ta0 + np.where(down, ta_d[t], 0.0)
            q = np.where(ta0 < hs[t], (hs[t] - ta0) / ta_q[t],
                         np.where(ta0 > cs[t], (cs[t] - ta0) / ta_q[t], 0.0))
            q = np.clip(q, -cmax, hmax)
            if i >= n_warm:
                tm_prev[t], need[t] = tm, q
                if shading:
                    shaded[t] = down
            tm = tm_c[t] + tm_m[t] * tm + tm_q[t] * q
            if shading:
                tm = tm + np.where(down, tm_d[t], 0.0)
                heated = q > 0.0
    phi_eff = np.where(shaded, np.broadcast_to(series["phi_sol_shaded"], (T, Z)), series["phi_sol"]) if shading \
        else series["phi_sol"]
    ta, ts, tmm, tm_t = step(tm_prev, need, phi_eff)
    out = {"temp_air": ta, "temp_surface": ts, "temp_mass": tmm, "temp_mass_end": tm_t,
           "heating": np.maximum(need, 0.0), "cooling": np.maximum(-need, 0.0)}
    if shading:
        out["shaded"] = shaded
    return out
