"""Validation cases of the atmosphere and solver against published references (see docs/atmosphere-and-solver.md).

- :func:`g173_comparison`: ASTM G173-03 under its SMARTS 2.9.2 conditions (direct normal and 37 deg tilted global).
- :func:`spctrl2_comparison`: NREL SPCTRL2 (Bird & Riordan 1986) example spectra under their inputs.
- :func:`sixs_comparison`: 6S's own direct and diffuse ground irradiance for the same gases and aerosol amount.
- :func:`rayleigh_benchmark`: the scalar Rayleigh fluxes of Sweigart (1970, Table 1) as used by DISORT test problem 2.
- :func:`low_sun_comparison`: plane-parallel vs spherical-shell direct beam at low sun.
"""

from __future__ import annotations

import csv
import multiprocessing as mp

import numpy as np

from widesky.core.spectral import band_average

from ..channels import CHANNEL_EDGES_NM, N_CHANNELS, channel_index
from .gases import _sixs, load_kdistributions
from .paths import data_file
from .solar import channel_extraterrestrial
from .solver import _trapezoid
from .solver import AtmosphereSpec, SkyState, SolverConfig, direct_transmittance, solve_sky

G173_ZENITH_DEG = 48.236
G173_TILT_DEG = 37.0
G173_DNI_280_2480 = 892.2  # W m-2, ASTM G173-03 direct+circumsolar integrated 280-2480 nm
G173_GTI_280_2480 = 992.5  # W m-2, global 37 deg tilt integrated 280-2480 nm
STRONG_BAND_TRANSMITTANCE = 0.85
"""A channel is a 'strong absorption band' in the per-channel G173 criterion when its molecular (H2O + mixed gas)
band transmittance along the G173 path (1.4164 cm water, air mass 1.5) is below this value [1]."""


def g173_case(et_source: str = "g173", aerosol_type: str = "continental_average", angstrom=None,
              ground_albedo: float = 0.2):
    """The ASTM G173-03 / SMARTS conditions as (SkyState, AtmosphereSpec): US standard atmosphere, 1.4164 cm water,
    0.3438 atm-cm ozone, AOD 0.084 at 500 nm, solar zenith 48.236 deg. The G173 aerosol (Shettle-Fenn rural) and
    spectral sandy-soil albedo are not reproduced: an OPAC mixture and a constant albedo stand in."""
    state = SkyState(solar_elevation_deg=90.0 - G173_ZENITH_DEG, aod500=0.084, ground_albedo=ground_albedo)
    spec = AtmosphereSpec(profile="us", precipitable_water=1.4164, ozone_du=343.8, aerosol_type=aerosol_type,
                          angstrom=angstrom, et_source=et_source)
    return state, spec


def g173_reference(data_dir=None):
    """ASTM G173-03 band means per channel [W m-2 nm-1]: dict etr, global_tilt, direct (55,)."""
    a = np.loadtxt(data_file("solar/ASTMG173.csv", data_dir), delimiter=",", skiprows=2)
    lo, hi = CHANNEL_EDGES_NM[:-1], CHANNEL_EDGES_NM[1:]
    return {k: band_average(a[:, 0], a[:, i], lo, hi, outside="hold")
            for k, i in (("etr", 1), ("global_tilt", 2), ("direct", 3))}


def g173_comparison(result=None, processes=None, progress=False, data_dir=None, **case):
    """Solve the G173 case (or take a SkyResult of it) and compare per channel and integrated 280-2480 nm.

    Returns
    -------
    dict with arrays (55,): model_dni, model_gti, ref_dni, ref_gti [W m-2 nm-1], ratio_dni, ratio_gti [1],
    energy_share [1] (channel share of the G173 direct), strong_band (bool); and scalars dni, gti, ref_dni,
    ref_gti [W m-2] and their ratios.
    """
    if result is None:
        state, spec = g173_case(**case)
        result = solve_sky(state, spec, processes=processes, progress=progress, data_dir=data_dir)
    ref = g173_reference(data_dir)
    poa = result.poa_global(G173_TILT_DEG, 0.0)["poa_global"]
    out = {"model_dni": result.dni, "model_gti": poa, "ref_dni": ref["direct"], "ref_gti": ref["global_tilt"],
           "ratio_dni": result.dni / ref["direct"], "ratio_gti": poa / ref["global_tilt"],
           "energy_share": ref["direct"] * 40.0 / np.sum(ref["direct"] * 40.0),
           "strong_band": _gas_transmittance_g173() < STRONG_BAND_TRANSMITTANCE,
           "dni": float(np.sum(result.dni) * 40.0), "gti": float(np.sum(poa) * 40.0),
           "ref_dni_integral": float(np.sum(ref["direct"]) * 40.0),
           "ref_gti_integral": float(np.sum(ref["global_tilt"]) * 40.0), "result": result}
    out["dni_ratio"] = out["dni"] / out["ref_dni_integral"]
    out["gti_ratio"] = out["gti"] / out["ref_gti_integral"]
    return out


