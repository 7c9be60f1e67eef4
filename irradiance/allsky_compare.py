"""Reference comparisons of the all-sky model: generic cell responses, spectral effects, average photon
energy, the ASTM G173 state, SEDES2 and PVSPEC (used by benchmarks/bench_allsky.py and the tests).

- :func:`generic_eqe`, :func:`spectral_response`: generic a-Si, CdTe, CIGS and c-Si responses.
- :func:`ape`: average photon energy [eV] over a band of channels.
- :func:`g173_channels`, :func:`model_at_g173`, :func:`g173_decomposition`: ASTM G173 global tilt on the
  channels, the sky model at the G173 state, and where the two differ (direct or diffuse; SPCTRL2 as an
  independent code, through pvlib).
- :func:`sedes2_global_horizontal`: SEDES2's cloud cover modifiers (Nann & Riordan 1991) applied to
  clear-sky spectra, from a coefficient file the user supplies (not shipped).
- :func:`pvspec_fit`, :func:`pvspec_published`, :func:`mismatch_by_kc`, :func:`ape_by_kc`: spectral
  mismatch and APE against the clear-sky index, and the PVSPEC relation (Pelland et al. 2020) as pvlib
  holds it.

Reference files are read from ``data_dir``, ``WIDESKY_DATA_DIR`` or ``../shared/data``; ASTM G173 from the copy
shipped in the package (or ``data_dir`` where given).
Units: wavelength [nm], spectral irradiance [W m-2 nm-1], energy [eV].
"""

from __future__ import annotations

import numpy as np

from widesky.core.paths import data_file, runtime_file
from widesky.core.spectral import band_average
from widesky.skymodel.visibility import aod_at_wavelength, visibility_from_aod550

from .allsky_plane import clear_plane_spectra, plane_poa
from .ground import vegetation_albedo_shape
from .skies import SkyStates

__all__ = ["generic_eqe", "spectral_response", "ape", "g173_channels", "model_at_g173",
           "g173_decomposition", "sedes2_global_horizontal", "pvspec_fit", "pvspec_published",
           "mismatch_by_kc", "mismatch_by_airmass", "spctrl2_airmass_trend", "pvspec_annual", "ape_by_kc", "spectral_effects", "KC_BINS", "PVSPEC_TYPES", "HC_EV_NM"]


def _data(rel, data_dir=None):
    return data_file(rel, data_dir)


def _g173(data_dir=None):
    return np.genfromtxt(runtime_file("solar/ASTMG173.csv", data_dir), delimiter=",", skip_header=2)


def spectral_effects(E, ref, sr, w):
    """Spectral effects [%] ``(sum SR E / sum E) / (sum SR ref / sum ref) - 1`` of spectra E (..., C)
    against a reference spectrum (C,), for each response in ``sr``, channel widths ``w`` [nm]."""
    E = np.asarray(E, dtype=float)
    return {k: 100 * (((E * s * w).sum(-1) / (E * w).sum(-1)) / ((ref * s * w).sum() / (ref * w).sum()) - 1)
            for k, s in sr.items()}

HC_EV_NM = 1239.84198  # h c / q [eV nm]


def generic_eqe(wavelength, data_dir=None):
    """Generic EQE curves [1] at wavelengths [nm]: plateau x window cutoff x band-gap edge (logistic
    edges). Shapes, not measured devices: a-Si:H (edge 650 nm, i.e. the 1.75 eV gap with its Urbach
    tail), CdTe (CdS window 510 nm passing 35 %, gap 1.45 eV -> edge 830 nm), CIGS (CdS window,
    graded gap about 1.15 eV -> edge 1100 nm), c-Si (the knot points of pvlib's example c-Si spectral
    response, ../shared/data/pv/, interpolated linearly and converted to EQE)."""
    lam = np.asarray(wavelength, dtype=float)

    def shape(q0, blue, blue_w, floor, red, red_w):
        window = floor + (1 - floor) / (1 + np.exp((blue - lam) / blue_w))
        return q0 * window / (1 + np.exp((lam - red) / red_w))

    eqe = {"a-Si": shape(0.85, 380, 20, 0.0, 650, 30),
           "CdTe": shape(0.90, 510, 12, 0.35, 830, 12),
           "CIGS": shape(0.90, 510, 12, 0.40, 1100, 35)}
    pts = np.loadtxt(_data("pv/pvlib_example_spectral_response_cSi_points.csv", data_dir), delimiter=",",
                     skiprows=2, usecols=(0, 1))
    sr = np.interp(lam, pts[:, 0], pts[:, 1], left=0.0, right=0.0)        # relative SR [A W-1]
    q = sr * HC_EV_NM / np.where(lam > 0, lam, 1.0)
    eqe["c-Si"] = 0.9 * q / q.max()
    return eqe


