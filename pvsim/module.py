"""Module model on channel-contracted irradiance: short-circuit current, effective irradiance,
spectral mismatch, low-irradiance and temperature corrections, tandem sub-cell currents, bifacial
gain, DC power and the inverter.

Everything is an array function. Channel quantities carry the sky's channels (default the PSM's 55
channels of 40 nm, 280-2480 nm): ``sr_channels`` (C,) [A W-1] are band averages of the cell's SR, so
``J = sum_c SR_c E_c dlambda_c`` [A m-2] with E_c the band-mean spectral irradiance [W m-2 nm-1] -- the
contraction the integrator does for a ``Response`` with ``unit="sr"`` or ``"qe"``.

Effective irradiance follows pvlib's meaning (after optical and spectral losses) [W m-2]:
``E_eff = 1000 * P_cell(J) / P_cell(J_ref)`` where ``J_ref`` are the sub-cell currents under the
reference spectrum (AM1.5G) at 1000 W m-2 and ``P_cell`` is the cell's power at those currents with
fixed voltages: ``J`` itself for a single junction, the 2T/4T stack rule for a tandem. DC power is
``P = eta_stc * area * E_eff * eta_rel(E_eff) * (1 + gamma_pdc (T_cell - 25))`` -- pvlib's PVWatts DC
model times the low-irradiance factor (which is 1 when ``low_irradiance_200 = 1``).
"""

from __future__ import annotations

import numpy as np

from .spectra import am15g_channels, band_average, channel_edges, qe_to_sr
from .technologies import CellTechnology, TandemTechnology, get_technology

__all__ = ["channel_sr", "short_circuit_current", "reference_currents", "stack_power",
           "effective_irradiance", "spectral_mismatch", "low_irradiance_factor", "temperature_factor",
           "dc_power", "pvwatts_inverter", "current_mismatch_loss", "tandem_stc_efficiency",
           "bifacial_effective_irradiance", "G_STC", "T_STC"]

G_STC = 1000.0   # W m-2
T_STC = 25.0     # degC
_FINE_STEP_NM = 1.0


def channel_sr(technology, edges=None):
    """Band-averaged spectral response of each sub-cell on the sky's channels.

    Parameters
    ----------
    technology : str, CellTechnology or TandemTechnology
    edges : array_like (C+1,), optional
        Channel edges [nm] (default the PSM's 55 channels).

    Returns
    -------
    dict
        sub-cell name -> (C,) mean SR over each channel [A W-1] (the SR evaluated on a 1 nm grid and
        integrated exactly as a piecewise linear curve).
    """
    tech = get_technology(technology)
    e = channel_edges() if edges is None else np.asarray(edges, dtype=float)
    w = np.arange(e[0], e[-1] + 0.5 * _FINE_STEP_NM, _FINE_STEP_NM)
    return {name: band_average(w, qe_to_sr(qe, w), e[:-1], e[1:])
            for name, qe in tech.subcell_qe(w).items()}


def short_circuit_current(spectral_irradiance, sr_channels, edges=None):
    """Short-circuit current density from band-mean spectral irradiance.

    Parameters
    ----------
    spectral_irradiance : array_like (..., C)
        Band-mean spectral irradiance [W m-2 nm-1].
    sr_channels : array_like (C,)
        Band-mean SR [A W-1].
    edges : array_like (C+1,), optional
        Channel edges [nm].

    Returns
    -------
    numpy.ndarray (...)
        [A m-2].
    """
    e = channel_edges() if edges is None else np.asarray(edges, dtype=float)
    s = np.asarray(sr_channels, dtype=float)
    E = np.asarray(spectral_irradiance, dtype=float)
    if s.shape != (e.size - 1,) or E.shape[-1] != s.size:
        raise ValueError(f"spectral_irradiance (..., {E.shape[-1]}) and sr_channels {s.shape} must match "
                         f"the {e.size - 1} channels")
    return E @ (s * np.diff(e))


def reference_currents(technology, edges=None, reference=None, reference_path=None):
    """Sub-cell currents under the reference spectrum at 1000 W m-2 (STC).

    Parameters
    ----------
    technology : str, CellTechnology or TandemTechnology
    edges : array_like (C+1,), optional
        Channel edges [nm].
    reference : array_like (C,), optional
        Band-mean reference spectrum [W m-2 nm-1]; default ASTM G173 global tilted (AM1.5G) read from
        ``reference_path`` or the input data directory.

    Returns
    -------
    dict
        sub-cell name -> J_ref [A m-2], computed on the channels exactly as the yield run's currents.
    """
    e = channel_edges() if edges is None else np.asarray(edges, dtype=float)
    ref = am15g_channels(e, reference_path) if reference is None else np.asarray(reference, dtype=float)
    return {k: float(short_circuit_current(ref, v, e)) for k, v in channel_sr(technology, e).items()}


