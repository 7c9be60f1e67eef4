"""Fitting error of a generated dataset against the reference solver on held-out skies (the paper's Fig. 10).

For every validation state of a build configuration (:func:`widesky.skymodel.generator.dataset_build.validation_states`; solved on
held-out directions, :func:`widesky.skymodel.generator.dataset_grid.validation_directions`) the dataset is evaluated with widesky's
evaluator at the same directions and sky state and compared per channel:

- normalised mean absolute error of radiance, ``sum w |model - solver| / sum w solver`` with solid-angle weights
  ``w`` [sr] over the sky hemisphere;
- sky-diffuse irradiance on a horizontal plane and on a plane tilted 37 deg facing the sun (both integrate the same
  directions with the same weights, so the difference is the fit's, not the quadrature's): relative error;
- direct normal irradiance from the dataset's transmittance against the solver's spherical-path direct beam;
- global irradiance, horizontal (direct + sky diffuse) and 37 deg tilted (direct + sky diffuse + isotropic ground
  reflection of the global horizontal at the state's albedo), each side from its own direct and diffuse.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..dataset import load_dataset
from ..evaluate import sky_radiance, solar_direct_normal
from .cache import load_state, validation_states
from .dataset_grid import direction_samples
from .dataset_mc import validation_file

__all__ = ["evaluate_errors", "summarise", "TILT_DEG", "TARGET_CHANNELS_NM"]

TILT_DEG = 37.0
"""Tilt of the tilted plane [deg] (facing the sun; ASTM G173's tilt)."""
TARGET_CHANNELS_NM = (400.0, 1300.0)
"""Channels whose centres lie in this range [nm] carry the per-channel targets."""


def evaluate_errors(config, dataset_path) -> list:
    """Errors of ``dataset_path`` on every cached validation state of ``config``.

    Returns
    -------
    list of dict: kind ('on' / 'off'), visibility [km], elevation [deg], albedo [1]; per channel (55,):
    nmae [1], e_horizontal, e_tilted (relative sky-diffuse irradiance errors [1], signed), dni_error (relative
    [1], signed), e_global_horizontal, e_global_tilted (relative global irradiance errors [1], signed); solver sky-diffuse irradiances dhi, dti [W m-2 nm-1]. States whose solve is missing are skipped.
    """

    model = load_dataset(dataset_path)
    out = []
    b = np.radians(TILT_DEG)
    normal = np.array([0.0, -np.sin(b), np.cos(b)])  # facing the sun at azimuth 180 (south)
    for kind, vis, ele, alb in validation_states(config):
        path = validation_file(config, kind, vis, ele, alb)
        if not path.exists():
            continue
        s = load_state(path)
        smp = direction_samples(s["zenith"], s["azimuth"], ele)
        ref = np.asarray(s["radiance"], float).reshape(-1, 55)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mod = sky_radiance(model, smp["directions"], ele, 180.0, vis, alb)
            dni = solar_direct_normal(model, ele, 180.0, vis, alb)
        w = smp["weights"][:, None]
        nmae = np.sum(w * np.abs(mod - ref), axis=0) / np.maximum(np.sum(w * ref, axis=0), 1e-300)
        cos_h = smp["directions"][:, 2:3] / np.linalg.norm(smp["directions"], axis=1, keepdims=True)
        cos_t = np.maximum(smp["directions"] @ normal, 0.0)[:, None]
        dhi_ref, dhi_mod = np.sum(w * cos_h * ref, axis=0), np.sum(w * cos_h * mod, axis=0)
        dti_ref, dti_mod = np.sum(w * cos_t * ref, axis=0), np.sum(w * cos_t * mod, axis=0)
        rel = lambda m, r: (m - r) / np.maximum(r, 1e-300)  # noqa: E731
        dni_ref = np.asarray(s["dni"], float)
        # relative DNI errors only where the beam is not extinguished (deep absorption bands, UV at low sun):
        # below 1e-4 of the band's extraterrestrial irradiance the ratio is noise
        dni_err = np.where(dni_ref > 1e-4 * np.asarray(s["et"], float), rel(dni, dni_ref), np.nan)
        mu0 = np.sin(np.radians(ele))
        cos_aoi = max(np.cos(np.radians(90.0 - ele - TILT_DEG)), 0.0)
        ghi_ref, ghi_mod = dni_ref * mu0 + dhi_ref, dni * mu0 + dhi_mod
        gnd = alb * (1.0 - np.cos(b)) / 2.0
        gti_ref = dni_ref * cos_aoi + dti_ref + gnd * ghi_ref
        gti_mod = dni * cos_aoi + dti_mod + gnd * ghi_mod
        out.append({"kind": kind, "visibility": vis, "elevation": ele, "albedo": alb, "nmae": nmae,
                    "e_horizontal": rel(dhi_mod, dhi_ref), "e_tilted": rel(dti_mod, dti_ref),
                    "e_global_horizontal": rel(ghi_mod, ghi_ref), "e_global_tilted": rel(gti_mod, gti_ref),
                    "dni_error": dni_err, "dhi": dhi_ref, "dti": dti_ref,
                    "dni": np.asarray(s["dni"], float)})
    return out


def summarise(errors: list, min_dhi_fraction: float = 0.0) -> dict:
    """Per-channel statistics of :func:`evaluate_errors` output (JSON-ready).

    Returns
    -------
    dict with wavelength_nm (55,); for 'all', 'on', 'off' states: nmae_mean, nmae_median, nmae_p90 (55,) [1],
    irradiance |error| medians and maxima (horizontal, tilted, dni) (55,) [1]; the channel-mean NMAE and the
    target checks (mean over channels < 6 %, median < 3 % and irradiance < 1 % for channels 400-1300 nm)."""
    wl = 300.0 + 40.0 * np.arange(55)
    res = {"wavelength_nm": wl.tolist(), "n_states": {}}
    tgt = (wl >= TARGET_CHANNELS_NM[0]) & (wl <= TARGET_CHANNELS_NM[1])
    for group in ("all", "on", "off"):
        sel = [e for e in errors if group == "all" or e["kind"] == group]
        res["n_states"][group] = len(sel)
        if not sel:
            continue
        nm = np.array([e["nmae"] for e in sel])
        g = {"nmae_mean": nm.mean(0), "nmae_median": np.median(nm, 0), "nmae_p90": np.percentile(nm, 90, 0)}
        for k in ("e_horizontal", "e_tilted", "dni_error", "e_global_horizontal", "e_global_tilted"):
            a = np.abs(np.array([e[k] for e in sel]))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)       # all-NaN channels (DNI in deep bands)
                g[k + "_median"] = np.nanmedian(a, 0)
                g[k + "_max"] = np.nanmax(a, 0)
        g = {k: np.round(v, 5).tolist() for k, v in g.items()}
        g["nmae_channel_mean"] = round(float(nm.mean()), 5)
        g["targets"] = {
            "mean_over_channels_below_6pct": bool(nm.mean() < 0.06),
            "median_below_3pct_400_1300": bool(np.all(np.median(nm, 0)[tgt] < 0.03)),
            "irradiance_median_below_1pct_400_1300": bool(
                np.all(np.array(g["e_horizontal_median"])[tgt] < 0.01)
                and np.all(np.array(g["e_tilted_median"])[tgt] < 0.01)),
            "global_irradiance_median_below_1pct_400_1300": bool(
                np.all(np.array(g["e_global_horizontal_median"])[tgt] < 0.01)
                and np.all(np.array(g["e_global_tilted_median"])[tgt] < 0.01)),
            "irradiance_max_below_1pct_400_1300": bool(
                np.all(np.array(g["e_horizontal_max"])[tgt] < 0.01)
                and np.all(np.array(g["e_tilted_max"])[tgt] < 0.01)),
        }
        res[group] = g
    return res
