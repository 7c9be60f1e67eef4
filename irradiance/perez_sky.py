"""The Perez all-weather sky: the angular distribution of diffuse light under any sky, from DNI and DHI.

Perez, Seals & Michalsky (1993), "All-weather model for sky luminance distribution -- preliminary
configuration and validation", Solar Energy 50(3), 235-245 ([PSM93]). The relative radiance of a sky
element at zenith angle ``theta`` and angle ``gamma`` from the sun is

    l(theta, gamma) = [1 + a exp(b / cos theta)] [1 + c exp(d gamma) + e cos^2 gamma]

(a gradation term: with ``a < 0`` the horizon is brighter than the zenith; an indicatrix: circumsolar
brightening ``c exp(d gamma)`` and forward/back scattering ``e cos^2 gamma``). Each coefficient is
``x1 + x2 Z + Delta (x3 + x4 Z)`` of the sun's zenith ``Z`` [rad] and the sky brightness ``Delta``, with
``(x1..x4)`` from the published table for the sky-clearness bin of ``epsilon``
(:data:`PEREZ_1993_COEFFICIENTS`); in the first (overcast) bin ``c`` and ``d`` take the paper's special forms
``c = exp((Delta (c1 + c2 Z))^c3) - c4`` and ``d = -exp(Delta (d1 + d2 Z)) + d3 + Delta d4``. The clearness
and brightness are those of the Perez et al. (1990) irradiance model, from the measured DHI and DNI:
``epsilon = ((DHI + DNI) / DHI + k Z^3) / (1 + k Z^3)``, ``k = 1.041``, ``Delta = DHI m / E0``
(:func:`perez_clearness_brightness`).

The model was fitted to luminance (photopic) scans; as in daylight-coefficient practice (Radiance's
``gendaymtx``) it is used here as the broadband angular shape of the diffuse light; the absolute level is set
by normalising the distribution to the measured diffuse horizontal irradiance
(:func:`perez_patch_shape`). Spectral composition is not the model's business: the all-sky model
(:mod:`widesky.irradiance.allsky`) gives the cloud light its spectrum and this module only its directions
(docs/all-sky.md, section 1, step 5).

Guards (the fit's domain; none changes a sky inside it): ``epsilon`` in [1, 12] and ``Delta`` in
[0.01, 0.6] (the ranges of the fitted data, PSM93); in bins 2-5 (``1.065 <= epsilon < 2.8``) ``Delta`` at
least 0.2 (the floor Radiance's ``gendaylit`` also applies), below which the published coefficients give
a negative zenith radiance (bin 2, sun 10 deg high, ``Delta = 0.05``: ``1 + a exp(b) = -0.62``; bin 3, sun
57 deg high, ``Delta = 0.05``: -0.18); ``b <= 0`` (the gradation term finite at the horizon) and the radiance
clipped at 0.
"""

from __future__ import annotations

import numpy as np

from .haze import relative_airmass

__all__ = ["PEREZ_1993_COEFFICIENTS", "PEREZ_1993_EPSILON_EDGES", "perez_clearness_brightness",
           "perez_sky_coefficients", "perez_relative_radiance", "perez_patch_shape", "perez_poa_ratio",
           "cie_patch_shape", "cloud_patch_shape"]

PEREZ_1993_EPSILON_EDGES = (1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2)
"""Upper edges of the first seven sky-clearness bins [1] (the eighth is open); the bins of Perez et al. (1990)."""

