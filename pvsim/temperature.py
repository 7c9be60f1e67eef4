"""Cell temperature models (pvlib's names, parameters and defaults).

- Faiman (Prog. Photovolt. 16 (2008) 307): ``T_cell = T_air + G / (u0 + u1 v)``.
- PVsyst (PVsyst 6 help, "Array thermal losses"): ``T_cell = T_air + alpha G (1 - eta) / (u_c + u_v v)``.

G is the plane-of-array irradiance [W m-2], v the wind speed [m s-1], temperatures [degC].
"""

from __future__ import annotations

import numpy as np

__all__ = ["faiman", "pvsyst_cell", "TEMPERATURE_MODEL_PARAMETERS", "temperature_model_parameters"]

TEMPERATURE_MODEL_PARAMETERS = {
    "faiman": {
        # Faiman 2008 fit for open-rack glass/polymer c-Si (pvlib's defaults)
        "open_rack": {"u0": 25.0, "u1": 6.84},
    },
    "pvsyst": {
        # PVsyst's published heat-loss factors (free-standing, semi-integrated, integrated/insulated back)
        "freestanding": {"u_c": 29.0, "u_v": 0.0},
        "semi_integrated": {"u_c": 20.0, "u_v": 0.0},
        "insulated": {"u_c": 15.0, "u_v": 0.0},
    },
}


def temperature_model_parameters(model, mounting):
    """Parameters of ``model`` ("faiman", "pvsyst") for ``mounting``; a wrong key lists the valid ones."""
    if model not in TEMPERATURE_MODEL_PARAMETERS:
        raise KeyError(f"temperature model {model!r} unknown; valid: {', '.join(TEMPERATURE_MODEL_PARAMETERS)}")
    table = TEMPERATURE_MODEL_PARAMETERS[model]
    if mounting not in table:
        raise KeyError(f"mounting {mounting!r} unknown for {model}; valid: {', '.join(table)}")
    return dict(table[mounting])


def _arrays(poa_global, temp_air, wind_speed):
    g = np.asarray(poa_global, dtype=float)
    t = np.asarray(temp_air, dtype=float)
    v = np.asarray(wind_speed, dtype=float)
    if np.any(v < 0):
        raise ValueError(f"wind_speed must be >= 0 [m s-1], got min {np.nanmin(v)!r}")
    return g, t, v


def faiman(poa_global, temp_air, wind_speed=1.0, u0=25.0, u1=6.84):
    """Faiman cell/module temperature.

    Parameters
    ----------
    poa_global : array_like
        Plane-of-array irradiance [W m-2].
    temp_air : array_like
        Ambient air temperature [degC].
    wind_speed : array_like
        Wind speed at module height [m s-1], >= 0.
    u0 : float
        Constant heat transfer coefficient [W m-2 K-1], > 0.
    u1 : float
        Wind-dependent coefficient [W m-3 s K-1], >= 0.

    Returns
    -------
    numpy.ndarray
        Cell temperature [degC] (arrays broadcast).
    """
    g, t, v = _arrays(poa_global, temp_air, wind_speed)
    if not (u0 > 0 and u1 >= 0):
        raise ValueError(f"u0={u0!r} must be > 0 and u1={u1!r} >= 0 [W m-2 K-1]")
    return t + g / (u0 + u1 * v)


def pvsyst_cell(poa_global, temp_air, wind_speed=1.0, u_c=29.0, u_v=0.0, module_efficiency=0.1,
                alpha_absorption=0.9):
    """PVsyst cell temperature.

    Parameters
    ----------
    poa_global : array_like
        [W m-2].
    temp_air : array_like
        [degC].
    wind_speed : array_like
        [m s-1], >= 0.
    u_c : float
        Constant heat loss factor [W m-2 K-1], > 0.
    u_v : float
        Wind heat loss factor [W m-3 s K-1], >= 0.
    module_efficiency : float
        Fraction of the absorbed light converted to electricity [1], [0, 1).
    alpha_absorption : float
        Absorbed fraction of the irradiance [1], (0, 1].

    Returns
    -------
    numpy.ndarray
        Cell temperature [degC].
    """
    g, t, v = _arrays(poa_global, temp_air, wind_speed)
    if not (u_c > 0 and u_v >= 0):
        raise ValueError(f"u_c={u_c!r} must be > 0 and u_v={u_v!r} >= 0 [W m-2 K-1]")
    if not (0 <= module_efficiency < 1 and 0 < alpha_absorption <= 1):
        raise ValueError(f"module_efficiency={module_efficiency!r} must be in [0, 1) and "
                         f"alpha_absorption={alpha_absorption!r} in (0, 1]")
    return t + alpha_absorption * g * (1.0 - module_efficiency) / (u_c + u_v * v)
