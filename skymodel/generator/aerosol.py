"""Aerosol optical properties: OPAC components by Mie theory, mixed as OPAC types, with a vertical profile.

Components (Hess, Koepke & Schult 1998, Bull. Am. Meteorol. Soc. 79, 831, "OPAC"): INSO (insoluble), WASO
(water-soluble, humidity-dependent) and SOOT, each a lognormal number size distribution
n(r) = N / (sqrt(2 pi) r ln sigma) exp(-(ln r - ln r_mod)^2 / (2 ln^2 sigma)) truncated to [r_min, r_max], with
parameters and refractive indices read from the data directory (``aerosol_opac/size_distr.cfg`` and
``aerosol_opac/refractive_indices/<comp><rh>_refr.dat``, the latter by :mod:`widesky.skymodel.opac`, which the
all-sky model's droplet optics share).

Mie theory: the coefficients a_n, b_n come from miepython (``miepython.an_bn``, Wiscombe 1979 series
length); efficiencies and the amplitude functions S1, S2 are summed here (Bohren & Huffman 1983, eqs. 4.61-4.62,
4.74) on a Gauss-Legendre grid of scattering-angle cosines, integrated over the size distribution, and
projected onto Legendre polynomials to give the phase-function moments used by the solver.

Mixtures: OPAC continental types by number density of each component (Hess et al. 1998, Table 4) [cm-3].

Vertical profile: the aerosol extinction is exponential with scale height H [km] from the ground to the top
level, renormalised so that the layer optical depths sum exactly to the requested AOD at 550 nm; with a
visibility V [km] that AOD is :func:`widesky.skymodel.visibility.aod550_from_visibility` (Koschmieder 3.912 / V minus
Rayleigh, times H).
"""

from __future__ import annotations

import functools
import hashlib
import json
import multiprocessing as mp
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from widesky.core.atomic import atomic_write

from ..opac import humidity_tag, refractive_index
from .paths import cache_dir, data_file

COMPONENT_NUMBER = {"inso": 1, "waso": 2, "soot": 3}
OPAC_TYPES = {
    # Hess et al. (1998) Table 4, number densities [cm-3]
    "continental_clean": {"waso": 2600.0, "inso": 0.15},
    "continental_average": {"waso": 7000.0, "inso": 0.4, "soot": 8300.0},
    "continental_polluted": {"waso": 15700.0, "inso": 0.6, "soot": 34300.0},
    "urban": {"waso": 28000.0, "inso": 1.5, "soot": 130000.0},
}
MIE_WAVELENGTHS_NM = np.unique(np.concatenate([np.arange(300.0, 2461.0, 40.0), [280.0, 500.0, 550.0, 2480.0]]))
"""Wavelengths where Mie properties are computed [nm]; others are interpolated."""
N_MU = 2000
MAX_MOMENTS = 512
PHASE_ANGLES_DEG = np.concatenate([np.arange(0.0, 1.0, 0.05), np.arange(1.0, 3.0, 0.1), np.arange(3.0, 10.0, 0.25),
                                   np.arange(10.0, 30.0, 0.5), np.arange(30.0, 180.1, 2.0)])
"""Scattering angles of the tabulated phase function handed to the solver's intensity correction [deg] (184, dense
in the forward peak; the phase function is interpolated linearly in the cosine between them)."""
PHASE_MU = np.cos(np.radians(PHASE_ANGLES_DEG[::-1]))
"""Cosines of :data:`PHASE_ANGLES_DEG`, ascending [1] (the order the solver wants)."""
N_RADII = 120
AREA_CUTOFF = 1e-10


@functools.lru_cache(maxsize=32)
def size_distribution(component: str, relative_humidity: int = 50, data_dir=None):
    """OPAC lognormal parameters of a component: dict with r_min, r_max, r_mod [um], density [g cm-3], sigma [1]."""
    if component not in COMPONENT_NUMBER:
        raise ValueError(f"component={component!r}: valid components are {tuple(COMPONENT_NUMBER)}")
    rh = humidity_tag(component, relative_humidity)
    rows = np.loadtxt(data_file("aerosol_opac/size_distr.cfg", data_dir), comments="#")
    sel = rows[(rows[:, 0] == COMPONENT_NUMBER[component]) & (rows[:, 1] == rh)]
    if len(sel) != 1:
        raise ValueError(f"no size distribution for {component} at RH {rh} % in size_distr.cfg")
    _, _, rmin, rmax, rmod, rho, sigma = sel[0]
    return {"r_min": rmin, "r_max": rmax, "r_mod": rmod, "density": rho, "sigma": sigma}