PEREZ_1993_COEFFICIENTS = np.array([
    # bin 1, epsilon 1.000-1.065 (overcast)
    [[1.3525, -0.2576, -0.2690, -1.4366], [-0.7670, 0.0007, 1.2734, -0.1233], [2.8000, 0.6004, 1.2375, 1.0000],
     [1.8734, 0.6297, 0.9738, 0.2809], [0.0356, -0.1246, -0.5718, 0.9938]],
    # bin 2, 1.065-1.230
    [[-1.2219, -0.7730, 1.4148, 1.1016], [-0.2054, 0.0367, -3.9128, 0.9156], [6.9750, 0.1774, 6.4477, -0.1239],
     [-1.5798, -0.5081, -1.7812, 0.1080], [0.2624, 0.0672, -0.2190, -0.4285]],
    # bin 3, 1.230-1.500
    [[-1.1000, -0.2515, 0.8952, 0.0156], [0.2782, -0.1812, -4.5000, 1.1766],
     [24.7219, -13.0812, -37.7000, 34.8438], [-5.0000, 1.5218, 3.9229, -2.6204],
     [-0.0156, 0.1597, 0.4199, -0.5562]],
    # bin 4, 1.500-1.950
    [[-0.5484, -0.6654, -0.2672, 0.7117], [0.7234, -0.6219, -5.6812, 2.6297],
     [33.3389, -18.3000, -62.2500, 52.0781], [-3.5000, 0.0016, 1.1477, 0.1062],
     [0.4659, -0.3296, -0.0876, -0.0329]],
    # bin 5, 1.950-2.800
    [[-0.6000, -0.3566, -2.5000, 2.3250], [0.2937, 0.0496, -5.6812, 1.8415],
     [21.0000, -4.7656, -21.5906, 7.2492], [-3.5000, -0.1554, 1.4062, 0.3988],
     [0.0032, 0.0766, -0.0656, -0.1294]],
    # bin 6, 2.800-4.500
    [[-1.0156, -0.3670, 1.0078, 1.4051], [0.2875, -0.5328, -3.8500, 3.3750],
     [14.0000, -0.9999, -7.1406, 7.5469], [-3.4000, -0.1078, -1.0750, 1.5702],
     [-0.0672, 0.4016, 0.3017, -0.4844]],
    # bin 7, 4.500-6.200
    [[-1.0000, 0.0211, 0.5025, -0.5119], [-0.3000, 0.1922, 0.7023, -1.6317],
     [19.0000, -5.0000, 1.2438, -1.9094], [-4.0000, 0.0250, 0.3844, 0.2656],
     [1.0468, -0.3788, -2.4517, 1.4656]],
    # bin 8, epsilon > 6.2 (clear)
    [[-1.0500, 0.0289, 0.4260, 0.3590], [-0.3250, 0.1156, 0.7781, 0.0025],
     [31.0625, -14.5000, -46.1148, 55.3750], [-7.2312, 0.4050, 13.3500, 0.6234],
     [1.5000, -0.6426, 1.8564, 0.5636]],
])
"""(8, 5, 4) coefficients ``(x1, x2, x3, x4)`` of ``a, b, c, d, e`` per sky-clearness bin: Perez, Seals &
Michalsky (1993), Solar Energy 50(3), 235-245, Table 1 (the values as distributed with Radiance's gendaylit
agree to every digit, checked 2026-12-05)."""

EPSILON_RANGE = (1.0, 12.0)
"""Sky clearness range [1] the coefficients are used over (clipped)."""

DELTA_RANGE = (0.01, 0.6)
"""Sky brightness range [1] the coefficients are used over (clipped)."""

DELTA_MIN_INTERMEDIATE = 0.2
"""Lowest sky brightness [1] used in bins 2-5 (``1.065 <= epsilon < 2.8``), module docstring."""


