"""The reference solves of a dataset build, one sky state at a time: DISORT radiance of a grid state on the fit
directions (:func:`solve_state`), the ground response per visibility (:func:`solve_ground`) and the held-out
references of the validation states whose elevation takes the split Monte Carlo radiance
(:func:`solve_split_validation`). The build (:mod:`widesky.skymodel.generator.dataset_build`) caches and schedules them.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from .atmosphere import slant_path_factors
from .cache import load_state
from .dataset_grid import fit_directions, ground_directions, validation_directions
from .dataset_mc import (SPLIT_VALIDATION_SAMPLES_FACTOR, mc_file, rest_across_visibility, single_scatter,
                         solve_mc_state, split_radiance)
from .solver import SkyState, channel_problems, run_disort

__all__ = ["GROUND_RESPONSE_ELEVATION_DEG", "solve_state", "solve_split_validation", "solve_ground"]


GROUND_RESPONSE_ELEVATION_DEG = 60.0
"""Solar elevation of the albedo-0/1 pair of runs that measure the ground response [deg] (any value works)."""



def _problems(visibility_km, config, data_dir=None):
    state = SkyState(45.0, visibility_km=float(visibility_km), ground_albedo=0.0)
    probs, et_ch, atm = channel_problems(state, config.spec(), None, config.solver_config(), data_dir)
    return probs, et_ch, atm



def solve_state(visibility_km: float, solar_elevation_deg: float, config, zenith_deg=None,
                azimuth_deg=None, albedo: float = 0.0, data_dir=None, channels=None) -> dict:
    """Solve one sky state (ground albedo ``albedo``) on a product grid of directions.

    Parameters
    ----------
    visibility_km : [km]; solar_elevation_deg : [deg] in (0, 90];
    zenith_deg, azimuth_deg : (T,), (P,) view zeniths [deg] and relative azimuths [deg]; default
        :func:`fit_directions`.
    albedo : [1] Lambertian ground albedo.
    channels : channel indices (0..54) to solve (default all; the others stay 0).

    Returns
    -------
    dict with zenith (T,), azimuth (P,) [deg]; radiance (T, P, 55) [W m-2 sr-1 nm-1];
    e0 (list of 55 arrays, per sub-problem global horizontal irradiance at the ground per unit normal beam
    flux [1]); et (55,) band-mean extraterrestrial irradiance [W m-2 nm-1]; dni, ghi_disort, dhi (55,)
    [W m-2 nm-1] (dni along the spherical-shell path); seconds [s].
    """
    t0 = time.perf_counter()
    cfg = config.solver_config()
    probs, et_ch, atm = _problems(visibility_km, config, data_dir)
    if zenith_deg is None:
        zenith_deg, azimuth_deg = fit_directions(solar_elevation_deg, config.zenith_step_deg)
    th = np.asarray(zenith_deg, float)
    ph = np.asarray(azimuth_deg, float)
    mu0 = np.cos(np.radians(90.0 - solar_elevation_deg))
    f_sph = slant_path_factors(atm.levels_km, [90.0 - solar_elevation_deg])[0]
    rad = np.zeros((len(th), len(ph), 55))
    e0, dif = [], np.zeros(55)
    for c in range(55):
        ek = []
        for p in (probs[c] if channels is None or c in set(int(x) for x in channels) else ()):
            r, fd, fb = run_disort(p, mu0, albedo, th, ph, cfg)
            rad[:, :, c] += p.weight * r
            ek.append(fd + fb)
            dif[c] += p.weight * fd
        e0.append(np.array(ek))
    tdir = _direct_transmittance(probs, f_sph)
    return {"zenith": th, "azimuth": ph, "radiance": rad * et_ch, "e0": e0, "et": et_ch, "dni": et_ch * tdir,
            "dhi": dif * et_ch, "seconds": time.perf_counter() - t0,
            "weights": [np.array([p.weight for p in probs[c]]) for c in range(55)]}



def _direct_transmittance(probs, path_factors) -> np.ndarray:
    """Band transmittance of the direct beam per channel (55,) [1]: sum over the sub-problems of weight x
    exp(-sum_l tau_l s_l / dz_l) for the spherical-shell path factors (L,) of the sun's direction."""
    return np.array([sum(p.weight * np.exp(-(p.tau_total * path_factors).sum()) for p in probs[c])
                     for c in range(55)])