def spectral_response(eqe, wavelength):
    """SR [A W-1] = EQE lambda q / (h c)."""
    return {k: v * np.asarray(wavelength) / HC_EV_NM for k, v in eqe.items()}


def g173_channels(edges, data_dir=None):
    """ASTM G173 global tilt band-averaged onto channel edges [nm] -> (C,) [W m-2 nm-1]."""
    a = _g173(data_dir)
    e = np.asarray(edges, dtype=float)
    return band_average(a[:, 0], a[:, 2], e[:-1], e[1:], outside="hold")


def model_at_g173(sky, components=False, ground="grey"):
    """The sky model's own global tilted spectrum at the G173 conditions (solar zenith 48.236 deg, plane
    tilted 37 deg toward the sun, AOD 0.084 at 500 nm as visibility through Koschmieder with Angstrom
    1.3, albedo 0.2) [W m-2 nm-1] (C,): the reference that separates the weather's spectral effect from
    the dataset's own difference to G173 at the reference state (``components``: all of plane_poa's parts;
    ``ground``: "grey" or "vegetation", the all-sky model's ground of :mod:`widesky.irradiance.ground`)."""
    vis = float(visibility_from_aod550(aod_at_wavelength(0.084, 500.0, 550.0, 1.3)))
    st = SkyStates.create([90.0 - 48.236], [180.0], vis, 0.2)
    c = clear_plane_spectra(sky, st, 37.0, 180.0)
    if ground not in ("grey", "vegetation"):
        raise ValueError(f"ground={ground!r} is not one of ('grey', 'vegetation')")
    kw = {}
    if ground == "vegetation":
        kw = {"albedo_shape": vegetation_albedo_shape(sky.wavelengths), "channel_edges": sky.channel_edges}
    p = plane_poa(c, np.ones(1), np.ones(1), 0.2, **kw)
    return {k: v[0] for k, v in p.items()} if components else p["poa_global"][0]


def ape(spec, wavelength, width, band=(320.0, 1080.0)):
    """Average photon energy [eV] of (..., C) spectra over the channels inside ``band`` (edges, nm)."""
    lam = np.asarray(wavelength)
    m = (lam - width / 2 >= band[0] - 1e-9) & (lam + width / 2 <= band[1] + 1e-9)
    e = (spec[..., m] * width[m]).sum(-1)
    n = (spec[..., m] * width[m] * lam[m] / HC_EV_NM).sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return e / n


def g173_decomposition(sky, sr, data_dir=None):
    """Why the sky model's spectrum at the G173 state differs from ASTM G173 global tilt (docs/all-sky.md,
    section 4): spectral effects [%] of the model's global tilted spectrum, of SPCTRL2's (Bird & Riordan
    1986, pvlib, the same state: AM1.5, 37 deg tilt, AOD500 0.084, water 1.42 cm, ozone 0.34 atm-cm,
    albedo 0.2, an equinox day so the sun-earth distance is 1), and of hybrids that swap the direct or
    the diffuse part between the model and G173 (G173's diffuse = global tilt - direct+circumsolar x
    cos 11.236 deg), and the model with the all-sky model's vegetated ground. Returns a dict of label ->
    {technology: %} and the (C,) diffuse spectra."""
    import pvlib
    edges = np.asarray(sky.channel_edges)
    wl, w = np.asarray(sky.wavelengths), np.diff(edges)
    a = _g173(data_dir)
    g173_dir = band_average(a[:, 0], a[:, 3], edges[:-1], edges[1:], outside="hold")
    g173 = band_average(a[:, 0], a[:, 2], edges[:-1], edges[1:], outside="hold")
    cos_aoi = np.cos(np.radians(48.236 - 37.0))
    model = model_at_g173(sky, components=True)
    r = pvlib.spectrum.spectrl2(apparent_zenith=48.236, aoi=48.236 - 37.0, surface_tilt=37.0, ground_albedo=0.2,
                                surface_pressure=101325.0, relative_airmass=1.5, precipitable_water=1.42,
                                ozone=0.34, aerosol_turbidity_500nm=0.084, dayofyear=94)
    spl_g = band_average(r["wavelength"], r["poa_global"].ravel(), edges[:-1], edges[1:], outside="hold")
    spl_d = spl_g - band_average(r["wavelength"], r["poa_direct"].ravel(), edges[:-1], edges[1:], outside="hold")

    def se(e, ref):
        return {k: float(v) for k, v in spectral_effects(e, ref, sr, w).items()}
    g_diff = g173 - g173_dir * cos_aoi
    m_diff = model["poa_global"] - model["poa_direct"]
    veg = model_at_g173(sky, components=True, ground="vegetation")
    out = {"the model at the G173 state": se(model["poa_global"], g173),
           "the model, vegetated ground": se(veg["poa_global"], g173),
           "SPCTRL2 at the G173 state": se(spl_g, g173),
           "the model, against SPCTRL2": se(model["poa_global"], spl_g),
           "model direct + G173 diffuse": se(model["poa_direct"] + g_diff, g173),
           "G173 direct + model diffuse": se(g173_dir * cos_aoi + m_diff, g173),
           "G173 direct + SPCTRL2 diffuse": se(g173_dir * cos_aoi + spl_d, g173)}
    return out, {"wl": wl, "G173": g_diff, "model": m_diff, "SPCTRL2": spl_d,
                 "model, vegetated ground": veg["poa_global"] - veg["poa_direct"]}


