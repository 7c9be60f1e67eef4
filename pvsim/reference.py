"""widesky's own AM1.5G: the sky model's global irradiance on a 37 deg tilted plane facing the sun at
the ASTM G173-03 conditions (solar zenith 48.236 deg; AOD 0.084 at 500 nm as a visibility through the
dataset's aerosol scale height, Angstrom exponent 1.3; albedo 0.2), computed with the integrator.

Use it as the mismatch reference where no G173 file is at hand, or to separate a spectral effect
from the dataset's own bias against G173 (docs/pvsim.md gives the per-channel deviation and its effect
on each technology's spectral factor).
"""

from __future__ import annotations

import numpy as np
import trimesh

from widesky.irradiance import OutputOptions, RunOptions, SkyStates, make_scene, poa_irradiance
from widesky.irradiance.skies import PragueSky
from widesky.skymodel.visibility import aod_at_wavelength, visibility_from_aod550

__all__ = ["G173_ZENITH_DEG", "G173_TILT_DEG", "widesky_am15g", "REFERENCE_SPECTRA", "DEFAULT_REFERENCE"]

REFERENCE_SPECTRA = ("g173", "widesky")
"""STC reference spectra of the yield model: ASTM G173-03 global tilted (shipped in the package) or the sky
model's own AM1.5G (:func:`widesky_am15g`)."""

DEFAULT_REFERENCE = "g173"
"""The reference every front end uses unless told otherwise (``widesky pv --reference``, a case's
``pv.reference``): ASTM G173-03, the standard test conditions' spectrum."""

G173_ZENITH_DEG = 48.236     # ASTM G173-03 solar zenith angle [deg]
G173_TILT_DEG = 37.0         # ASTM G173-03 receiver tilt [deg], facing the sun
G173_AOD500 = 0.084          # ASTM G173-03 aerosol optical depth at 500 nm [1]
G173_GTI_280_2480 = 992.5    # ASTM G173-03 global tilted integrated over 280-2480 nm [W m-2]


def widesky_am15g(sky=None, albedo=0.2, angstrom=1.3):
    """Band-mean global tilted spectrum of the sky model at the G173 conditions.

    Parameters
    ----------
    sky : irradiance.PragueSky, optional
        Default the embedded dataset.
    albedo : float
        Ground albedo [1].
    angstrom : float
        Angstrom exponent converting AOD 500 -> 550 nm [1].

    Returns
    -------
    dict
        ``spectrum`` (C,) [W m-2 nm-1], ``channel_edges`` (C+1,) [nm], ``visibility`` [km] used,
        ``broadband`` [W m-2] over the channels, and ``scaled`` (C,): the spectrum scaled to G173's
        992.5 W m-2 over 280-2480 nm (widesky's spectral shape at the standard's irradiance: the
        reference pvsim uses for ``reference="widesky"``).
    """
    sky = sky or PragueSky()
    vis = float(visibility_from_aod550(aod_at_wavelength(G173_AOD500, 500.0, 550.0, angstrom)))
    lo, hi = sky.model.visibility_range if hasattr(sky.model, "visibility_range") else (20.0, 131.8)
    vis = float(np.clip(vis, lo, hi))
    t = np.radians(G173_TILT_DEG)
    # a 1 m2 plate facing south (azimuth 180) with the sun due south
    n = np.array([0.0, -np.sin(t), np.cos(t)])
    u = np.array([1.0, 0.0, 0.0])
    v = np.cross(n, u)
    c = np.array([0.0, 0.0, 1.0])
    pts = [c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2]
    plate = trimesh.Trimesh(pts, [[0, 1, 2], [0, 2, 3]], process=False)
    scene = make_scene([plate], ground_z=0.0)
    st = SkyStates.create(np.array([90.0 - G173_ZENITH_DEG]), np.array([180.0]), vis, albedo)
    res = poa_irradiance(scene, sky, st, output=OutputOptions(spectral=True), run=RunOptions(n_jobs=1))
    spec = np.asarray(res.spectral["global"] if "global" in res.spectral else
                      sum(res.spectral[p] for p in ("direct", "sky_diffuse", "ground_diffuse")))[0]
    a = res.faces.area
    s = (spec * a[:, None]).sum(axis=0) / a.sum()
    e = np.asarray(res.channel_edges, dtype=float)
    bb = float(np.sum(s * np.diff(e)))
    return {"spectrum": s, "channel_edges": e, "visibility": vis, "broadband": bb,
            "scaled": s * G173_GTI_280_2480 / bb}
