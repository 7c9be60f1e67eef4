"""Directions and knots of a dataset build's fit grid: the product grids of view zeniths x relative azimuths the
reference solver is sampled on (:func:`fit_directions`, held-out :func:`validation_directions`, the ground response's
:func:`ground_directions`), their fit angles and solid-angle weights (:func:`direction_samples`, :func:`fit_weights`)
and the power-spaced knots of the fit (:func:`knots`, :func:`with_midpoints`).

Shared by the build (:mod:`widesky.skymodel.generator.dataset_build`), its solves
(:mod:`widesky.skymodel.generator.dataset_solve`) and the Monte Carlo states
(:mod:`widesky.skymodel.generator.dataset_mc`). Angles [deg] unless named [rad].
"""

from __future__ import annotations

import numpy as np

from ..evaluate import directions_from_angles, reference_angles
from .solver import MAX_VIEW_ZENITH_DEG

__all__ = ["AZIMUTHS_DEG", "SUN_OFFSETS_DEG", "fit_directions", "validation_directions", "ground_directions", "knots",
           "with_midpoints", "direction_samples", "fit_weights"]


AZIMUTHS_DEG = np.concatenate([[0.0, 0.25, 0.5, 1.0, 1.5, 2.5, 4.0, 6.0, 9.0, 12.5, 17.0, 22.0, 28.0, 35.0, 42.5],
                               np.arange(50.0, 180.1, 5.0)])
"""Relative azimuths of the fit grid [deg] (0 = toward the sun), refined near the sun; every 5 deg beyond 50 deg,
finer than the sun-angle knots there (6-9 deg), so that no knot cell of the fit goes unsampled (with 10 deg steps the
fit rang between the samples: docs/default-dataset.md, "Smoothness")."""


SUN_OFFSETS_DEG = np.array([0.25, 0.5, 1.0, 1.5, 2.5, 4.0, 6.0])
"""Offsets of extra view zeniths around the solar zenith [deg]."""



def fit_directions(solar_elevation_deg: float, zenith_step_deg: float = 2.0):
    """Product grid of the fit samples for one solar elevation.

    Returns
    -------
    zenith (T,) [deg] ascending in [0, 89.95], relative azimuth (P,) [deg] ascending in [0, 180]: uniform
    zeniths every ``zenith_step_deg`` plus the horizon band and zeniths around the sun; azimuths refined near
    the sun (:data:`AZIMUTHS_DEG`).
    """
    zs = 90.0 - float(solar_elevation_deg)
    th = np.concatenate([np.arange(0.0, 89.0, zenith_step_deg), [85.5, 87.0, 88.0, 89.0, MAX_VIEW_ZENITH_DEG],
                         zs + SUN_OFFSETS_DEG, zs - SUN_OFFSETS_DEG, [zs]])
    th = np.unique(np.round(np.clip(th, 0.0, MAX_VIEW_ZENITH_DEG), 6))
    return th, AZIMUTHS_DEG.copy()



def validation_directions(solar_elevation_deg: float):
    """Held-out product grid (no zenith or azimuth of :func:`fit_directions` except the horizon limit):
    zenith (T,) [deg], relative azimuth (P,) [deg]; fine enough for hemispherical integrals."""
    zs = 90.0 - float(solar_elevation_deg)
    off = np.array([0.375, 0.75, 1.25, 2.0, 3.25, 5.0, 7.5])
    th = np.concatenate([np.arange(0.75, 89.0, 1.5), [86.25, 87.5, 88.5, 89.5, MAX_VIEW_ZENITH_DEG],
                         zs + off, zs - off])
    th = np.unique(np.round(np.clip(th, 0.1, MAX_VIEW_ZENITH_DEG), 6))
    ph = np.concatenate([[0.125, 0.375, 0.75, 1.25, 2.0, 3.25, 5.0, 7.5, 10.75, 14.75, 19.5, 25.0, 31.5, 38.75, 46.25],
                         np.arange(55.0, 180.0, 5.0), [179.5]])
    return th, np.unique(ph)



def ground_directions():
    """Zeniths [deg] on which the ground response t_k(theta) is tabulated (interpolated elsewhere)."""
    return np.unique(np.concatenate([np.arange(0.0, 89.6, 0.5), [89.75, MAX_VIEW_ZENITH_DEG]]))



def knots(n: int, lo: float, hi: float, power: float, dense_at: str = "lo") -> np.ndarray:
    """``n`` ascending knots in [lo, hi] [rad], power-spaced: dense at ``lo`` (``dense_at='lo'``) or at ``hi``."""
    t = np.linspace(0.0, 1.0, int(n))
    if dense_at == "lo":
        return lo + (hi - lo) * t ** power
    return hi - (hi - lo) * (1.0 - t) ** power



def with_midpoints(breaks, lo: float, hi: float) -> np.ndarray:
    """``breaks`` (ascending) with the midpoint of every interval that lies inside [``lo``, ``hi``] inserted (same
    unit as ``breaks``). Pure array function."""
    b = np.asarray(breaks, float)
    inside = (b[:-1] >= lo) & (b[1:] <= hi)
    return np.sort(np.concatenate([b, 0.5 * (b[:-1] + b[1:])[inside]]))



def direction_samples(zenith_deg, azimuth_deg, solar_elevation_deg):
    """Sample directions of a product grid and their fit angles.

    Returns
    -------
    dict with directions (T*P, 3) east-north-up (sun toward the south), gamma, zero, shadow (T*P,) [rad] from
    :func:`widesky.skymodel.reference_angles`, alpha (the zenith factor's angle: zero with the sun up, shadow below the
    horizon) and solid-angle weights (T*P,) [sr] of the grid cells (whole circle: each half-circle azimuth counts
    twice).
    """
    th = np.asarray(zenith_deg, float)
    ph = np.asarray(azimuth_deg, float)
    T, P = np.meshgrid(th, ph, indexing="ij")
    dirs = directions_from_angles(T.ravel(), 180.0 + P.ravel())
    ang = reference_angles(dirs, float(solar_elevation_deg), 180.0)
    tr = np.radians(th)
    edges = np.concatenate([[tr[0]], 0.5 * (tr[1:] + tr[:-1]), [max(tr[-1], 0.5 * np.pi)]])
    band = np.cos(edges[:-1]) - np.cos(edges[1:])
    pr = np.radians(ph)
    pe = np.concatenate([[pr[0]], 0.5 * (pr[1:] + pr[:-1]), [pr[-1]]])
    w = 2.0 * np.outer(band, np.diff(pe)).ravel()
    alpha = ang["zero"] if float(solar_elevation_deg) >= 0 else ang["shadow"]
    return {"directions": dirs, "gamma": ang["gamma"], "zero": ang["zero"], "shadow": ang["shadow"], "alpha": alpha,
            "weights": w}



def fit_weights(solid_angle):
    """Fit weights from cell solid angles [sr]: the solid angle with a floor of a quarter of its median, so that
    the densely sampled aureole still counts."""
    w = np.asarray(solid_angle, float)
    return np.maximum(w, 0.25 * np.median(w))