def sedes2_global_horizontal(coefficients, channel_edges, dni_clear, dhi_clear, sin_el, ghi):
    """SEDES2 all-sky global horizontal spectra [W m-2 nm-1] (T, C) from clear-sky spectra (T, C) and
    measured GHI (T,), as Whitaker & Newmiller (1998, NREL/SR-520-23942, section 2.1.3) describe it after
    Nann & Riordan (1991): the clear global spectrum rescaled to the measured GHI, times the cloud cover
    modifier ``CCM = A1 + A2 / cos z + (B1 + B2 / cos z) k + (C1 + C2 / cos z) k^2`` with the clear-sky
    index ``k = GHI / GHI_clear``. ``coefficients``: a CSV file with columns wavelength_nm, A1, A2, B1, B2,
    C1, C2 (320-1050 nm; not shipped, docs/all-sky.md names its source); interpolated linearly at the
    channel centres and held beyond its ends."""
    c = np.genfromtxt(coefficients, delimiter=",", names=True)
    edges = np.asarray(channel_edges, dtype=float)
    lam, w = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    a1, a2, b1, b2, c1, c2 = (np.interp(lam, c["wavelength_nm"], c[n])[None, :]
                              for n in ("A1", "A2", "B1", "B2", "C1", "C2"))
    g0 = dni_clear * sin_el[:, None] + dhi_clear
    k = (ghi / (g0 @ w))[:, None]
    mu = sin_el[:, None]
    ccm = a1 + a2 / mu + (b1 + b2 / mu) * k + (c1 + c2 / mu) * k * k
    return g0 * k * ccm


# PVSPEC (Pelland et al. 2020, IEEE PVSC 47, 1258; coefficients as in pvlib.spectrum.spectral_factor_pvspec):
# spectral mismatch M = a1 kc^a2 AM^a3 fitted to measurements at eight North American sites; the
# technologies here and the pvlib module types they are compared with
PVSPEC_TYPES = {"a-Si": "asi", "CdTe": "fs4-2", "c-Si": "monosi", "CIGS": "cigs"}


def pvspec_fit(E, kc, am, sr, mask):
    """Fit the PVSPEC form ``log M = log a1 + a2 log kc + a3 log AM`` (least squares over the hours in
    ``mask``) to hourly spectra E (T, C) with responses sr; M relative to the spectra's own mean shape
    (the exponents do not depend on the reference). Returns {technology: (a2, a3)}."""
    X = np.column_stack([np.ones(mask.sum()), np.log(kc[mask]), np.log(am[mask])])
    out = {}
    for k, s in sr.items():
        m = (E[mask] * s).sum(1) / E[mask].sum(1)
        coef, *_ = np.linalg.lstsq(X, np.log(m / m.mean()), rcond=None)
        out[k] = (float(coef[1]), float(coef[2]))
    return out


def pvspec_published():
    """{technology: (a2, a3)} of PVSPEC as pvlib holds them (None without pvlib)."""
    try:
        import pvlib
    except ImportError:
        return None
    out = {}
    for k, t in PVSPEC_TYPES.items():
        m = [float(pvlib.spectrum.spectral_factor_pvspec(am, kc, t)) for kc, am in ((1, 1), (np.e, 1), (1, np.e))]
        out[k] = (np.log(m[1] / m[0]), np.log(m[2] / m[0]))
    return out


AM_BINS = ((1.0, 1.3), (1.3, 1.7), (1.7, 2.2), (2.2, 3.0), (3.0, 4.0), (4.0, 6.0), (6.0, 10.0))


def mismatch_by_airmass(E, w, s, ref, airmass, mask, min_hours=5):
    """[((lo, hi), geometric bin centre, hours, median M)] over the air-mass bins AM_BINS for the hours in
    ``mask``: ``M = (sum_c E s w / sum_c E w) / ref``, the hour's spectral mismatch against the reference
    whose response-weighted mean is ``ref`` (E (T, C) [W m-2 nm-1], w (C,) channel widths [nm], s (C,)
    response [A W-1 or relative]); bins with fewer than ``min_hours`` hours are left out."""
    m = (E * s * w).sum(1) / (E * w).sum(1) / ref
    out = []
    for lo, hi in AM_BINS:
        sel = mask & (airmass >= lo) & (airmass < hi)
        if sel.sum() >= min_hours:
            out.append(((lo, hi), float(np.sqrt(lo * hi)), int(sel.sum()), float(np.median(m[sel]))))
    return out


