"""Assembly of per-layer optical properties of one channel as a weighted set of monochromatic-like sub-problems.

A 40 nm channel is split into

- spectral groups g: the 1 nm bins of the channel sorted by their column extinction of ozone + Rayleigh and
  cut where it grows by more than ``GROUP_RATIO`` (and ``GROUP_ABS``), so that the steep ozone Hartley-Huggins
  bands and the Rayleigh slope are band-averaged correctly (weight: the group's share of the extraterrestrial
  irradiance in the channel; ozone and Rayleigh optical depths: ET-weighted means over the group's bins;
  aerosol properties at the group's ET-weighted mean wavelength);
- the exponential-sum terms i of water vapour and j of the mixed gases (:mod:`widesky.skymodel.generator.gases`),
  combined under the random-overlap assumption.

Each sub-problem (g, i, j) has weight w_g w_i w_j (summing to 1) and is one solver run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..channels import FINE_WAVELENGTHS_NM, fine_slice
from .aerosol import PHASE_MU
from widesky.core.rayleigh import rayleigh_cross_section, rayleigh_moments

GROUP_RATIO = 1.2
GROUP_ABS = 0.02


@dataclass(frozen=True)
class SubProblem:
    """One solver run of a channel: weight [1], effective wavelength [nm] and per-layer (ground first) optical depths
    of Rayleigh scattering, aerosol extinction and gas absorption [1], aerosol single-scattering albedo [1] and
    aerosol Legendre moments (nmom+1,) [1]; optionally the aerosol phase function tabulated at
    :data:`widesky.skymodel.generator.aerosol.PHASE_MU` [1], which the solver's intensity correction uses instead of the
    (truncated) Legendre series."""

    weight: float
    wavelength_nm: float
    tau_rayleigh: np.ndarray
    tau_aerosol: np.ndarray
    tau_absorption: np.ndarray
    ssa_aerosol: float
    moments_aerosol: np.ndarray
    moments_rayleigh: np.ndarray
    phase_aerosol: np.ndarray | None = None

    @property
    def tau_total(self) -> np.ndarray:
        return self.tau_rayleigh + self.tau_aerosol + self.tau_absorption

    def disort_layers(self):
        """Per-layer (dtau (L,), ssa (L,), moments (L, nmom+1)) ordered top of atmosphere first, as DISORT wants."""
        sca_r = self.tau_rayleigh
        sca_a = self.tau_aerosol * self.ssa_aerosol
        dtau = self.tau_total
        sca = sca_r + sca_a
        ssa = np.where(dtau > 0, sca / np.maximum(dtau, 1e-300), 0.0)
        mom = (sca_r[:, None] * self.moments_rayleigh[None, :] + sca_a[:, None] * self.moments_aerosol[None, :]) / \
            np.maximum(sca, 1e-300)[:, None]
        mom[:, 0] = 1.0
        return dtau[::-1].copy(), np.clip(ssa[::-1], 0.0, 1.0 - 1e-12), mom[::-1].copy()

    def phase_table(self):
        """Per-layer phase function (L, len(PHASE_MU)) [1] at :data:`widesky.skymodel.generator.aerosol.PHASE_MU`, top of
        atmosphere first (DISORT's order): Rayleigh (1 + 5 chi_2 P_2(mu), exact for its two moments) and the
        aerosol's tabulated Mie phase function, weighted by their scattering optical depths; None without a table."""
        if self.phase_aerosol is None:
            return None
        sca_r = self.tau_rayleigh
        sca_a = self.tau_aerosol * self.ssa_aerosol
        p_r = 1.0 + 5.0 * self.moments_rayleigh[2] * (1.5 * PHASE_MU ** 2 - 0.5)
        tab = (sca_r[:, None] * p_r[None, :] + sca_a[:, None] * np.asarray(self.phase_aerosol)[None, :]) / \
            np.maximum(sca_r + sca_a, 1e-300)[:, None]
        return tab[::-1].copy()


def spectral_groups(channel, et_fine, tau_col_fine):
    """Split a channel's 40 bins into groups: list of index arrays into the channel's bins."""
    s = fine_slice(channel)
    tau = tau_col_fine[s]
    order = np.argsort(tau)
    groups, cur = [], [order[0]]
    for j in order[1:]:
        t0 = tau[cur[0]]
        if tau[j] > t0 * GROUP_RATIO and tau[j] - t0 > GROUP_ABS:
            groups.append(np.array(cur))
            cur = [j]
        else:
            cur.append(j)
    groups.append(np.array(cur))
    return groups


def channel_subproblems(channel, atmosphere, et_fine, o3_tau_fine, aerosol, aod550, aerosol_fractions, kdist,
                        nmom, co2_ppm=360.0, skip_tau=40.0):
    """All sub-problems of one channel (see module docstring).

    Parameters
    ----------
    channel : int (0..54); atmosphere : Atmosphere; et_fine : (2200,) ET [W m-2 nm-1];
    o3_tau_fine : (L, 2200) ozone optical depth per layer [1]; aerosol : AerosolOptics; aod550 [1];
    aerosol_fractions : (L,) [1]; kdist : GasKDistribution; nmom : number of Legendre moments;
    skip_tau : sub-problems whose vertical absorption optical depth exceeds this are dropped (their weight is kept
    in the channel normalisation, i.e. they contribute zero).

    Returns
    -------
    list of SubProblem
    """
    s = fine_slice(channel)
    wl = FINE_WAVELENGTHS_NM[s]
    et = et_fine[s]
    sig_r = rayleigh_cross_section(wl, co2_ppm)
    tau_r_fine = np.outer(atmosphere.air, sig_r)  # (L, 40)
    o3 = o3_tau_fine[:, s]
    col = np.zeros(len(et_fine))
    col[s] = (tau_r_fine + o3).sum(axis=0)
    groups = spectral_groups(channel, et_fine, col)
    etsum = et.sum()
    w_h2o = atmosphere.h2o_cm
    air_frac = atmosphere.air / atmosphere.air.sum()
    kw, km = kdist.water[channel], kdist.mixed[channel]
    out = []
    for g in groups:
        eg = et[g]
        wg = eg.sum() / etsum
        lam = float(np.sum(eg * wl[g]) / eg.sum())
        tr = (tau_r_fine[:, g] * eg).sum(axis=1) / eg.sum()
        to3 = (o3[:, g] * eg).sum(axis=1) / eg.sum()
        ext, ssa_a, mom_a = aerosol.at(lam)
        ph_a = aerosol.phase_at(lam)
        ph_a = None if ph_a is None else ph_a[0]
        ta = aod550 * ext[0] * aerosol_fractions
        mom_a = mom_a[0, : nmom + 1]
        mom_r = rayleigh_moments(lam, nmom, co2_ppm)
        for ki, wi in zip(kw.k, kw.w):
            for kj, wj in zip(km.k, km.w):
                tabs = to3 + ki * w_h2o + kj * air_frac
                weight = wg * wi * wj
                if tabs.sum() > skip_tau or weight <= 0:
                    continue
                out.append(SubProblem(weight=float(weight), wavelength_nm=lam, tau_rayleigh=tr, tau_aerosol=ta,
                                      tau_absorption=tabs, ssa_aerosol=float(ssa_a[0]), moments_aerosol=mom_a,
                                      moments_rayleigh=mom_r, phase_aerosol=ph_a))
    return out
