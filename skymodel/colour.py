"""Colour: CIE 1931 colour matching functions and sRGB encoding for sky renders.

The CIE 1931 2-degree colour matching functions are evaluated with the multi-lobe piecewise-Gaussian
fit of Wyman, Sloan and Shirley (2013), "Simple Analytic Approximations to the CIE XYZ Color Matching
Functions", JCGT 2(2) (their equation 2 coefficients); its error against the tabulated CIE 1931
functions is below the accuracy a 40 nm-channel composite can resolve. XYZ to linear sRGB uses the
IEC 61966-2-1 matrix (D65 white).
"""

from __future__ import annotations

import numpy as np

__all__ = ["cie1931_xyz", "channel_xyz_weights", "xyz_to_linear_srgb", "srgb_encode"]

# (amplitude, mean [nm], sigma below the mean [nm], sigma above the mean [nm]) per lobe
_LOBES = {
    "x": ((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2)),
    "y": ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1)),
    "z": ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8)),
}

_XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986],
                         [-0.9689, 1.8758, 0.0415],
                         [0.0557, -0.2040, 1.0570]])


def cie1931_xyz(wavelength):
    """CIE 1931 2-degree colour matching functions x, y, z [1] at ``wavelength`` [nm]; shape (..., 3)."""
    lam = np.asarray(wavelength, float)
    out = []
    for key in "xyz":
        v = np.zeros_like(lam)
        for a, mu, s1, s2 in _LOBES[key]:
            s = np.where(lam < mu, s1, s2)
            v = v + a * np.exp(-0.5 * ((lam - mu) / s) ** 2)
        out.append(v)
    return np.stack(out, axis=-1)


def channel_xyz_weights(lower, width):
    """Integrals of x, y, z over each channel [lower, lower + width) [nm]: weights (C, 3) [nm] that turn
    per-channel spectral radiance [W m-2 sr-1 nm-1] into tristimulus values."""
    lower = np.atleast_1d(np.asarray(lower, float))
    t = (np.arange(int(np.ceil(width))) + 0.5) / np.ceil(width)
    lam = lower[:, None] + width * t[None, :]
    return cie1931_xyz(lam).mean(axis=1) * width


def xyz_to_linear_srgb(xyz):
    """CIE XYZ (..., 3) to linear sRGB (..., 3) (D65)."""
    xyz = np.asarray(xyz)
    m = _XYZ_TO_SRGB.T.astype(xyz.dtype) if xyz.dtype == np.float32 else _XYZ_TO_SRGB.T
    return (xyz if xyz.dtype == np.float32 else xyz.astype(float)) @ m


def srgb_encode(linear):
    """sRGB transfer function on values clipped to [0, 1]; returns floats in [0, 1] (float32 stays float32)."""
    v = np.asarray(linear)
    v = np.clip(v if v.dtype == np.float32 else v.astype(float), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1.0 / 2.4) - 0.055)