def perez_clearness_brightness(dhi, dni, sun_elevation, dni_extra=1361.0):
    """Sky clearness ``epsilon`` and brightness ``Delta`` of Perez et al. (1990, 1993) from measured irradiance.

    ``epsilon = ((DHI + DNI) / DHI + k z^3) / (1 + k z^3)``, ``k = 1.041``, ``z`` the sun's zenith [rad];
    ``Delta = DHI m / E0`` with ``m`` the Kasten-Young relative air mass and ``E0`` the extraterrestrial normal
    irradiance.

    Parameters
    ----------
    dhi, dni : array_like
        (T,) diffuse horizontal and direct normal irradiance [W m-2] (NaN DNI counts as 0).
    sun_elevation : array_like
        (T,) apparent sun elevation [deg].
    dni_extra : array_like
        Extraterrestrial normal irradiance [W m-2], scalar or (T,).

    Returns
    -------
    (epsilon, delta, ok) : (T,) [1], [1], bool
        ``ok`` where the sun is up and DHI > 0; elsewhere ``epsilon = 1``, ``delta = 0``.
    """
    d = np.nan_to_num(np.asarray(dhi, dtype=float))
    b = np.maximum(np.nan_to_num(np.asarray(dni, dtype=float)), 0.0)
    el = np.asarray(sun_elevation, dtype=float)
    z = np.radians(90.0 - np.clip(el, 0.0, 90.0))
    ok = (d > 0) & (el > 0)
    dd = np.where(ok, d, 1.0)
    k = 1.041 * z ** 3
    eps = np.where(ok, ((dd + b) / dd + k) / (1.0 + k), 1.0)
    am = np.nan_to_num(relative_airmass(np.where(ok, el, 45.0)))
    delta = np.where(ok, dd * am / np.asarray(dni_extra, dtype=float), 0.0)
    return eps, delta, ok


def perez_sky_coefficients(epsilon, delta, sun_zenith):
    """The five coefficients ``a, b, c, d, e`` of the all-weather sky (PSM93), with the module's guards.

    Parameters
    ----------
    epsilon, delta : array_like
        (T,) sky clearness and brightness [1] (:func:`perez_clearness_brightness`).
    sun_zenith : array_like
        (T,) sun zenith angle [rad].

    Returns
    -------
    numpy.ndarray
        (T, 5) ``a, b, c, d, e`` [1] (``d`` per radian of ``gamma``).
    """
    eps = np.clip(np.asarray(epsilon, dtype=float), *EPSILON_RANGE)
    dl = np.clip(np.asarray(delta, dtype=float), *DELTA_RANGE)
    z = np.asarray(sun_zenith, dtype=float)
    k = np.searchsorted(PEREZ_1993_EPSILON_EDGES, eps, side="right")
    dl = np.where((k >= 1) & (k <= 4), np.maximum(dl, DELTA_MIN_INTERMEDIATE), dl)
    x = PEREZ_1993_COEFFICIENTS[k]                                   # (T, 5, 4)
    out = x[..., 0] + x[..., 1] * z[..., None] + dl[..., None] * (x[..., 2] + x[..., 3] * z[..., None])
    first = k == 0                                                    # the overcast bin's own forms
    if np.any(first):
        c1, c2, c3, c4 = PEREZ_1993_COEFFICIENTS[0, 2]
        d1, d2, d3, d4 = PEREZ_1993_COEFFICIENTS[0, 3]
        zf, df = np.broadcast_to(z, k.shape)[first], dl[first]
        out[first, 2] = np.exp(np.maximum(df * (c1 + c2 * zf), 0.0) ** c3) - c4
        out[first, 3] = -np.exp(df * (d1 + d2 * zf)) + d3 + df * d4
    out[..., 1] = np.minimum(out[..., 1], 0.0)
    return out


def perez_relative_radiance(cos_theta, cos_gamma, coefficients):
    """Relative radiance ``[1 + a exp(b / cos theta)] [1 + c exp(d gamma) + e cos^2 gamma]`` [1], >= 0.

    Parameters
    ----------
    cos_theta, cos_gamma : array_like
        Cosines of the sky element's zenith angle and of its angle from the sun [1], broadcast against each
        other and against ``coefficients[..., i]``.
    coefficients : array_like
        (..., 5) from :func:`perez_sky_coefficients`.

    Returns
    -------
    numpy.ndarray
        Relative radiance (0 at or below the horizon).
    """
    c = np.asarray(coefficients, dtype=float)
    a, b, cc, d, e = (c[..., i] for i in range(5))
    ct = np.asarray(cos_theta, dtype=float)
    cg = np.clip(np.asarray(cos_gamma, dtype=float), -1.0, 1.0)
    grad = 1.0 + a * np.exp(b / np.maximum(ct, 0.01))
    ind = 1.0 + cc * np.exp(d * np.arccos(cg)) + e * cg * cg
    return np.where(ct > 0, np.maximum(grad * ind, 0.0), 0.0)


