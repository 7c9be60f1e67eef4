"""Stage 2 of :func:`widesky.irradiance.poa_irradiance`: the sky of every daylight step, in chunks.

The sky model per chunk of steps (:func:`sky_chunk`), contracted with the columns, scaled by the
Earth-Sun distance, the per-step (and per-channel) factors and the measured-weather match
(:mod:`widesky.irradiance.step_scaling`); :func:`evaluate_sky` runs it over the whole period in chunks
sorted by sky state while the ray-casting tasks run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .allsky_sky import allsky_patch_radiance
from .integrator import horizontal_diffuse, patch_radiance
from .measured import measured_scale_factors
from .output_plan import sky_state_order
from .patches import cosine_weights, reinhart
from .step_scaling import StepScaling

__all__ = ["SkyTerms", "sky_chunk", "evaluate_sky"]


@dataclass(frozen=True, eq=False)
class SkyTerms:
    """The contracted sky of the daylight steps (:func:`evaluate_sky`).

    Attributes
    ----------
    Lp : numpy.ndarray
        (T_lit, P, columns) float32 contracted patch radiance [W m-2 sr-1 x weight unit].
    dni : numpy.ndarray
        (T_lit, columns) contracted direct normal irradiance [W m-2 x weight unit].
    pos : numpy.ndarray
        (T,) row of each step in ``Lp`` and ``dni`` (-1: not lit).
    n_patches : int
        P, sky patches.
    seconds : float
        Time spent in the sky model [s].
    """

    Lp: np.ndarray
    dni: np.ndarray
    pos: np.ndarray
    n_patches: int
    seconds: float

    def take(self, idx):
        """(Lp float64, dni) of steps ``idx``."""
        return self.Lp[self.pos[idx]].astype(np.float64), self.dni[self.pos[idx]]


def sky_chunk(sky, patches, states, Wall, settings, scaling: StepScaling, w_horizontal, idx):
    """Contracted patch radiance (Tc, P, columns) and direct normal irradiance (Tc, columns) of steps
    ``idx``; fills ``scaling``'s per-step factors (and the model's DNI/DHI, the all-sky ground) at ``idx``."""
    st = states.take(idx)
    sc = scaling
    if sc.allsky is not None:                      # all-sky model: factors per step and channel
        Lp, dni, f, (sc.model[0][idx], sc.model[1][idx]), g = allsky_patch_radiance(
            sky, patches, st, Wall, settings, sc.allsky[0].take(idx), sc.allsky[1], sc.allsky[2],
            ground_shape=sc.ground_shape)
        if g is not None:
            sc.ground_steps[0][idx], sc.ground_steps[1][idx] = g
        sc.sun[idx], sc.sky[idx] = f.scaling.sun_scale, f.scaling.sky_scale
        return Lp, dni
    Lp, dni, cs = patch_radiance(sky, patches, st, Wall, settings,
                                 sun_scale=None if sc.ch_sun is None else sc.ch_sun[idx],
                                 sky_scale=None if sc.ch_sky is None else sc.ch_sky[idx])
    if sc.measured is not None:                    # column 0 is broadband: the model's DNI, DHI
        model_dni, model_dhi = sc.model
        model_dni[idx] = dni[:, 0]
        model_dhi[idx] = horizontal_diffuse(Lp[..., 0], cs[:, 0], w_horizontal, st.sun_elevation)
        f = measured_scale_factors(model_dni[idx], model_dhi[idx], sc.measured[0][idx], sc.measured[1][idx],
                                   missing="clear")
        sc.sun[idx], sc.sky[idx] = f.sun_scale, f.sky_scale
    # circumsolar light travels with the sun but is sky light: it takes the sky's scale
    dni = dni * sc.sun[idx][:, None] + cs * sc.sky[idx][:, None]
    Lp *= sc.sky[idx][:, None, None]
    return Lp, dni


def evaluate_sky(sky, states, settings, Wall, scaling: StepScaling, lit) -> SkyTerms:
    """The sky of every daylight step ``lit``, evaluated in chunks sorted by sky state over the whole period
    (equal states share a sky-model call; output blocks of consecutive steps would split them); kept
    contracted (T_lit x P x columns, float32: small)."""
    patches = reinhart(settings.mf)
    P = patches.n_patches
    w_horizontal = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]      # (P,) [sr]
    T = len(states)
    pos = np.full(T, -1)
    pos[lit] = np.arange(lit.size)
    Lp_all = np.zeros((lit.size, P, Wall.shape[1]), np.float32)
    dni_all = np.zeros((lit.size, Wall.shape[1]))
    # steps that share sky-model work next to each other (the sky's own order where it has one)
    order = sky.state_order(states, lit) if hasattr(sky, "state_order") else sky_state_order(states, lit)
    seconds = 0.0
    for c0 in range(0, order.size, settings.time_chunk):
        idx = np.sort(order[c0:c0 + settings.time_chunk])
        t0 = time.perf_counter()
        Lp_c, dni_c = sky_chunk(sky, patches, states, Wall, settings, scaling, w_horizontal, idx)
        seconds += time.perf_counter() - t0
        Lp_all[pos[idx]] = Lp_c
        dni_all[pos[idx]] = dni_c
    return SkyTerms(Lp_all, dni_all, pos, P, seconds)