def _currents(technology, currents):
    names = technology.subcells
    missing = [n for n in names if n not in currents]
    if missing:
        raise ValueError(f"currents lack sub-cell(s) {missing}; got {sorted(currents)}")
    return [np.asarray(currents[n], dtype=float) for n in names]


def stack_power(technology, currents):
    """Cell power density at fixed voltages from the sub-cell currents.

    Parameters
    ----------
    technology : CellTechnology or TandemTechnology
    currents : dict
        sub-cell name -> J [A m-2] (arrays broadcast).

    Returns
    -------
    numpy.ndarray
        Single junction: J [A m-2] (the voltage is folded into eta_stc); tandem: 2T
        ``min(J_top, J_bot) (V_top + V_bot)``, 4T ``J_top V_top + J_bot V_bot`` [W m-2] (before
        ``module_factor``).
    """
    tech = get_technology(technology)
    js = _currents(tech, currents)
    if isinstance(tech, CellTechnology):
        return js[0]
    vt, vb = tech.voltages
    if tech.terminals == 2:
        return np.minimum(js[0], js[1]) * (vt + vb)
    return js[0] * vt + js[1] * vb


def current_mismatch_loss(technology, currents):
    """A 2T stack's loss to current mismatch, relative to each sub-cell at its own current [1].

    ``1 - sum(min(J_t, J_b) (V_t + V_b)) / sum(J_t V_t + J_b V_b)`` over all given steps (pass annual
    series for the annual loss; sums weight by energy). 0 for a 4T stack or a single junction.
    """
    tech = get_technology(technology)
    if not isinstance(tech, TandemTechnology) or tech.terminals == 4:
        return 0.0
    jt, jb = _currents(tech, currents)
    vt, vb = tech.voltages
    free = np.sum(jt * vt + jb * vb)
    return float(1.0 - np.sum(np.minimum(jt, jb) * (vt + vb)) / free) if free > 0 else 0.0


def tandem_stc_efficiency(technology, edges=None, reference=None, reference_path=None):
    """Module efficiency at STC [1] of a tandem from its voltage model under the reference spectrum
    (``module_factor * stack_power(J_ref) / 1000``); a single junction returns its ``eta_stc``."""
    tech = get_technology(technology)
    if isinstance(tech, CellTechnology):
        return tech.eta_stc
    jref = reference_currents(tech, edges, reference, reference_path)
    return float(tech.module_factor * stack_power(tech, jref) / G_STC)


def effective_irradiance(technology, currents, jref):
    """Effective irradiance [W m-2]: ``1000 P_cell(J) / P_cell(J_ref)`` (pvlib's meaning: after the
    optical and spectral losses that are in the currents).

    ``J`` comes from the sky's in-band (280-2480 nm) spectrum and ``J_ref`` from AM1.5G over the same channels
    (992.48 of its 1000 W m-2; cells collect nothing beyond 2480 nm): no broadband rescaling enters, and under a
    weather file the sky carries the measured DNI/DHI times :func:`widesky.core.spectral.in_band_share`, so
    nothing beyond 2480 nm is counted twice (docs/pvsim.md, "Weather files and the 280-2480 nm band").

    Parameters
    ----------
    technology : str, CellTechnology or TandemTechnology
    currents, jref : dict
        sub-cell name -> J [A m-2]; the reference currents from :func:`reference_currents`.
    """
    tech = get_technology(technology)
    p_ref = float(stack_power(tech, jref))
    if not p_ref > 0:
        raise ValueError(f"reference power of {tech.name!r} is {p_ref!r}: the cell collects nothing "
                         "under the reference spectrum")
    return G_STC * stack_power(tech, currents) / p_ref