def cie_patch_shape(patches):
    """(P,) CIE standard overcast patch radiance normalised to unit horizontal irradiance [sr-1]
    (:func:`widesky.irradiance.overcast_sky.cie_overcast_relative` at the patch centres)."""
    cz = patches.directions[:, 2]
    f = np.where(cz >= 0, (1.0 + 2.0 * np.clip(cz, 0.0, 1.0)) / 3.0, 0.0)
    return f / (f * patches.vector[:, 2]).sum()


_SAMPLES = {}


def _samples(patches, samples):
    """``patches.subsample(samples)`` with the weights normalised per patch, kept per patches object."""
    key = (id(patches), samples)
    hit = _SAMPLES.get(key)
    if hit is None or hit[0] is not patches:
        d, w = patches.subsample(samples)
        hit = _SAMPLES[key] = (patches, d, w / w.sum(axis=1, keepdims=True))
        while len(_SAMPLES) > 8:
            _SAMPLES.pop(next(iter(_SAMPLES)))
    return hit[1], hit[2]


def perez_patch_shape(patches, sun_direction, epsilon, delta, valid=None, samples=4):
    """Per-step patch radiance of the all-weather sky, normalised to unit horizontal irradiance [sr-1].

    Each patch's radiance is the solid-angle-weighted mean of :func:`perez_relative_radiance` over
    ``samples x samples`` stratified directions (``SkyPatches.subsample``); the distribution is then divided
    by its horizontal irradiance ``sum_p L_p H_p`` (``H_p`` the patches' exact horizontal projected solid
    angles), so ``DHI x shape`` is a sky whose horizontal diffuse irradiance is exactly ``DHI``.

    Parameters
    ----------
    patches : SkyPatches
    sun_direction : array_like
        (T, 3) unit vectors towards the sun (ENU).
    epsilon, delta : array_like
        (T,) sky clearness and brightness [1].
    valid : array_like, optional
        (T,) bool: steps to model (sun up, DHI > 0); the others get the CIE overcast shape.
    samples : int
        Sub-directions per patch side.

    Returns
    -------
    numpy.ndarray
        (T, P) [sr-1].
    """
    s = np.asarray(sun_direction, dtype=float)
    T = s.shape[0]
    d, w = _samples(patches, int(samples))                         # (P, n, 3), (P, n) normalised per patch
    P, n = w.shape
    cz = np.clip(s[:, 2], -1.0, 1.0)
    coef = perez_sky_coefficients(epsilon, delta, np.arccos(np.clip(cz, 0.0, 1.0)))   # (T, 5)
    cg = np.matmul(s, d.reshape(-1, 3).T)                           # (T, P n)
    ct = d[..., 2].reshape(-1)
    if np.all(ct > 0):          # the sky's samples: perez_relative_radiance in place, one (T, P n) array at a time
        a, b, cc, dd, e = (coef[:, i, None] for i in range(5))
        np.clip(cg, -1.0, 1.0, out=cg)
        grad = np.exp(b / np.maximum(ct, 0.01))
        grad *= a
        grad += 1.0
        ind = np.arccos(cg)
        ind *= dd
        np.exp(ind, out=ind)
        ind *= cc
        ind += 1.0
        cg *= e * cg
        ind += cg
        ind *= grad
        rel = np.maximum(ind, 0.0, out=ind)
    else:
        rel = perez_relative_radiance(ct, cg, coef[:, None, :])
    lp = np.einsum("tpn,pn->tp", rel.reshape(T, P, n), w)
    h = lp @ patches.vector[:, 2]
    ok = h > 0
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    out = np.empty((T, patches.n_patches))
    out[ok] = lp[ok] / h[ok, None]
    out[~ok] = cie_patch_shape(patches)[None, :]
    return out