def _gas_transmittance_g173():
    kd = load_kdistributions()
    m = 1.0 / np.cos(np.radians(G173_ZENITH_DEG))
    return np.array([float(kd.transmittance(c, 1.4164, m)) for c in range(N_CHANNELS)])


SPCTRL2_ZENITH_DEG = 47.912086486816406
"""Inputs of the SPCTRL2 example spectra (pvlib's test fixture, generated with solar_utils 0.3 = NREL SPCTRL2 C code):
apparent zenith 47.912 deg, pressure 1013 hPa, ozone 0.344 atm-cm, water 1.42 cm, AOD(500) 0.1, alpha 1.14,
albedo 0.2, day 75, horizontal surface."""


def spctrl2_reference(data_dir=None):
    """SPCTRL2 example spectra: wavelength [nm], and dif, dir (normal), etr, glo [W m-2 nm-1]."""
    with open(data_file("validation/spectrl2_example_spectra.csv", data_dir)) as f:
        rows = list(csv.DictReader(f))
    col = {k: np.array([float(r[k]) for r in rows]) for k in ("wavelength", "specdif", "specdir", "specetr",
                                                                "specglo")}
    return {"wavelength_nm": col["wavelength"] * 1000.0, "dhi": col["specdif"] / 1000.0,
            "dni": col["specdir"] / 1000.0, "etr": col["specetr"] / 1000.0, "ghi": col["specglo"] / 1000.0}


def spctrl2_comparison(result=None, processes=None, progress=False, data_dir=None):
    """Compare with SPCTRL2 integrated over 300-2480 nm (ours 280-2480; 280-300 nm carries < 0.01 W m-2 at the
    ground) and per channel where SPCTRL2 samples it.

    Returns dict: dni, dhi, ghi [W m-2] for model and reference and their ratios, per-channel arrays.
    """
    if result is None:
        state = SkyState(solar_elevation_deg=90.0 - SPCTRL2_ZENITH_DEG, aod500=0.1, ground_albedo=0.2,
                         day_of_year=75)
        spec = AtmosphereSpec(precipitable_water=1.42, ozone_du=344.0, angstrom=1.14)
        result = solve_sky(state, spec, processes=processes, progress=progress, data_dir=data_dir)
    ref = spctrl2_reference(data_dir)
    w = ref["wavelength_nm"]
    sel = (w >= 300) & (w <= 2480)
    out = {"result": result}
    for k in ("dni", "dhi", "ghi"):
        model = getattr(result, k)
        out["model_" + k] = float(np.sum(model) * 40.0)
        out["ref_" + k] = float(_trapezoid(ref[k][sel], w[sel]))
        out[k + "_ratio"] = out["model_" + k] / out["ref_" + k]
        out["channel_ref_" + k] = band_average(w, ref[k], CHANNEL_EDGES_NM[:-1], CHANNEL_EDGES_NM[1:],
                                               outside="hold")
        out["channel_ratio_" + k] = model / out["channel_ref_" + k]
    return out


def sixs_comparison(result=None, channels=None, processes=2, data_dir=None):
    """6S (sixsV1.1, its Continental aerosol model at the same AOD(550)) against this solver for the G173 gases,
    solar zenith 48.236 deg, albedo 0.2. Irradiances are compared as fractions of the extraterrestrial
    irradiance of each code, then weighted by one ET spectrum, so that the ET tables do not enter.

    Returns dict with per-channel direct and diffuse (incl. 6S's environment term) horizontal fractions of both codes
    and the integrated ratios ours / 6S.
    """
    ch = channel_index(channels)
    if result is None:
        state, spec = g173_case(et_source="tsis1")
        result = solve_sky(state, spec, channels=ch, processes=processes, data_dir=data_dir)
    aod550 = result.meta["aod550"]
    jobs = [(float(CHANNEL_EDGES_NM[c]), float(CHANNEL_EDGES_NM[c + 1]), aod550) for c in result.channels]
    if processes and processes > 1:
        with mp.get_context("spawn").Pool(processes) as pool:
            res = pool.map(_sixs_aerosol_run, jobs)
    else:
        res = [_sixs_aerosol_run(j) for j in jobs]
    mu0 = np.cos(np.radians(result.state.solar_zenith_deg))
    s_dir = np.array([r[0] for r in res])
    s_dif = np.array([r[1] for r in res])
    m_dir = result.dni * mu0 / result.extraterrestrial
    m_dif = result.dhi / result.extraterrestrial
    et = result.extraterrestrial
    return {"channels": result.channels, "sixs_direct": s_dir, "sixs_diffuse": s_dif, "model_direct": m_dir,
            "model_diffuse": m_dif, "direct_ratio": float(np.sum(et * m_dir) / np.sum(et * s_dir)),
            "diffuse_ratio": float(np.sum(et * m_dif) / np.sum(et * s_dif)),
            "global_ratio": float(np.sum(et * (m_dir + m_dif)) / np.sum(et * (s_dir + s_dif))), "result": result}


