"""Spectral optics of a water cloud layer: droplet absorption and two-stream slab transmittance.

Used by :mod:`widesky.irradiance.allsky` for the spectral change that an overcast cloud layer makes to the
light that crosses it. Cloud droplets (effective radius 5-15 um) are large against 280-2480 nm, so
their extinction is spectrally flat (extinction efficiency ~2, the "extinction paradox"); what
changes the spectrum is absorption by liquid water, weak in the visible and strong in the NIR
(950, 1150, 1450, 1950 nm and beyond), multiplied by the long photon paths of multiple scattering.

- :func:`liquid_water_k`: imaginary refractive index of liquid water, read from the OPAC
  stratus-continental optical constants (Hess et al. 1998, ``aerosol_opac/refractive_indices/
  stco00_refr.dat`` in the reference data folder, not shipped; log-linear between the table's wavelengths).
- :func:`droplet_coalbedo`: single-scattering co-albedo ``1 - omega`` of droplets of radius ``r``
  from van de Hulst's anomalous-diffraction absorption efficiency ``Q_abs(w) = 1 + 2 e^-w / w +
  2 (e^-w - 1) / w^2`` with ``w = 4 x k`` (van de Hulst 1957, "Light scattering by small
  particles", ch. 11), and ``Q_ext = 2``, times a refraction factor 1.5: anomalous diffraction
  ignores the longer internal paths of refracted rays, and Mie theory (miepython) for a gamma
  distribution of effective radius 10 um and variance 0.1 gives 1.37-1.70 times its absorption
  over 700-2100 nm (tests/test_allsky_optics.py keeps the product within 20 % of Mie).
- :func:`slab_transmittance`: diffuse transmittance of a homogeneous slab from the two-stream
  equations with the Eddington coefficients (Meador & Weaver 1980, J. Atmos. Sci. 37, 630,
  Table 1), ``T = k / (k cosh(k tau) + g1 sinh(k tau))``, ``k = sqrt(g1^2 - g2^2)``; conservative
  limit ``T = 1 / (1 + 3 (1 - g) tau / 4)``.
- :func:`cloud_optical_depth`: the optical depth whose conservative two-stream transmittance is a
  given broadband cloud transmittance (the inverse of that limit).

Units: wavelength [nm], radius [um], optical depth [1].
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
from tqdm import tqdm

from widesky.core.atomic import atomic_write
from widesky.core.paths import DataNotFoundError, cache_dir, data_file, runtime_file
from widesky.core.rayleigh import rayleigh_cross_section
from widesky.skymodel.opac import refractive_index

__all__ = ["liquid_water_k", "droplet_coalbedo", "mie_droplet_optics", "cloud_spectral_transmittance",
           "transmitted_path_factor", "mie_droplet_table", "cloud_thickness_m", "DROPLET_VARIANCE", "slab_transmittance", "cloud_optical_depth",
           "cloud_relative_transmittance", "DEFAULT_DROPLET_RADIUS", "DEFAULT_ASYMMETRY",
           "ADT_REFRACTION_FACTOR", "LIQUID_WATER_CONTENT", "saturation_vapour_density",
           "cloud_vapour_path", "vapour_band_deepening", "rayleigh_optical_depth", "rayleigh_spherical_albedo",
           "cloud_top_rayleigh_gain", "CLOUD_TOP_PRESSURE_RATIO", "exponential_integral_1",
           "exponential_integral_3"]

DEFAULT_DROPLET_RADIUS = 10.0
"""Effective droplet radius [um] of a typical continental stratiform water cloud (observed 5-15 um;
10 um is the common default, e.g. Hu & Stamnes 1993, J. Climate 6, 728)."""

ADT_REFRACTION_FACTOR = 1.5
"""Ratio of Mie to anomalous-diffraction droplet absorption [1] (measured 1.37-1.70, see above)."""

DEFAULT_ASYMMETRY = 0.86
"""Asymmetry parameter [1] of water droplets in the visible and near IR (0.85-0.87 for r_e 5-20 um,
Hu & Stamnes 1993)."""


def liquid_water_k(wavelength_nm, data_dir=None):
    """Imaginary part of the refractive index of liquid water [1] at wavelengths [nm].

    Read from the OPAC optical constants of water clouds in the reference data folder (``data_dir``,
    ``WIDESKY_DATA_DIR`` or ``../shared/data``; not shipped: libRadtran's copy is under GPL-2; raises
    :class:`widesky.core.paths.DataNotFoundError` naming the file and where to get it when absent). Only the
    non-default ``droplet_optics="adt"`` and non-default droplet sizes need it. The table is coarse beyond 1 um
    (1.0, 1.25, 1.5, 1.75, 2.0, 2.5 um), so the
    absorption peaks at 1450 and 1940 nm are underestimated (about 3x at their centres).
    """
    w = np.asarray(wavelength_nm, dtype=float)
    if np.any(~np.isfinite(w)) or np.any(w < 250) or np.any(w > 40000):
        raise ValueError(f"wavelength_nm outside the table's range [250, 40000] nm: {w.ravel()[:3]}")
    return -np.imag(_water_index(w, data_dir))


_OPAC_WATER = "aerosol_opac/refractive_indices/stco00_refr.dat"


def _water_index(wavelength_nm, data_dir):
    """Complex refractive index of liquid water from the OPAC water-cloud table in the reference data folder;
    a missing table is a DataNotFoundError naming the file and where to get it."""
    try:
        data_file(_OPAC_WATER, data_dir)
    except DataNotFoundError as exc:
        raise DataNotFoundError(
            f"the liquid-water optical constants {_OPAC_WATER!r} (OPAC, Hess et al. 1998; libRadtran 2.0's "
            "data/aerosol/OPAC/refractive_indices/stco00_refr.dat, GPL-2, so not shipped with widesky) are needed "
            "for droplet_optics='adt' and for droplet sizes other than the default: put the file in a reference "
            f"data folder (data_dir=..., or WIDESKY_DATA_DIR), or keep the default droplets ({exc})") from None
    return refractive_index("stco", wavelength_nm, 0, data_dir=data_dir)


def _q_abs_adt(w):
    """Anomalous-diffraction absorption efficiency [1] for w = 4 x k (series below 1e-3)."""
    w = np.asarray(w, dtype=float)
    small = w < 1e-3
    ws = np.where(small, 1.0, w)
    exact = 1.0 + 2.0 * np.exp(-ws) / ws + 2.0 * (np.exp(-ws) - 1.0) / ws ** 2
    series = 2.0 * w / 3.0 - w ** 2 / 4.0 + w ** 3 / 15.0
    return np.where(small, series, exact)


def droplet_coalbedo(wavelength_nm, k, radius_um=DEFAULT_DROPLET_RADIUS):
    """Single-scattering co-albedo ``1 - omega`` [1] of water droplets (anomalous diffraction).

    Parameters
    ----------
    wavelength_nm : array_like
        Wavelengths [nm], > 0.
    k : array_like
        Imaginary refractive index of water [1], >= 0 (:func:`liquid_water_k`).
    radius_um : float
        Effective droplet radius [um], in [1, 100].

    Returns
    -------
    numpy.ndarray
        ``ADT_REFRACTION_FACTOR * Q_abs / Q_ext`` with ``Q_ext = 2`` (large-droplet limit),
        capped at 0.5.
    """
    r = float(radius_um)
    if not 1.0 <= r <= 100.0:
        raise ValueError(f"radius_um={radius_um!r} um outside the valid range [1, 100]")
    lam = np.asarray(wavelength_nm, dtype=float)
    if np.any(~(lam > 0)):
        raise ValueError("wavelength_nm must be > 0 nm")
    kk = np.asarray(k, dtype=float)
    if np.any(kk < 0):
        raise ValueError("k must be >= 0")
    x = 2.0 * np.pi * r * 1000.0 / lam
    return np.minimum(0.5 * ADT_REFRACTION_FACTOR * _q_abs_adt(4.0 * x * kk), 0.5)


DROPLET_VARIANCE = 0.1
"""Effective variance [1] of the droplets' gamma size distribution (Hansen & Travis 1974, Space Sci. Rev.
16, 527: 0.1-0.2 for water clouds; 0.1 is the usual default)."""

_MIE_WAVELENGTHS_NM = np.arange(280.0, 2501.0, 20.0)
_SHIPPED_TABLE = "droplet_mie_r10_v0.1.csv"


def mie_droplet_table(radius_um=DEFAULT_DROPLET_RADIUS, variance=DROPLET_VARIANCE, data_dir=None, n_radii=320,
                      progress=True):
    """(W, 4) table of wavelength [nm], mean extinction efficiency [1], co-albedo [1] and asymmetry [1] of water
    droplets, every 20 nm over 280-2500 nm (see :func:`mie_droplet_optics`): Mie (miepython ``efficiencies_mx``)
    on ``n_radii`` radii 0.5-40 um (finer than the extinction's interference ripple at 280 nm) weighted by the
    gamma distribution's cross-section ``pi r^2 n(r)``. Some 3 minutes on one core for 320 radii."""
    import miepython
    lam = _MIE_WAVELENGTHS_NM
    r = np.linspace(0.5, 40.0, int(n_radii))
    area = np.pi * r ** 2 * r ** ((1.0 - 3.0 * variance) / variance) * np.exp(-r / (radius_um * variance))
    m = _water_index(lam, data_dir)
    rows = []
    for li, mi in tqdm(list(zip(lam, m)), desc="droplet Mie table", unit="wavelength", disable=not progress,
                       leave=False):
        qe, qs, _, g = miepython.efficiencies_mx(complex(mi.real, -abs(mi.imag)), 2.0 * np.pi * r * 1000.0 / li)
        rows.append((li, (qe * area).sum() / area.sum(), 1.0 - (qs * area).sum() / (qe * area).sum(),
                     (g * qs * area).sum() / (qs * area).sum()))
    return np.array(rows)


@functools.lru_cache(maxsize=8)
def _mie_table(radius_um, variance, data_dir):
    """The (W, 4) table: the shipped one for the default droplets (``irradiance/data``, made by
    ``irradiance/data/make_droplet_table.py``), otherwise computed once and kept in the cache directory."""
    if np.isclose(radius_um, DEFAULT_DROPLET_RADIUS) and np.isclose(variance, DROPLET_VARIANCE):
        return np.genfromtxt(Path(__file__).with_name("data") / _SHIPPED_TABLE, delimiter=",", skip_header=2)
    path = cache_dir() / f"droplet_mie_r{radius_um:.4g}_v{variance:.4g}.npy"
    if path.is_file():
        return np.load(path)
    table = mie_droplet_table(radius_um, variance, data_dir)
    with atomic_write(path) as tmp:
        np.save(tmp, table)
    return table


def mie_droplet_optics(wavelength_nm, radius_um=DEFAULT_DROPLET_RADIUS, variance=DROPLET_VARIANCE, data_dir=None):
    """Mie optics of water droplets with a gamma size distribution.

    Mie theory (miepython ``efficiencies_mx``) for the liquid-water refractive index of the OPAC
    water-cloud component (real and imaginary parts, :func:`liquid_water_k`'s table), averaged over the
    gamma distribution of effective radius ``radius_um`` [um] and effective variance ``variance`` [1]
    (Hansen & Travis 1974, eq. 2.56), tabulated every 20 nm over 280-2500 nm (:func:`mie_droplet_table`; the
    default droplets' table ships with widesky, others are computed once and cached) and interpolated.

    Returns
    -------
    (extinction, coalbedo, asymmetry) : numpy.ndarray
        Extinction relative to 550 nm [1] (droplets are large but not infinitely: it rises a few % into
        the NIR), single-scattering co-albedo ``1 - omega`` [1] and asymmetry parameter g [1] (0.87 in the
        blue falling to 0.85 by 1.5 um), each shaped like ``wavelength_nm`` [nm].
    """
    r, v = float(radius_um), float(variance)
    if not 2.0 <= r <= 30.0:
        raise ValueError(f"radius_um={radius_um!r} um outside the valid range [2, 30]")
    if not 0.01 <= v <= 0.3:
        raise ValueError(f"variance={variance!r} outside the valid range [0.01, 0.3]")
    lam = np.asarray(wavelength_nm, dtype=float)
    if np.any((lam < 280.0) | (lam > 2500.0)):
        raise ValueError("wavelength_nm outside the table's range [280, 2500] nm")
    t = _mie_table(r, v, None if data_dir is None else str(data_dir))
    q550 = np.interp(550.0, t[:, 0], t[:, 1])
    return np.interp(lam, t[:, 0], t[:, 1]) / q550, np.interp(lam, t[:, 0], t[:, 2]), np.interp(lam, t[:, 0], t[:, 3])


def cloud_spectral_transmittance(tau, extinction, coalbedo, asymmetry, reference_asymmetry=DEFAULT_ASYMMETRY):
    """Spectral diffuse transmittance of a droplet cloud relative to the conservative grey cloud of the same
    optical depth at 550 nm.

    ``slab_transmittance(tau extinction(l), coalbedo(l), asymmetry(l)) / slab_transmittance(tau, 0, g_ref)``:
    the droplets' spectral extinction and asymmetry parameter change the transport optical depth
    ``(1 - g) tau`` (it grows about 10 % from the visible to 1.5 um), their absorption removes NIR light.

    Parameters
    ----------
    tau : array_like
        (T,) optical depths at 550 nm [1].
    extinction, coalbedo, asymmetry : array_like
        (C,) per channel [1] (:func:`mie_droplet_optics`).
    reference_asymmetry : float
        g [1] of the grey reference (the one the optical depth was inverted with).

    Returns
    -------
    numpy.ndarray
        (T, C) [1].
    """
    t = np.asarray(tau, dtype=float)
    e, c, g = (np.asarray(a, dtype=float) for a in (extinction, coalbedo, asymmetry))
    bad_g = ~((g >= 0.0) & (g < 1.0))
    if np.any(bad_g):
        raise ValueError(f"asymmetry={float(g[bad_g][0])!r} outside the valid range [0, 1)")
    if np.any(t < 0):
        raise ValueError("tau must be >= 0")
    if np.any((c < 0) | (c >= 1)):
        raise ValueError("coalbedo outside the valid range [0, 1)")
    T = _slab(t[:, None] * e[None, :], c[None, :], g[None, :])   # all channels at once, the same arithmetic
    return T / slab_transmittance(t, 0.0, reference_asymmetry)[:, None]


def transmitted_path_factor(tau, asymmetry=DEFAULT_ASYMMETRY):
    """Mean geometric path of diffusely transmitted light in a cloud layer, in units of its thickness [1].

    By the equivalence theorem the mean path equals ``-d ln T / d k`` for an absorption coefficient k
    spread evenly through the layer; with the two-stream slab (:func:`slab_transmittance`) that is
    ``-d ln T / d(c tau)`` at c -> 0 (a finite difference at c = 1e-6). It grows from 1.8 at tau 3 to 2.8 at
    tau 20 and 7 at tau 80 (g 0.86); DISORT for the same slab with a beam at 40 deg gives 1.9, 2.9 and 7.0
    (tests/test_allsky_optics.py).
    """
    t = np.asarray(tau, dtype=float)
    eps = 1e-6
    ts = np.where(t > 0, t, 1.0)
    f = -(np.log(slab_transmittance(ts, eps, asymmetry)) - np.log(slab_transmittance(ts, 0.0, asymmetry))) / (eps * ts)
    return np.where(t > 0, f, 1.0)


def slab_transmittance(tau, coalbedo, asymmetry=DEFAULT_ASYMMETRY):
    """Diffuse transmittance [1] of a homogeneous cloud slab (two-stream, Eddington coefficients).

    Parameters
    ----------
    tau : array_like
        Optical depth [1], >= 0.
    coalbedo : array_like
        Single-scattering co-albedo ``1 - omega`` [1], in [0, 1); broadcast against ``tau``.
    asymmetry : float
        Asymmetry parameter g [1], in [0, 1).

    Returns
    -------
    numpy.ndarray
        Transmittance [1] for diffuse light entering the top, no reflecting surface below.
    """
    g = float(asymmetry)
    if not 0.0 <= g < 1.0:
        raise ValueError(f"asymmetry={asymmetry!r} outside the valid range [0, 1)")
    t = np.asarray(tau, dtype=float)
    c = np.asarray(coalbedo, dtype=float)
    if np.any(t < 0):
        raise ValueError("tau must be >= 0")
    if np.any((c < 0) | (c >= 1)):
        raise ValueError("coalbedo outside the valid range [0, 1)")
    return _slab(t, c, g)


def _slab(t, c, g):
    """:func:`slab_transmittance` of checked inputs; ``g`` may be an array broadcast against ``t`` and ``c``."""
    om = 1.0 - c
    g1 = (7.0 - om * (4.0 + 3.0 * g)) / 4.0
    g2 = -(1.0 - om * (4.0 - 3.0 * g)) / 4.0
    kk = np.sqrt(np.maximum(g1 * g1 - g2 * g2, 0.0))
    kt = kk * t
    # T = k / (k cosh(kt) + g1 sinh(kt)); written with sinh(kt)/k so k -> 0 is the conservative limit
    with np.errstate(over="ignore"):
        shk = np.where(kk > 1e-12, np.sinh(np.minimum(kt, 700.0)) / np.where(kk > 1e-12, kk, 1.0), t)
        den = np.cosh(np.minimum(kt, 700.0)) + g1 * shk
    return 1.0 / den


def cloud_optical_depth(transmittance, asymmetry=DEFAULT_ASYMMETRY, max_tau=200.0):
    """Optical depth [1] of a conservative cloud slab with the given diffuse transmittance [1].

    The inverse of the conservative two-stream limit ``T = 1 / (1 + 3 (1 - g) tau / 4)``;
    ``transmittance`` is clipped to [1 / (1 + 3 (1 - g) max_tau / 4), 1] (NaN stays NaN).
    """
    g = float(asymmetry)
    if not 0.0 <= g < 1.0:
        raise ValueError(f"asymmetry={asymmetry!r} outside the valid range [0, 1)")
    tr = np.asarray(transmittance, dtype=float)
    gam = 0.75 * (1.0 - g)
    lo = 1.0 / (1.0 + gam * float(max_tau))
    tr = np.clip(tr, lo, 1.0)
    return (1.0 / tr - 1.0) / gam


def cloud_relative_transmittance(tau, coalbedo, asymmetry=DEFAULT_ASYMMETRY):
    """Spectral transmittance of an absorbing cloud slab relative to the same slab without absorption.

    Parameters
    ----------
    tau : array_like
        (T,) optical depths [1].
    coalbedo : array_like
        (C,) co-albedo per channel [1].

    Returns
    -------
    numpy.ndarray
        (T, C) ``slab_transmittance(tau, coalbedo) / slab_transmittance(tau, 0)`` [1], in (0, 1].
    """
    t = np.asarray(tau, dtype=float)[:, None]
    c = np.asarray(coalbedo, dtype=float)[None, :]
    return slab_transmittance(t, c, asymmetry) / slab_transmittance(t, np.zeros_like(c), asymmetry)


LIQUID_WATER_CONTENT = 0.3
"""Liquid water content [g m-3] of low stratiform clouds used to turn a cloud's liquid water path into
its geometric thickness (observed means 0.1-0.4 g m-3; Miles, Verlinde & Clothiaux 2000, J. Atmos.
Sci. 57, 295)."""

US62_WATER_COLUMN = 1.424
"""Precipitable water [cm] of 6S's US Standard 1962 atmosphere, the column of the band transmittances
in ``gas/6S_band_gas_transmittance_USS62_55ch.csv``."""


def saturation_vapour_density(temp):
    """Water vapour density at saturation over water [g m-3] at ``temp`` [degC] (Magnus formula,
    Alduchov & Eskridge 1996: e_s = 6.1094 exp(17.625 T / (T + 243.04)) hPa)."""
    t = np.asarray(temp, dtype=float)
    e = 610.94 * np.exp(17.625 * t / (t + 243.04))                         # [Pa]
    return e / (461.5 * (t + 273.15)) * 1000.0


def cloud_thickness_m(tau, radius_um=DEFAULT_DROPLET_RADIUS, lwc=LIQUID_WATER_CONTENT):
    """Geometric thickness [m] of a water cloud of optical depth ``tau`` [1], effective droplet radius [um] and
    liquid water content [g m-3]: ``H = LWP / LWC`` with ``LWP = 2 rho_w r_e tau / 3`` (Stephens 1978)."""
    return (2.0 / 3.0) * np.asarray(tau, dtype=float) * float(radius_um) / float(lwc)


def cloud_vapour_path(tau, temp_dew, asymmetry=DEFAULT_ASYMMETRY, radius_um=DEFAULT_DROPLET_RADIUS,
                      lwc=LIQUID_WATER_CONTENT, path="two_stream"):
    """Extra water-vapour path [cm] of light transmitted through a cloud layer.

    Photons transmitted through the layer travel on average ``L = H f(tau)`` in it, against about ``H``
    for light that crosses it once. ``path="two_stream"`` (default): ``f`` by the equivalence theorem from
    the two-stream slab (:func:`transmitted_path_factor`: 2.8 at tau 20, within 5 % of DISORT);
    ``"diffusion"``: the thick-slab limit of diffusion theory ``f = (1 - g) tau / 2`` (the mean first-passage
    time ``H^2 / (6 D)``, ``D = c l_t / 3``; Davis & Marshak 2002, J. Atmos. Sci. 59, 2713), which leaves out
    the boundary terms and is half the two-stream path at tau 20. The layer is saturated; its vapour density is
    taken at the surface dew point (the cloud-base temperature of a well-mixed boundary layer). The
    thickness ``H = LWP / LWC`` with ``LWP = 2 rho_w r_e tau / 3`` (Stephens 1978, J. Atmos. Sci. 35,
    2123).

    Parameters
    ----------
    tau : array_like
        (T,) cloud optical depth [1].
    temp_dew : array_like
        (T,) dew point [degC] (NaN: 0 extra path).
    asymmetry : float
        [1].
    radius_um : float
        Effective droplet radius [um].
    lwc : float
        Liquid water content [g m-3].
    path : {"two_stream", "diffusion"}
        The mean-path factor ``f`` (above).

    Returns
    -------
    numpy.ndarray
        (T,) extra precipitable-water path [cm], in [0, 2 US62 columns = 2.85 cm] (the cap keeps the
        band law of :func:`vapour_band_deepening` within its range).
    """
    if path not in ("two_stream", "diffusion"):
        raise ValueError(f"path={path!r} is not one of ('two_stream', 'diffusion')")
    t = np.asarray(tau, dtype=float)
    td = np.asarray(temp_dew, dtype=float)
    thickness = cloud_thickness_m(t, radius_um, lwc)
    factor = transmitted_path_factor(t, asymmetry) if path == "two_stream" else 0.5 * (1.0 - float(asymmetry)) * t
    extra = thickness * np.maximum(factor - 1.0, 0.0)
    du = saturation_vapour_density(td) * extra * 1e-4                        # g m-3 * m -> g cm-2
    return np.clip(np.where(np.isfinite(du), du, 0.0), 0.0, 2.0 * US62_WATER_COLUMN)


@functools.lru_cache(maxsize=8)
def _vapour_log_ratio(lower_edges, data_dir):
    """log(T(2 u0) / T(u0)) per channel (C,) from the 6S band table, read once per channel set (the all-sky
    path asks for it every chunk of steps)."""
    a = np.genfromtxt(runtime_file("gas/6S_band_gas_transmittance_USS62_55ch.csv", data_dir),
                      delimiter=",", names=True)
    ratio = []
    for lo in lower_edges:
        r0 = a[(a["sza"] == 0) & np.isclose(a["lo_nm"], lo)]
        r6 = a[(a["sza"] == 60) & np.isclose(a["lo_nm"], lo)]
        if len(r0) != 1 or len(r6) != 1:
            raise ValueError(f"channel starting at {lo} nm is not in the 6S band table (280-2480 nm, 40 nm)")
        t0, t6 = float(r0["T_h2o"][0]), float(r6["T_h2o"][0])
        ratio.append(t6 / t0 if t0 > 1e-6 else 1.0)
    out = np.log(np.clip(np.array(ratio), 1e-6, 1.0))
    out.flags.writeable = False
    return out


def vapour_band_deepening(channel_edges, delta_u, data_dir=None):
    """Band transmittance factor [1] of an extra water-vapour path per channel.

    From 6S band-mean water transmittances of the 55 channels at one and two US62 columns
    (``gas/6S_band_gas_transmittance_USS62_55ch.csv``, widesky's own 6S product shipped in the package; from
    ``data_dir`` instead where one is given; sun at 0 and 60 deg): the factor for one more
    column is ``T(2 u0) / T(u0)``, and for ``delta_u`` it is that ratio to the power ``delta_u / u0``
    (a local exponential in the path; saturating bands are not exactly exponential, about right for
    ``delta_u`` up to ``u0``).

    Parameters
    ----------
    channel_edges : array_like
        (C+1,) [nm]; must be the 40 nm channels of the table (280-2480 nm) or a contiguous part.
    delta_u : array_like
        (T,) extra precipitable-water path [cm].

    Returns
    -------
    numpy.ndarray
        (T, C) factors in (0, 1].
    """
    logr = _vapour_log_ratio(tuple(np.asarray(channel_edges, dtype=float)[:-1]), data_dir)
    du = np.asarray(delta_u, dtype=float)[:, None]
    return np.exp(logr[None, :] * du / US62_WATER_COLUMN)


SEA_LEVEL_AIR_COLUMN = 2.1475e25
"""Air molecules per cm2 above sea level at 1013.25 hPa [cm-2] (``p N_A / (M g)`` with M = 28.9644 g mol-1,
g = 9.80665 m s-2): with the Bodhaine et al. (1999) cross-section it gives the Rayleigh optical depth
0.0973 at 550 nm (Bodhaine's Table 3: 0.0973 for 360 ppm CO2)."""

CLOUD_TOP_PRESSURE_RATIO = 0.8
"""Pressure at the top of a low cloud layer relative to the surface [1]: 0.8 is about 1.8 km, the
typical top of the boundary-layer stratocumulus and stratus that make most overcast hours at mid
latitudes (tops mostly 1-2 km; Wood 2012, Mon. Wea. Rev. 140, 2373)."""


def rayleigh_optical_depth(wavelength_nm, pressure_ratio=1.0):
    """Rayleigh optical depth [1] of the air above a level at ``pressure_ratio`` times the sea-level
    pressure [1], at wavelengths [nm] (Bodhaine et al. 1999 cross-section, 360 ppm CO2)."""
    p = float(pressure_ratio)
    if not 0.0 <= p <= 1.1:
        raise ValueError(f"pressure_ratio={pressure_ratio!r} outside the valid range [0, 1.1]")
    return rayleigh_cross_section(wavelength_nm) * SEA_LEVEL_AIR_COLUMN * p


def rayleigh_spherical_albedo(tau):
    """Spherical albedo [1] of a conservative Rayleigh layer of optical depth ``tau`` [1] over a black
    surface: the fraction of isotropic diffuse light from below that the layer sends back down,
    ``s = (3 tau - (4 + 2 tau) E3(tau) + 2 exp(-tau)) / (4 + 3 tau)`` (the 6S code's Rayleigh
    spherical albedo, Vermote et al. 1997; exact single scattering for thin layers, ``s -> tau``, and
    the two-stream limit for thick ones). Within 2 % of DISORT for tau 0.01-1
    (tests/test_allsky_optics.py)."""
    t = np.asarray(tau, dtype=float)
    if np.any(t < 0):
        raise ValueError("tau must be >= 0")
    return (3.0 * t - (4.0 + 2.0 * t) * exponential_integral_3(t) + 2.0 * np.exp(-t)) / (4.0 + 3.0 * t)


_EULER_GAMMA = 0.5772156649015329
# Abramowitz & Stegun (1964), eq. 5.1.56: x e^x E1(x) = (x^4 + a1 x^3 + a2 x^2 + a3 x + a4) /
# (x^4 + b1 x^3 + b2 x^2 + b3 x + b4) for 1 <= x, absolute error below 2e-8
_AS_E1_A = (8.5733287401, 18.0590169730, 8.6347608925, 0.2677737343)
_AS_E1_B = (9.5733223454, 25.6329561486, 21.0996530827, 3.9584969228)


def exponential_integral_1(x):
    """Exponential integral ``E1(x) = int_1^inf exp(-x t) / t dt`` [1] for ``x > 0`` [1]: its power series
    ``-gamma - ln x - sum_k (-x)^k / (k k!)`` up to x = 1 (to float rounding), Abramowitz & Stegun's rational
    approximation 5.1.56 above (relative error below 2e-8)."""
    x = np.asarray(x, dtype=float)
    if np.any(~(x > 0)):
        raise ValueError("x must be > 0")
    out = np.empty_like(x)
    small = x <= 1.0
    xs = x[small]
    term, total = np.ones_like(xs), np.zeros_like(xs)
    for k in range(1, 40):                       # |x|^k / (k k!) < 1e-17 by k = 18 for x <= 1
        term = term * (-xs) / k
        total += term / k
    out[small] = -_EULER_GAMMA - np.log(xs) - total
    xl = x[~small]
    a, b = _AS_E1_A, _AS_E1_B
    num = (((xl + a[0]) * xl + a[1]) * xl + a[2]) * xl + a[3]
    den = (((xl + b[0]) * xl + b[1]) * xl + b[2]) * xl + b[3]
    out[~small] = num / den * np.exp(-xl) / xl
    return out


def exponential_integral_3(x):
    """Exponential integral ``E3(x) = int_1^inf exp(-x t) / t^3 dt`` [1] for ``x >= 0`` [1], from E1 by the
    recurrence ``E_{n+1} = (exp(-x) - x E_n) / n``: ``E3 = (exp(-x) (1 - x) + x^2 E1(x)) / 2``; E3(0) = 1/2."""
    x = np.asarray(x, dtype=float)
    if np.any(~(x >= 0)):
        raise ValueError("x must be >= 0")
    safe = np.where(x > 0, x, 1.0)
    return np.where(x > 0, 0.5 * (np.exp(-x) * (1.0 - x) + x * x * exponential_integral_1(safe)), 0.5)


def cloud_top_rayleigh_gain(wavelength_nm, tau, albedo=0.2, asymmetry=DEFAULT_ASYMMETRY,
                            pressure_ratio=CLOUD_TOP_PRESSURE_RATIO):
    """Spectral gain [1] of the light under a cloud layer from multiple reflection between the cloud
    top and the molecular atmosphere above it.

    A cloud reflects much of the light it receives back up; the air above scatters a share ``s`` of
    that (its spherical albedo, :func:`rayleigh_spherical_albedo`, ~ lambda^-4) back down onto the
    cloud, which transmits part of it and reflects the rest up again. ``R* = R + T^2 A / (1 - A R)``
    is the reflectance of cloud and ground together (conservative two-stream slab ``T``, ``R = 1 - T``,
    :func:`slab_transmittance`; ground albedo ``A``): the ground's part ``A`` returns with the whole
    column's spherical albedo ``s0``, as in the clear sky, the cloud's extra ``R* - A`` with that of the
    air above the cloud top, ``s``. Summed, the light under the cloud is
    ``(1 - A s0) / (1 - A s0 - (R* - A) s)`` times what the clear-sky global spectrum (which already
    holds the clear sky's ``1 / (1 - A s0)``) gives: 1 without cloud. This is the blue shift of
    overcast light that spectral measurements under cloud show (SEDES2's cloud cover modifiers rise
    towards the blue as the clear-sky index falls; Nann & Riordan 1991).

    Parameters
    ----------
    wavelength_nm : array_like
        (C,) channel centres [nm].
    tau : array_like
        (T,) cloud optical depth [1] (0: gain 1).
    albedo : array_like
        (T,) or scalar ground albedo [1], in [0, 1].
    asymmetry : float
        Droplet asymmetry parameter [1].
    pressure_ratio : float
        Pressure at the cloud top relative to the sea-level pressure [1].

    Returns
    -------
    numpy.ndarray
        (T, C) gain [1]; 1 at ``tau = 0``, >= 1 wherever the cloud reflects more than the ground.
    """
    t = np.asarray(tau, dtype=float)
    a = np.broadcast_to(np.asarray(albedo, dtype=float), t.shape)
    if np.any((a < 0) | (a > 1)):
        raise ValueError("albedo outside the valid range [0, 1]")
    lam = np.asarray(wavelength_nm, dtype=float)
    s_top = rayleigh_spherical_albedo(rayleigh_optical_depth(lam, pressure_ratio))[None, :]
    s_all = rayleigh_spherical_albedo(rayleigh_optical_depth(lam, 1.0))[None, :]
    tr = slab_transmittance(t, 0.0, asymmetry)[:, None]
    r = 1.0 - tr
    a = a[:, None]
    r_star = r + tr * tr * a / (1.0 - a * r)
    return (1.0 - a * s_all) / (1.0 - a * s_all - (r_star - a) * s_top)