def spectral_mismatch(effective, broadband, broadband_ref):
    """Spectral mismatch factor M (IEC 60904-7) [1].

    ``M = (E_eff / 1000) / (G / G_ref)``: the effective irradiance relative to STC divided by the
    broadband irradiance relative to the reference's over the same wavelength range.

    Parameters
    ----------
    effective : array_like
        Effective irradiance computed from the spectral irradiance alone (no angular optics) [W m-2].
    broadband : array_like
        Broadband irradiance over the channels (280-2480 nm for the PSM) [W m-2].
    broadband_ref : float
        Reference spectrum's irradiance over the same channels [W m-2] (AM1.5G 280-2480 nm: 992.48).

    Returns
    -------
    numpy.ndarray
        M [1]; NaN where ``broadband`` <= 0.
    """
    g = np.asarray(broadband, dtype=float)
    e = np.asarray(effective, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(g > 0, (e / G_STC) / (g / broadband_ref), np.nan)


def low_irradiance_factor(effective, low_irradiance_200):
    """Relative efficiency at low irradiance, 25 degC [1].

    ``eta_rel = 1 + a ln(E / 1000)`` with ``a = (low_irradiance_200 - 1) / ln(0.2)``: 1 at 1000 W m-2,
    the datasheet figure at 200 W m-2 (the first-order term of the Heydenreich et al. 2008 and Driesse
    & Stein 2020 (ADR) models); clipped at 0 below; 0 where ``effective`` <= 0. Above 1000 W m-2 it
    continues the same law.

    Parameters
    ----------
    effective : array_like
        [W m-2].
    low_irradiance_200 : float
        Relative efficiency at 200 W m-2 [1].
    """
    e = np.asarray(effective, dtype=float)
    a = (low_irradiance_200 - 1.0) / np.log(0.2)
    pos = e > 0
    rel = np.where(pos, e, 1.0)                    # in place below: large (T, F) arrays
    rel /= G_STC
    np.log(rel, out=rel)
    rel *= a
    rel += 1.0
    np.maximum(rel, 0.0, out=rel)
    rel[~pos] = 0.0
    return rel


def temperature_factor(temp_cell, gamma_pdc, temp_ref=T_STC):
    """``1 + gamma_pdc (T_cell - temp_ref)`` [1] (pvlib's PVWatts form); ``temp_cell`` [degC],
    ``gamma_pdc`` [1/K]."""
    out = np.array(temp_cell, dtype=float)
    out -= temp_ref
    out *= gamma_pdc
    out += 1.0
    return out


def bifacial_effective_irradiance(front, back, bifaciality):
    """``E_front + bifaciality * E_back`` [W m-2]; ``bifaciality`` [1] in [0, 1]."""
    if not 0.0 <= bifaciality <= 1.0:
        raise ValueError(f"bifaciality={bifaciality!r} outside the valid range [0, 1]")
    return np.asarray(front, dtype=float) + bifaciality * np.asarray(back, dtype=float)


def dc_power(effective, temp_cell, pdc0, gamma_pdc, low_irradiance_200=1.0):
    """DC power [W]: ``pdc0 * E/1000 * eta_rel(E) * (1 + gamma_pdc (T_cell - 25))``.

    Parameters
    ----------
    effective : array_like
        Effective irradiance [W m-2].
    temp_cell : array_like
        [degC].
    pdc0 : float or array_like
        DC rating at STC [W] (``eta_stc * area``  * 1000 W m-2).
    gamma_pdc : float
        [1/K].
    low_irradiance_200 : float
        Relative efficiency at 200 W m-2 [1]; 1 gives pvlib's ``pvwatts_dc`` exactly.
    """
    e = np.asarray(effective, dtype=float)
    return (np.asarray(pdc0, dtype=float) * e / G_STC * low_irradiance_factor(e, low_irradiance_200)
            * temperature_factor(temp_cell, gamma_pdc))


def pvwatts_inverter(pdc, pdc0, eta_inv_nom=0.96, eta_inv_ref=0.9637):
    """PVWatts inverter (Dobos, NREL/TP-6A20-62641, 2014), pvlib's ``inverter.pvwatts`` parameters.

    ``eta = eta_inv_nom / eta_inv_ref * (-0.0162 z - 0.0059 / z + 0.9858)``, ``z = pdc / pdc0``;
    AC power ``eta * pdc`` limited to [0, ``eta_inv_nom * pdc0``] (eta < 0 below z = 0.006); 0 where
    ``pdc`` <= 0.

    Parameters
    ----------
    pdc : array_like
        DC input [W].
    pdc0 : float
        DC input limit [W], > 0.

    Returns
    -------
    numpy.ndarray
        AC power [W].
    """
    if not pdc0 > 0:
        raise ValueError(f"pdc0={pdc0!r} must be > 0 [W]")
    p = np.asarray(pdc, dtype=float)
    z = np.where(p > 0, p / pdc0, 1.0)
    eta = eta_inv_nom / eta_inv_ref * (-0.0162 * z - 0.0059 / z + 0.9858)
    return np.where(p > 0, np.clip(eta * p, 0.0, eta_inv_nom * pdc0), 0.0)