def _sixs_aerosol_run(job):
    from Py6S import AeroProfile, GroundReflectance

    lo, hi, aod550 = job
    s = _sixs(lo, hi, 1.4164, 0.3438, G173_ZENITH_DEG)
    s.aero_profile = AeroProfile.PredefinedType(AeroProfile.Continental)
    s.aot550 = aod550
    s.ground_reflectance = GroundReflectance.HomogeneousLambertian(0.2)
    s.run()
    o = s.outputs
    et = o.int_solar_spectrum / o.int_funct_filt  # W m-2 um-1
    return (o.direct_solar_irradiance / et, (o.diffuse_solar_irradiance + o.environmental_irradiance) / et)


SWEIGART_RAYLEIGH = (
    # Sweigart (1970) Table 1 as DISORT test problem 2 (Stamnes et al.): pure Rayleigh slab, mu0 = 0.080442,
    # beam flux pi, black ground. (tau, ssa, diffuse down at bottom, up at top)
    (0.2, 0.5, 4.41791e-02, 5.35063e-02),
    (0.2, 1.0, 1.06123e-01, 1.25561e-01),
    (5.0, 0.5, 2.51683e-04, 6.24730e-02),
    (5.0, 1.0, 2.68008e-02, 2.25915e-01),
)


def rayleigh_benchmark(n_streams: int = 16):
    """Run the Sweigart (1970) Rayleigh cases through :func:`widesky.skymodel.generator.solver.run_disort`'s DISORT setup.

    Returns list of (tau, ssa, model_down, ref_down, model_up, ref_up) with fluxes for beam flux pi.
    """
    out = []
    for tau, ssa, ref_dn, ref_up in SWEIGART_RAYLEIGH:
        down, up = rayleigh_layer_fluxes(tau, ssa, 0.080442, n_streams)
        out.append((tau, ssa, down, ref_dn, up, ref_up))
    return out


def rayleigh_layer_fluxes(tau, ssa, mu0, n_streams=16):
    """DISORT fluxes of one homogeneous Rayleigh layer (phase moments 1, 0, 0.1) over a black ground, beam flux pi
    at cosine ``mu0``: (diffuse downward flux at the bottom, upward flux at the top) [same units as the beam]."""
    import disortpp

    cfg = disortpp.DisortConfig(1, n_streams)
    cfg.flags.use_lambertian_surface = True
    cfg.flags.use_user_tau = True
    cfg.flags.comp_only_fluxes = True
    cfg.num_user_tau = 2
    cfg.num_phase_func_moments = n_streams
    cfg.allocate()
    cfg.delta_tau = [tau]
    cfg.single_scat_albedo = [ssa]
    m = np.zeros(n_streams + 1)
    m[0], m[2] = 1.0, 0.1
    cfg.phase_function_moments = [m.tolist()]
    cfg.tau_user = [0.0, tau]
    cfg.bc.direct_beam_flux = np.pi
    cfg.bc.direct_beam_mu = float(mu0)
    cfg.bc.surface_albedo = 0.0
    r = disortpp.DisortSolver().solve(cfg)
    return float(r.flux_down[1]), float(r.flux_up[0])


def low_sun_comparison(elevations_deg=(0.5, 1, 2, 3, 5, 7.5, 10, 15), visibility_km: float = 40.0,
                       spec: AtmosphereSpec = AtmosphereSpec(), data_dir=None):
    """Direct-beam band transmittance, plane-parallel (1/cos) vs spherical shells, at low sun.

    Returns dict: elevation_deg (E,), t_spherical, t_plane_parallel (E, 55) [1], and the ratio of integrated
    DNI 280-2480 nm plane-parallel / spherical (E,) with the TSIS-1 ET.
    """
    el = np.asarray(elevations_deg, float)
    st = SkyState(solar_elevation_deg=45.0, visibility_km=visibility_km)
    ts = direct_transmittance(st, 90.0 - el, spec, spherical=True, data_dir=data_dir)
    tp = direct_transmittance(st, 90.0 - el, spec, spherical=False, data_dir=data_dir)
    et = channel_extraterrestrial(spec.et_source, data_dir)
    return {"elevation_deg": el, "t_spherical": ts, "t_plane_parallel": tp,
            "dni_ratio": (tp @ et) / (ts @ et), "airmass_spherical_air": None}


def stream_convergence(streams=(8, 16, 32, 64), channels=(5, 20), data_dir=None):
    """Sky radiance at the G173 state for several stream counts on a few channels: dict streams -> SkyResult."""
    state, spec = g173_case(et_source="tsis1")
    vz = np.array([48.236 - 5, 48.236 - 2, 48.236 - 0.5, 0.0, 30.0, 60.0, 80.0, 48.236, 48.236])
    va = np.array([0.0, 0.0, 0.0, 0.0, 90.0, 180.0, 0.0, 5.0, 20.0])
    return {n: solve_sky(state, spec, vz, va, channels=list(channels), config=SolverConfig(n_streams=n,
                                                                                           n_moments=max(256, n)),
                         processes=1, data_dir=data_dir) for n in streams}


__all__ = ["g173_case", "g173_reference", "g173_comparison", "spctrl2_reference", "spctrl2_comparison",
           "sixs_comparison", "rayleigh_benchmark", "low_sun_comparison", "stream_convergence",
           "N_CHANNELS"]