def solve_split_validation(visibility_km: float, elevation_deg: float, albedo: float, config,
                           data_dir=None) -> dict:
    """Held-out reference of a validation state whose elevation takes the split Monte Carlo radiance
    (:func:`widesky.skymodel.generator.dataset_mc.split_state`): the exact singly scattered light on the held-out grid
    (:func:`validation_directions`) plus the rest from the Monte Carlo state at that elevation: at a grid state the
    grid's own, smoothed across visibility as the fit's is
    (:func:`widesky.skymodel.generator.dataset_mc.rest_across_visibility` on the held-out grid), elsewhere a run of its own
    with :data:`widesky.skymodel.generator.dataset_mc.SPLIT_VALIDATION_SAMPLES_FACTOR` times the paths; the same keys as
    :func:`solve_state` uses for validation (zenith, azimuth [deg], radiance (T, P, 55) [W m-2 sr-1 nm-1] at
    ``albedo`` [1], dni, et (55,) [W m-2 nm-1], seconds)."""
    t0 = time.perf_counter()
    th, ph = validation_directions(elevation_deg)
    grid = mc_file(config, visibility_km, elevation_deg)
    vis = [float(v) for v in config.visibilities_km]
    if grid.exists() and float(visibility_km) in vis:
        m = load_state(grid)
        m.update(fine_zenith=th, fine_azimuth=ph,
                 single_fine=single_scatter(visibility_km, elevation_deg, th, ph, config, data_dir))
        rest = rest_across_visibility(config, elevation_deg, albedo, th, ph)[vis.index(float(visibility_km))]
        radiance = split_radiance(m, albedo, rest=rest)
    else:
        longer = replace(config, mc_samples=int(config.mc_samples) * SPLIT_VALIDATION_SAMPLES_FACTOR)
        m = solve_mc_state(visibility_km, elevation_deg, longer, data_dir, fine_directions=(th, ph))
        radiance = split_radiance(m, albedo)
    probs, et_ch, atm = _problems(visibility_km, config, data_dir)
    tdir = _direct_transmittance(probs, slant_path_factors(atm.levels_km, [90.0 - elevation_deg])[0])
    return {"zenith": th, "azimuth": ph, "radiance": radiance, "et": et_ch, "dni": et_ch * tdir,
            "solved_elevation": float(elevation_deg), "albedo": float(albedo), "seconds": time.perf_counter() - t0}



def solve_ground(visibility_km: float, config, data_dir=None) -> dict:
    """Ground response of the atmosphere per channel sub-problem (see module docstring).

    Returns
    -------
    dict with zenith (T,) [deg]; t (list of 55 arrays (K_c, T)) diffuse transmittance for isotropic illumination
    from below [1]; s (list of 55 arrays (K_c,)) spherical albedo [1]; weights (list of 55 (K_c,)); seconds.
    """
    t0 = time.perf_counter()
    cfg = config.solver_config()
    probs, _, _ = _problems(visibility_km, config, data_dir)
    th = ground_directions()
    ph = np.array([90.0, 135.0, 180.0])
    mu0 = np.cos(np.radians(90.0 - GROUND_RESPONSE_ELEVATION_DEG))
    ts, ss = [], []
    for c in range(55):
        tk, sk = [], []
        for p in probs[c]:
            r0, fd0, fb0 = run_disort(p, mu0, 0.0, th, ph, cfg)
            r1, fd1, fb1 = run_disort(p, mu0, 1.0, th, ph, cfg)
            e0, e1 = fd0 + fb0, fd1 + fb1
            if e1 <= 1e-30 or e0 <= 1e-30:
                tk.append(np.zeros(len(th)))
                sk.append(0.0)
                continue
            tk.append(np.pi * (r1 - r0).mean(axis=1) / e1)
            sk.append(1.0 - e0 / e1)
        ts.append(np.array(tk).reshape(len(probs[c]), len(th)))
        ss.append(np.array(sk))
    return {"zenith": th, "t": ts, "s": ss, "weights": [np.array([p.weight for p in probs[c]]) for c in range(55)],
            "seconds": time.perf_counter() - t0}