def cloud_patch_shape(patches, sun_direction, epsilon, delta, cloud_dhi, clear_radiance=None,
                      clear_circumsolar=None, valid=None, samples=4):
    """Angular distribution of the cloud light that makes clear and cloud light together the Perez sky.

    The all-sky model splits the step's diffuse light into clear-sky light (the clear sky's own
    radiance, :mod:`widesky.irradiance.allsky`) and cloud light. The Perez all-weather sky (PSM93) describes
    the *whole* diffuse field of a sky of the step's clearness and brightness, clear gaps included. So the
    cloud light takes what the Perez sky has beyond the clear light, direction by direction:
    ``K_p = max(0, (D_clear + D_cloud) S_p - C_p)`` with ``S_p`` the Perez shape per unit horizontal
    irradiance (:func:`perez_patch_shape`), ``C_p`` the clear light's (broadband) patch radiance and
    ``D_clear``, ``D_cloud`` the two parts' horizontal irradiances, then normalised to unit horizontal
    irradiance. Where no patch is clipped the sum is exactly the Perez sky; overcast (no clear light) it is
    the Perez sky; where the clear light alone exceeds the Perez sky in some patches (a clear aureole or
    horizon brighter than the fit's) those patches get no cloud light and the rest keeps the Perez
    proportions. No light is counted twice: the clear sky's circumsolar light is subtracted from the Perez
    sky's circumsolar region.

    Parameters
    ----------
    patches : SkyPatches
    sun_direction : array_like
        (T, 3) unit vectors towards the sun.
    epsilon, delta : array_like
        (T,) sky clearness and brightness [1] (NaN: not modelled, CIE overcast shape).
    cloud_dhi : array_like
        (T,) the cloud light's (broadband) horizontal irradiance [W m-2].
    clear_radiance : array_like, optional
        (T, P) the clear light's broadband patch radiance [W m-2 sr-1] (as scaled for the step); None: the
        cloud light is the Perez sky on its own.
    clear_circumsolar : array_like, optional
        (T,) the clear light's circumsolar normal irradiance [W m-2] traced with the sun (counted in the
        sun's patch).
    valid : array_like, optional
        (T,) bool, as :func:`perez_patch_shape`.
    samples : int
        Sub-directions per patch side.

    Returns
    -------
    numpy.ndarray
        (T, P) [sr-1], unit horizontal irradiance.
    """
    eps = np.asarray(epsilon, dtype=float)
    ok = np.isfinite(eps) & np.isfinite(np.asarray(delta, dtype=float))
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    target = perez_patch_shape(patches, sun_direction, np.where(ok, eps, 1.0), np.nan_to_num(delta), valid=ok,
                               samples=samples)
    if clear_radiance is None:
        return target
    w_h = patches.vector[:, 2]
    c = np.array(clear_radiance, dtype=float)                     # (T, P)
    s = np.asarray(sun_direction, dtype=float)
    if clear_circumsolar is not None:
        sp = patches.index(s)
        up = sp >= 0
        t = np.nonzero(up)[0]
        c[t, sp[up]] += np.asarray(clear_circumsolar, dtype=float)[up] / patches.solid_angle[sp[up]]
    total = c @ w_h + np.asarray(cloud_dhi, dtype=float)
    k = np.maximum(total[:, None] * target - c, 0.0)
    h = k @ w_h
    use = ok & (h > 0)
    out = target.copy()
    out[use] = k[use] / h[use, None]
    return out


def perez_poa_ratio(shape, poa_weights):
    """Sky diffuse on planes relative to the diffuse horizontal irradiance under per-step patch shapes.

    Parameters
    ----------
    shape : array_like
        (T, P) patch radiance per unit horizontal irradiance [sr-1] (:func:`perez_patch_shape`).
    poa_weights : array_like
        (P,) or (F, P) projected solid angles of the patches seen by each plane [sr].

    Returns
    -------
    numpy.ndarray
        (T,) or (T, F) [1].
    """
    return np.asarray(shape, dtype=float) @ np.asarray(poa_weights, dtype=float).T