def spctrl2_airmass_trend(sky, sr, tilt, zeniths=(48.236, 60.0, 66.0, 70.0, 75.0), aod500=0.084,
                          data_dir=None):
    """Clear-sky spectral effects [%] against G173 of SPCTRL2's global spectrum (Bird & Riordan 1986, through
    pvlib, a test dependency) on a south plane tilted ``tilt`` [deg] with the sun in the plane's azimuth at
    each zenith angle [deg] (AOD500 ``aod500``, water 1.42 cm, ozone 0.34 atm-cm, albedo 0.2, sea level, an
    equinox day): an independent code's air-mass trend for the clear hours. Returns
    [(zenith, Kasten-Young relative air mass, {technology: %})]."""
    import pvlib
    edges = np.asarray(sky.channel_edges)
    w = np.diff(edges)
    g173 = g173_channels(edges, data_dir)
    out = []
    for z in zeniths:
        am = float(pvlib.atmosphere.get_relative_airmass(z, "kastenyoung1989"))
        r = pvlib.spectrum.spectrl2(apparent_zenith=z, aoi=abs(z - tilt), surface_tilt=tilt, ground_albedo=0.2,
                                    surface_pressure=101325.0, relative_airmass=am, precipitable_water=1.42,
                                    ozone=0.34, aerosol_turbidity_500nm=aod500, dayofyear=94)
        g = band_average(r["wavelength"], r["poa_global"].ravel(), edges[:-1], edges[1:], outside="hold")
        out.append((float(z), am, {k: float(v) for k, v in spectral_effects(g, g173, sr, w).items()}))
    return out


def pvspec_annual(kc, airmass_absolute, weight, kc_range=(0.05, 1.5)):
    """Annual spectral effects by the measured PVSPEC relation (Pelland et al. 2020, coefficients as in
    pvlib's ``spectral_factor_pvspec``; pvlib is a test dependency): ``sum M w / sum w - 1`` over the hours,
    with ``M = a1 kc^a2 AM^a3`` of PVSPEC's measured modules, the clear-sky index clipped to ``kc_range``
    (the power law diverges at kc -> 0), weights ``w`` the hours' plane-of-array irradiance [W m-2].

    Also the same relation at a clear AM1.5 hour (kc 1, AM 1.5), PVSPEC's own offset from the reference
    spectrum that measured modules see in clear sky. Returns ``({technology: annual effect},
    {technology: effect at kc 1, AM 1.5})`` as fractions, or None without pvlib."""
    try:
        import pvlib
    except ImportError:
        return None
    kc = np.clip(np.asarray(kc, float), *kc_range)
    am = np.asarray(airmass_absolute, float)
    w = np.asarray(weight, float)
    ok = np.isfinite(kc) & np.isfinite(am) & np.isfinite(w) & (w > 0)
    annual, clear = {}, {}
    for k, t in PVSPEC_TYPES.items():
        m = np.asarray(pvlib.spectrum.spectral_factor_pvspec(am[ok], kc[ok], t), float)
        annual[k] = float((m * w[ok]).sum() / w[ok].sum() - 1.0)
        clear[k] = float(pvlib.spectrum.spectral_factor_pvspec(1.5, 1.0, t)) - 1.0
    return annual, clear


KC_BINS = ((0.0, 0.2), (0.2, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 1.0), (1.0, 2.0))


def ape_by_kc(E, kc, wl, w):
    """[((lo, hi), median hourly APE [eV])] over the clear-sky-index bins KC_BINS (empty bins left out)."""
    a = ape(E, wl, w)
    return [((lo, hi), float(np.nanmedian(a[(kc >= lo) & (kc < hi)]))) for lo, hi in KC_BINS
            if np.any((kc >= lo) & (kc < hi))]


def mismatch_by_kc(E, kc, s, mask):
    """[((lo, hi), centre, median of M / median M at kc 0.9-1.1)] over KC_BINS for the response s."""
    m = (E * s).sum(1) / E.sum(1)
    ref = np.nanmedian(m[(kc >= 0.9) & (kc < 1.1) & mask])
    out = []
    for lo, hi in KC_BINS:
        sel = (kc >= lo) & (kc < hi) & mask
        if sel.any():
            out.append(((lo, hi), 0.5 * (lo + min(hi, 1.2)), float(np.nanmedian(m[sel]) / ref)))
    return out


