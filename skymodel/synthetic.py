"""Synthetic Prague-Sky-Model-format datasets for tests, benchmarks and demos.

These are NOT physical skies. They have the right structure (rank decomposition, knots, grids,
transmittance factors, polarisation) and a sky-like look (Rayleigh-like blue, brighter aureole and
horizon, redder low sun), so every code path of the reader and evaluator can be exercised and the
renderer shows something plausible. ``roughness`` adds seeded random terms that make configurations
change sign inside cells (exercising the clamp at zero).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_outputs
from .writer import DatasetContents, write_dataset

__all__ = ["synthetic_contents", "write_synthetic_dataset"]


def _knots(n, lo, hi, power=1.5):
    t = np.linspace(0.0, 1.0, n) ** power
    return lo + (hi - lo) * t


def synthetic_contents(*, visibilities=(20.0, 60.0, 131.8), albedos=(0.0, 0.5, 1.0), altitudes=(0.0,),
                       elevations=None, n_channels=55, channel_start=280.0, channel_width=40.0, rank=4,
                       n_sun=24, n_zen=24, n_emph=16, polarisation=False, pol_rank=2, n_pol_sun=12,
                       n_pol_zen=12, trans_dims=(12, 8), trans_rank=3, roughness=0.0, seed=0) -> DatasetContents:
    """Build a synthetic dataset's contents (see module docstring). Grids: visibilities [km], albedos,
    altitudes [m], elevations [deg]; channels from ``channel_start`` [nm] every ``channel_width`` [nm]."""
    rng = np.random.default_rng(seed)
    if elevations is None:
        elevations = np.array([-4.2, -2.0, 0.0, 2.0, 5.0, 10.0, 15.0, 22.5, 30.0, 45.0, 60.0, 90.0])
    vis = np.asarray(visibilities, float)
    alb = np.asarray(albedos, float)
    alt = np.asarray(altitudes, float)
    ele = np.asarray(elevations, float)
    lam = channel_start + channel_width * (np.arange(n_channels) + 0.5)
    sb = _knots(n_sun, 0.0, np.pi, 1.6)
    zb = _knots(n_zen, 0.0, np.pi, 1.0)
    eb = _knots(n_emph, 0.0, np.pi, 1.0)
    G = (len(vis), len(alb), len(alt), len(ele), n_channels)
    V, A, H, E, L = np.meshgrid(vis, alb, alt, ele, lam, indexing="ij")
    # spectral shape: a smooth solar-like curve times Rayleigh + aerosol scattering
    solar = 1.8 * np.exp(-0.5 * ((L - 480.0) / 420.0) ** 2) + 0.15
    tau_r = 0.0088 * (L / 1000.0) ** -4.05
    tau_a = (3.912 / V - 0.0116) * 1.5 * (L / 550.0) ** -1.3
    sin_e = np.sin(np.radians(np.maximum(E, 0.5)))
    day = np.clip((E + 4.5) / 6.0, 0.02, 1.0)
    redden = np.exp(-(tau_r + tau_a) / (sin_e + 0.05))
    base = solar * day * (0.25 + 0.75 * redden) * (1.0 + 0.3 * A) * np.exp(-H / 8000.0)
    g = sb
    z = zb
    sun = np.empty(G + (rank, n_sun))
    zen = np.empty(G + (rank, n_zen))
    # rank 0: Rayleigh phase, airmass brightening towards the horizon
    sun[..., 0, :] = 0.75 * (1.0 + np.cos(g) ** 2)
    airm = 1.0 / np.maximum(np.cos(np.minimum(z, np.pi / 2)), 0.08)
    zen[..., 0, :] = (base * tau_r)[..., None] * (1.0 - np.exp(-0.3 * airm))[None] * 4.0
    if rank == 1:  # a single separable term: Rayleigh and aerosol brightness share the phase factor
        zen[..., 0, :] += (base * tau_a)[..., None] * np.exp(-0.2 * airm)[None] * 3.0
    else:  # rank 1: aerosol aureole
        width = 0.08 + 0.25 * (V / 131.8)
        sun[..., 1, :] = np.exp(-g[None, None, None, None, None, :] / width[..., None])
        zen[..., 1, :] = (base * tau_a)[..., None] * np.exp(-0.2 * airm)[None] * 3.0
    for r in range(2, rank):
        # small smooth corrections (a few % of the leading terms): the sky stays positive
        phase = rng.uniform(0, np.pi)
        sun[..., r, :] = np.cos(r * g + phase)
        zen[..., r, :] = 0.03 / r * (zen[..., 0, :] + zen[..., 1, :]) * np.sin((r - 1) * z + phase)[None]
    emph = np.broadcast_to(1.0 + 0.4 * np.exp(-(np.pi / 2 - np.minimum(eb, np.pi / 2)) / 0.15), G + (n_emph,)).copy()
    if roughness > 0:
        sun += roughness * rng.uniform(-1, 1, sun.shape)
        zen += roughness * rng.uniform(-1, 1, zen.shape) * base[..., None, None]
        emph += roughness * rng.uniform(-1, 1, emph.shape)
    # transmittance: sqrt(T) in [0, 1]
    ddim, adim = trans_dims
    d = np.linspace(0, 1, ddim)[:, None]
    a = np.linspace(0, 1, adim)[None, :]
    alt_t = np.asarray(alt, np.float32)
    vis_t = np.asarray(vis, np.float32)
    U = np.empty((len(alt_t), ddim, adim, trans_rank))
    for r in range(trans_rank):
        U[..., r] = (np.exp(-(r + 1) * 2.5 * d ** 4 * (1.2 - a) ** 3) / trans_rank)[None]
    U *= 1.0 - 0.05 * rng.random(U.shape)
    Vt = np.empty((len(vis_t), len(alt_t), n_channels, trans_rank))
    tau_tot = (0.0088 * (lam / 1000.0) ** -4.05)[None, :] + (3.912 / vis_t[:, None] - 0.0116) * 1.5 * (lam / 550) ** -1.3
    for r in range(trans_rank):
        Vt[..., r] = np.exp(-tau_tot / (r + 1))[:, None, :]
    Vt = np.clip(Vt, 0, 1)
    contents = DatasetContents(vis, alb, alt, ele, channel_start, channel_width, sb, zb, eb, sun, zen, emph,
                               alt_t, vis_t, U.astype(np.float32), Vt.astype(np.float32))
    if polarisation:
        psb = _knots(n_pol_sun, 0.0, np.pi, 1.0)
        pzb = _knots(n_pol_zen, 0.0, np.pi, 1.0)
        ps = np.empty(G + (pol_rank, n_pol_sun))
        pz = np.empty(G + (pol_rank, n_pol_zen))
        ps[..., 0, :] = np.sin(psb) ** 2 / (1 + np.cos(psb) ** 2)
        pz[..., 0, :] = -(0.8 * (V / 131.8) ** 0.3)[..., None] * np.ones(n_pol_zen)
        for r in range(1, pol_rank):
            ps[..., r, :] = 0.1 * np.cos(r * psb)
            pz[..., r, :] = 0.1 * rng.uniform(-1, 1, G + (n_pol_zen,))
        contents.pol_sun_breaks, contents.pol_zenith_breaks = psb, pzb
        contents.pol_sun, contents.pol_zen = ps.astype(np.float32), pz.astype(np.float32)
    return contents


def write_synthetic_dataset(path, description="synthetic dataset", **kwargs) -> Path:
    """Write a synthetic dataset (see :func:`synthetic_contents` for the keyword arguments) and its
    JSON sidecar marking it as synthetic; returns the path."""
    path = Path(path)
    c = synthetic_contents(**kwargs)
    write_dataset(path, c)
    meta = {"synthetic": True, "description": description,
            "generator": "widesky.skymodel.synthetic.synthetic_contents",
            "parameters": {k: (list(v) if isinstance(v, (tuple, list, np.ndarray)) else v) for k, v in kwargs.items()}}
    with atomic_outputs(path.with_suffix(path.suffix + ".json")) as (tmp,):
        tmp.write_text(json.dumps(meta, indent=1, default=float))
    return path