def _legendre_matrix(mu, lmax):
    p = np.empty((lmax + 1, len(mu)))
    p[0] = 1.0
    if lmax >= 1:
        p[1] = mu
    for n in range(1, lmax):
        p[n + 1] = ((2 * n + 1) * mu * p[n] - n * p[n - 1]) / (n + 1)
    return p


@functools.lru_cache(maxsize=1)
def _angular_grid():
    from scipy.special import roots_legendre

    mu, w = roots_legendre(N_MU)
    return mu, w, _legendre_matrix(mu, MAX_MOMENTS)


def _pi_tau(mu, nmax):
    pi = np.zeros((nmax + 1, len(mu)))
    tau = np.zeros((nmax + 1, len(mu)))
    pi[1] = 1.0
    tau[1] = mu
    for n in range(2, nmax + 1):
        pi[n] = ((2 * n - 1) * mu * pi[n - 1] - n * pi[n - 2]) / (n - 1)
        tau[n] = n * mu * pi[n] - (n + 1) * pi[n - 1]
    return pi[1:], tau[1:]


def mie_sphere(m, x, mu, pitau=None):
    """Mie efficiencies and angular scattering of one homogeneous sphere.

    Parameters
    ----------
    m : complex
        Refractive index n - i k [1].
    x : float
        Size parameter 2 pi r / lambda [1].
    mu : (M,) cosines of the scattering angle [1].

    Returns
    -------
    qext, qsca : float
        Extinction and scattering efficiencies [1].
    s11 : (M,) (|S1|^2 + |S2|^2) / 2 [1] (Bohren & Huffman normalisation: Csca = (1/k^2) int s11 dOmega).
    """
    import miepython

    a, b = miepython.an_bn(m, x)
    nterm = len(a)
    n = np.arange(1, nterm + 1)
    qext = 2.0 / x ** 2 * np.sum((2 * n + 1) * (a.real + b.real))
    qsca = 2.0 / x ** 2 * np.sum((2 * n + 1) * (np.abs(a) ** 2 + np.abs(b) ** 2))
    if pitau is None or pitau[0].shape[0] < nterm:
        pi, tau = _pi_tau(mu, nterm)
    else:
        pi, tau = pitau[0][:nterm], pitau[1][:nterm]
    f = (2 * n + 1) / (n * (n + 1.0))
    fa, fb = f * a, f * b
    c = np.stack([fa.real, fa.imag, fb.real, fb.imag])  # real matrix products (no complex cast of pi, tau)
    p_ = c @ pi
    t_ = c @ tau
    s1r, s1i = p_[0] + t_[2], p_[1] + t_[3]
    s2r, s2i = t_[0] + p_[2], t_[1] + p_[3]
    return float(qext), float(qsca), 0.5 * (s1r ** 2 + s1i ** 2 + s2r ** 2 + s2i ** 2)


def _component_optics_one(args):
    component, rh, wl, data_dir = args
    sd = size_distribution(component, rh, data_dir)
    mu, w, leg = _angular_grid()
    r = np.geomspace(sd["r_min"], sd["r_max"], N_RADII)
    lnr = np.log(r)
    dlnr = np.gradient(lnr)
    ls = np.log(sd["sigma"])
    nr = np.exp(-0.5 * ((lnr - np.log(sd["r_mod"])) / ls) ** 2) / (np.sqrt(2 * np.pi) * ls) * dlnr
    nr /= nr.sum()  # number fraction per radius bin (truncated distribution, unit total)
    area = nr * r ** 2
    keep = area >= AREA_CUTOFF * area.max()  # radii carrying a negligible share of the cross-section
    r, nr = r[keep], nr[keep]
    m = complex(refractive_index(component, wl, rh, data_dir))
    k = 2 * np.pi / (wl * 1e-3)  # um-1
    cext = csca = 0.0
    ang = np.zeros(len(mu))
    xmax = k * r[-1]
    pitau = _pi_tau(mu, int(xmax + 4.05 * xmax ** (1 / 3) + 3))
    for ri, wi in zip(r, nr):
        x = k * ri
        qe, qs, s11 = mie_sphere(m, x, mu, pitau)
        g = np.pi * ri ** 2
        cext += wi * qe * g
        csca += wi * qs * g
        ang += wi * s11 / k ** 2
    csca_quad = 2 * np.pi * np.sum(w * ang)
    phase = 4 * np.pi * ang / csca_quad
    mom = 0.5 * (leg * (w * phase)[None, :]).sum(axis=1)
    vol = np.sum(nr * 4.0 / 3.0 * np.pi * r ** 3)
    return {"cext_um2": cext, "csca_um2": csca, "csca_quad_um2": csca_quad, "moments": mom,
            "phase": _tabulate_phase(mu, phase), "volume_um3": vol, "density": sd["density"]}


