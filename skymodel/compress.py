"""Channel omission (the paper's wavelength compression, Vevoda et al. 2022, section 3.4 and Fig. 7).

Greedy omission: the first ``keep_first`` channels (default 12: 280-760 nm) are always kept; from the last kept
channel, the next channels are dropped as long as linear interpolation (in wavelength) between the last kept channel
and the candidate next kept one reproduces every dropped channel within ``max_error`` (maximum relative error over
all samples, or a chosen quantile of it; values darker than 1 % of their sample's brightest channel are measured
against that 1 %); the last channel is always kept. A channel list written by ``widesky dataset compress`` lets a user load
only the kept channels (less memory) and get the omitted ones back by interpolation::

    model = load_compressed(path, "channels.json")            # loads the kept channels only
    L = sky_radiance_all_channels(model, dirs, 30, 180, 40, 0.2)  # (..., 55), omitted channels interpolated
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_outputs

from .dataset import load_dataset
from .evaluate import sky_radiance

__all__ = ["greedy_omission", "interpolate_channels", "omission_errors", "radiance_samples", "omission_curve",
           "write_channel_list", "read_channel_list", "load_compressed", "sky_radiance_all_channels"]


def interpolate_channels(values, kept_wavelengths, wavelengths):
    """Linear interpolation along the last axis from kept channels to all channels.

    Parameters
    ----------
    values : ndarray (..., K)  values at the kept channels (any unit)
    kept_wavelengths : (K,) [nm] ascending centres of the kept channels
    wavelengths : (C,) [nm] centres wanted

    Returns
    -------
    ndarray (..., C); outside the kept range the end values are held.
    """
    v = np.asarray(values, float)
    kw = np.asarray(kept_wavelengths, float)
    wl = np.asarray(wavelengths, float)
    if v.shape[-1] != kw.size:
        raise ValueError(f"values have {v.shape[-1]} channels, kept_wavelengths {kw.size}")
    if kw.size == 1:
        return np.repeat(v, wl.size, axis=-1)
    j = np.clip(np.searchsorted(kw, wl, side="right") - 1, 0, kw.size - 2)
    f = np.clip((wl - kw[j]) / (kw[j + 1] - kw[j]), 0.0, 1.0)
    return v[..., j] * (1.0 - f) + v[..., j + 1] * f


def _floor(y, floor_fraction):
    """Per-sample floor [same unit as y] (N, 1): ``floor_fraction`` of the sample's brightest channel (at least the
    smallest positive float), so that channels far darker than the rest of their spectrum (saturated absorption
    bands, clamped fit values) are measured against that floor instead of blowing up a relative error of ~0."""
    return np.maximum(floor_fraction * np.abs(y).max(axis=1, keepdims=True), np.finfo(float).tiny)


def _rel_error(true, approx, floor):
    return np.abs(approx - true) / np.maximum(np.abs(true), floor)


def greedy_omission(values, wavelengths, max_error, keep_first: int = 12, floor_fraction: float = 0.01,
                    quantile: float = 1.0):
    """Channels kept by greedy omission (see module docstring).

    Parameters
    ----------
    values : ndarray (N, C)  samples of the quantity per channel (e.g. sky radiance [W m-2 sr-1 nm-1])
    wavelengths : (C,) [nm] channel centres, ascending
    max_error : float  largest allowed relative error of an interpolated channel [1]
    keep_first : int  channels always kept at the start
    floor_fraction : float  relative errors use max(|value|, floor_fraction x the sample's brightest channel) [1]
    quantile : float  statistic of the relative error over the samples compared with ``max_error``: 1 = the maximum
        (the paper's rule), 0.99 = the 99th percentile (ignores the worst 1 % of samples)

    Returns
    -------
    kept : int ndarray (K,) ascending channel indices
    """
    y = np.asarray(values, float).reshape(-1, np.shape(values)[-1])
    wl = np.asarray(wavelengths, float)
    C = y.shape[1]
    fl = _floor(y, floor_fraction)
    kept = list(range(max(1, min(keep_first, C))))
    k = kept[-1]
    while k < C - 1:
        nxt = k + 1
        for m in range(k + 2, C):
            mids = np.arange(k + 1, m)
            f = (wl[mids] - wl[k]) / (wl[m] - wl[k])
            approx = y[:, [k]] * (1.0 - f) + y[:, [m]] * f
            err = _rel_error(y[:, mids], approx, fl)
            stat = err.max() if quantile >= 1.0 else np.quantile(err, quantile, axis=0).max()
            if stat <= max_error:
                nxt = m
            else:
                break
        kept.append(nxt)
        k = nxt
    return np.array(sorted(set(kept)), dtype=np.int64)


def omission_errors(values, wavelengths, kept, floor_fraction: float = 0.01, quantile: float = 1.0):
    """Relative error per channel [1] (C,) of reconstructing ``values`` (N, C) from the ``kept`` channels (maximum
    over samples, or the given quantile; 0 for kept channels)."""
    y = np.asarray(values, float).reshape(-1, np.shape(values)[-1])
    wl = np.asarray(wavelengths, float)
    rec = interpolate_channels(y[:, kept], wl[kept], wl)
    err = _rel_error(y, rec, _floor(y, floor_fraction))
    return err.max(axis=0) if quantile >= 1.0 else np.quantile(err, quantile, axis=0)


def radiance_samples(model, n_directions: int = 400, seed: int = 0, min_elevation: float = 2.0):
    """Sky radiance of ``model`` at seeded random upper-hemisphere directions for every grid configuration
    (visibility, albedo, solar elevation >= ``min_elevation`` [deg]; sun at azimuth 180 deg).

    Returns
    -------
    ndarray (N, C) [W m-2 sr-1 nm-1]
    """
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 1, n_directions)
    phi = rng.uniform(0, 2 * np.pi, n_directions)
    z = np.sqrt(u) * 0.999  # cosine-weighted up to the horizon
    r = np.sqrt(1 - z * z)
    dirs = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)
    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for v in model.visibilities:
            for a in model.albedos:
                for e in model.elevations:
                    if e < min_elevation:
                        continue
                    out.append(sky_radiance(model, dirs, float(e), 180.0, float(v), float(a)))
    return np.concatenate(out, axis=0)


def omission_curve(values, wavelengths, thresholds, keep_first: int = 12, quantile: float = 1.0):
    """Kept channels per threshold: list of (threshold [1], kept indices)."""
    return [(float(t), greedy_omission(values, wavelengths, t, keep_first, quantile=quantile)) for t in thresholds]


def write_channel_list(path, kept, wavelengths, max_error, dataset=None, quantile: float = 1.0) -> Path:
    """Write a channel list (JSON: kept channel indices and centres [nm], the threshold, the dataset)."""
    kept = np.asarray(kept, int)
    wl = np.asarray(wavelengths, float)
    d = {"kept_channels": kept.tolist(), "kept_wavelengths_nm": wl[kept].tolist(), "n_channels": int(wl.size),
         "wavelengths_nm": wl.tolist(), "max_error": float(max_error), "error_quantile": float(quantile), "interpolation": "linear in wavelength",
         "dataset": None if dataset is None else str(dataset)}
    path = Path(path)
    with atomic_outputs(path) as (tmp,):
        tmp.write_text(json.dumps(d, indent=1))
    return path


def read_channel_list(path) -> dict:
    """Read a channel list written by :func:`write_channel_list`."""
    d = json.loads(Path(path).read_text())
    for key in ("kept_channels", "wavelengths_nm"):
        if key not in d:
            raise ValueError(f"channel list {path}: missing field {key!r}")
    return d


def load_compressed(path, channel_list, **kwargs):
    """Load only the kept channels of a dataset (less memory); the model remembers the file's channel centres
    (``model.full_wavelengths`` [nm]) so :func:`sky_radiance_all_channels` can interpolate the omitted ones.
    ``channel_list`` is a path or the dict of :func:`read_channel_list`; other keywords go to load_dataset."""
    cl = read_channel_list(channel_list) if not isinstance(channel_list, dict) else channel_list
    model = load_dataset(path, channels=cl["kept_channels"], **kwargs)
    if model.n_channels_file != int(cl.get("n_channels", model.n_channels_file)):
        raise ValueError(f"channel list is for {cl.get('n_channels')} channels, the dataset has "
                         f"{model.n_channels_file}")
    model.full_wavelengths = model.channel_start + model.channel_width * (np.arange(model.n_channels_file) + 0.5)
    return model


def sky_radiance_all_channels(model, *args, **kwargs):
    """:func:`widesky.skymodel.sky_radiance` on a model from :func:`load_compressed`, returned on every channel of the file
    (shape (..., n_channels_file) [W m-2 sr-1 nm-1]) with the omitted channels linearly interpolated."""
    if kwargs.get("channels") is not None or kwargs.get("wavelengths") is not None:
        raise ValueError("sky_radiance_all_channels returns every channel: do not pass channels or wavelengths")
    vals = sky_radiance(model, *args, **kwargs)
    full = getattr(model, "full_wavelengths", None)
    if full is None:
        return vals
    return interpolate_channels(vals, model.wavelengths, full)