def _tabulate_phase(mu, phase):
    """The phase function on :data:`PHASE_MU` from its values at the quadrature cosines ``mu`` (log-linear)."""
    order = np.argsort(mu)
    return np.exp(np.interp(PHASE_MU, mu[order], np.log(np.maximum(phase[order], 1e-300))))


def component_optics(component: str, relative_humidity: int = 50, data_dir=None, processes: int = 2,
                     progress: bool = False):
    """Mie optical properties per particle of an OPAC component on :data:`MIE_WAVELENGTHS_NM` (cached on disk).

    Returns
    -------
    dict with
        wavelength_nm (W,) [nm]; cext, csca (W,) cross-sections per particle [um2]; ssa (W,) [1];
        moments (W, MAX_MOMENTS+1) Legendre moments [1] (chi_0 = 1); g (W,) asymmetry parameter [1];
        phase (W, len(PHASE_MU)) the phase function itself at :data:`PHASE_MU` (normalised to 4 pi over the sphere) [1];
        quadrature_error (W,) relative difference of the angular integral vs the series Csca [1].
    """
    rh = humidity_tag(component, relative_humidity)
    sd = size_distribution(component, rh, data_dir)
    m_tab = refractive_index(component, MIE_WAVELENGTHS_NM, rh, data_dir)
    key = hashlib.sha1(json.dumps([component, rh, sd, MIE_WAVELENGTHS_NM.tolist(), N_MU, MAX_MOMENTS, N_RADII, AREA_CUTOFF,
                                   np.round(m_tab.real, 6).tolist(), np.round(m_tab.imag, 9).tolist(), 2,
                                   PHASE_MU.tolist()]
                                  ).encode()).hexdigest()[:16]
    path = cache_dir() / f"mie_{component}{rh:02d}_{key}.npz"
    if path.exists():
        z = np.load(path)
        return {k: z[k] for k in z.files}
    args = [(component, rh, float(w), None if data_dir is None else str(data_dir)) for w in MIE_WAVELENGTHS_NM]
    # inside a pool worker (a dataset build's solve job meeting an empty Mie cache) a nested pool is not
    # allowed: compute serially there
    if processes > 1 and not mp.current_process().daemon:
        with mp.get_context("spawn").Pool(processes) as pool:
            res = list(_progress(pool.imap(_component_optics_one, args), len(args), progress, f"Mie {component}"))
    else:
        res = [_component_optics_one(a) for a in _progress(args, len(args), progress, f"Mie {component}")]
    out = {"wavelength_nm": MIE_WAVELENGTHS_NM.copy(),
           "cext": np.array([r["cext_um2"] for r in res]), "csca": np.array([r["csca_um2"] for r in res]),
           "moments": np.array([r["moments"] for r in res]),
           "phase": np.array([r["phase"] for r in res]),
           "volume_um3": np.array([r["volume_um3"] for r in res]),
           "quadrature_error": np.array([r["csca_quad_um2"] / r["csca_um2"] - 1 for r in res])}
    out["ssa"] = out["csca"] / out["cext"]
    out["g"] = out["moments"][:, 1]
    with atomic_write(path) as tmp:     # workers may race to fill the cache: each writes its own file
        np.savez(tmp, **out)
    return out


def _progress(it, total, enabled, desc):
    if not enabled:
        return it
    return tqdm(it, total=total, desc=desc, leave=False)


@dataclass(frozen=True)
class AerosolOptics:
    """Spectral optical properties of an aerosol mixture, per unit AOD at 550 nm.

    wavelength_nm (W,) [nm]; extinction (W,) extinction relative to 550 nm [1]; ssa (W,) [1];
    moments (W, nmom+1) [1]; phase (W, len(PHASE_MU)) the phase function at :data:`PHASE_MU` [1] (None: not
    tabulated).
    """

    wavelength_nm: np.ndarray
    extinction: np.ndarray
    ssa: np.ndarray
    moments: np.ndarray
    name: str
    phase: np.ndarray | None = None

    def at(self, wavelength_nm):
        """Interpolate to wavelengths [nm]: returns (relative extinction (N,), ssa (N,), moments (N, nmom+1))."""
        w = np.atleast_1d(np.asarray(wavelength_nm, float))
        lw = np.log(self.wavelength_nm)
        ext = np.exp(np.interp(np.log(w), lw, np.log(self.extinction)))
        ssa = np.interp(w, self.wavelength_nm, self.ssa)
        mom = np.stack([np.interp(w, self.wavelength_nm, self.moments[:, j]) for j in range(self.moments.shape[1])],
                       axis=1)
        return ext, ssa, mom

    def phase_at(self, wavelength_nm):
        """The tabulated phase function at wavelengths [nm]: (N, len(PHASE_MU)) [1] (log-linear in wavelength), or
        None when the mixture carries no table."""
        if self.phase is None:
            return None
        w = np.atleast_1d(np.asarray(wavelength_nm, float))
        lp = np.log(np.maximum(self.phase, 1e-300))
        return np.exp(np.stack([np.interp(w, self.wavelength_nm, lp[:, j]) for j in range(lp.shape[1])], axis=1))

    def aod(self, aod550, wavelength_nm):
        """Aerosol optical depth [1] at wavelengths [nm] for an AOD at 550 nm [1]."""
        return float(aod550) * self.at(wavelength_nm)[0]


def opac_mixture(opac_type: str = "continental_average", relative_humidity: int = 50, data_dir=None,
                 processes: int = 2, progress: bool = False, angstrom=None) -> AerosolOptics:
    """Optical properties of an OPAC mixture (Hess et al. 1998) by Mie theory.

    Parameters
    ----------
    opac_type : str
        One of :data:`OPAC_TYPES` (continental clean / average / polluted, urban).
    relative_humidity : int
        Relative humidity [%] for WASO, one of :data:`HUMIDITIES`.
    angstrom : float, optional
        If given, replace the Mie spectral dependence of the extinction by the Angstrom law
        (lambda / 550)^-angstrom [1]; single-scattering albedo and phase function stay those of the mixture.

    Returns
    -------
    AerosolOptics
    """
    if opac_type not in OPAC_TYPES:
        raise ValueError(f"opac_type={opac_type!r}: valid types are {tuple(OPAC_TYPES)}")
    ext = sca = mom = phase = None
    for comp, number in OPAC_TYPES[opac_type].items():
        o = component_optics(comp, relative_humidity, data_dir, processes, progress)
        e = number * o["cext"]
        s = number * o["csca"]
        ext = e if ext is None else ext + e
        sca = s if sca is None else sca + s
        mom = s[:, None] * o["moments"] if mom is None else mom + s[:, None] * o["moments"]
        phase = s[:, None] * o["phase"] if phase is None else phase + s[:, None] * o["phase"]
    wl = MIE_WAVELENGTHS_NM.copy()
    mom = mom / sca[:, None]
    phase = phase / sca[:, None]
    e550 = float(np.interp(550.0, wl, ext))
    rel = ext / e550 if angstrom is None else (wl / 550.0) ** (-float(angstrom))
    name = opac_type + ("" if angstrom is None else f"+angstrom{angstrom:g}")
    return AerosolOptics(wavelength_nm=wl, extinction=rel, ssa=sca / ext, moments=mom, name=name, phase=phase)


def aerosol_layer_fractions(levels_km, scale_height_km: float) -> np.ndarray:
    """Fraction of the aerosol optical depth in each layer [1], shape (L,), summing to 1 exactly:
    exponential extinction exp(-z / H) between the levels [km], renormalised over ground-top."""
    z = np.asarray(levels_km, float)
    h = float(scale_height_km)
    if not h > 0:
        raise ValueError(f"scale_height_km={h} must be > 0 km")
    e = np.exp(-z / h)
    f = (e[:-1] - e[1:]) / (e[0] - e[-1])
    return f / f.sum()
