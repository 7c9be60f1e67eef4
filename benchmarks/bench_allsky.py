"""All-sky spectra under measured weather: annual spectral effects of PV technologies, before/after.

The study of docs/all-sky.md: a south-facing plane tilted at the site's latitude, an hourly weather
year from ``../shared/data/weather/`` (or WIDESKY_DATA_DIR), the default dataset's clear sky at each
step's state, and generic EQE curves. For each technology the annual spectral effect is

    SE = (sum_t sum_c SR_c E_tc dl_c / sum_t sum_c E_tc dl_c) / (same for ASTM G173 global tilt) - 1

over 280-2480 nm (the 55 channels; G173 band-averaged onto them). "plain" is the measured path as
it is today (clear-sky shape scaled to measured DNI/DHI), "all-sky" the model of irradiance.allsky
with each part added in turn. Also the average photon energy (APE, 340-1060 nm: the channels with
centres 340-1060 nm) of hourly plane-of-array spectra, in all and in overcast hours (clearness index
below 0.3), against G173's.

Usage:  python benchmarks/bench_allsky.py [--sites amsterdam|all] [--figure docs/figures/allsky_spectral_effects.png]
        [--sedes2 COEFFICIENTS.csv] [--stride N] [--cache DIR] [--prefer aod|visibility]

Also printed: where the sky model at the G173 state differs from G173 (direct or diffuse, with SPCTRL2),
the spectral mismatch against the clear-sky index with PVSPEC, and the APE of global horizontal spectra
against the clear-sky index, with SEDES2 when its coefficient file is given (docs/validation/all-sky.md).

Prints a table per site and the time of each phase (the sky evaluation dominates; the all-sky factors
cost milliseconds for a year, reported as a ratio to the plain scaling measured in the same run).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_write
import widesky.irradiance as ir
from widesky.irradiance.allsky import CLEAR_SHAPE, AllSkyOptions, allsky_factors
from widesky.irradiance.allsky_compare import (ape, ape_by_kc, g173_channels,
                                      g173_decomposition, generic_eqe, mismatch_by_airmass, mismatch_by_kc, model_at_g173,
                                      PVSPEC_TYPES, pvspec_annual, spctrl2_airmass_trend, pvspec_fit, pvspec_published, sedes2_global_horizontal,
                                      spectral_response)
from widesky.irradiance.allsky_plane import (ClearPlaneSpectra, clear_patch_broadband, clear_plane_spectra, cloud_poa_ratio,
                                    plane_poa)
from widesky.irradiance.ground import vegetated_steps, vegetation_albedo_shape


def _site_file(name):
    """The site's weather year: shipped with widesky (Denver), else in the reference data folder (WIDESKY_DATA_DIR or
    ../shared/data; widesky.core.paths)."""
    from widesky.core.paths import data_reference
    return data_reference(f"data:weather/{SITES[name]}")


SITES = {
    "amsterdam": "NLD_Amsterdam062400_IWEC.epw",
    "chicago": "USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw",
    "denver": "USA_CO_Denver.Intl.AP.725650_TMY3.epw",
    "san_francisco": "USA_CA_San.Francisco.Intl.AP.724940_TMY3.epw",
}

# Dirnberger et al. (2015), Sol. Energy Mater. Sol. Cells 132, 431-442: measured annual spectral
# effects at Freiburg (Germany) relative to AM1.5G, % (as quoted in issue 16).
DIRNBERGER_FREIBURG = {"a-Si": 3.4, "CdTe": 2.4, "c-Si": 1.4, "CIGS": 0.6}

def load_site(path, sky, prefer="visibility", stride=1):
    wd = ir.read_weather(path)
    data = wd.data
    sp = wd.site.solar_position(data.index, wd.label, wd.step)
    st = ir.sky_states(sp, data, model=sky.model, prefer=prefer)
    keep = (st["solar_elevation"].to_numpy() > sky.min_sun_elevation) & (data["ghi"].to_numpy() > 0)
    keep &= np.isfinite(data["dni"].to_numpy()) & np.isfinite(data["dhi"].to_numpy())
    st, data = st[keep][::stride], data[keep][::stride]
    states = ir.SkyStates.create(st["solar_elevation"].to_numpy(), st["azimuth"].to_numpy(),
                                 st["visibility"].to_numpy(), st["albedo"].to_numpy())
    raw_vis = data["visibility"].to_numpy() if "visibility" in data else np.full(len(data), np.nan)
    if prefer == "aod":
        raw_vis = st["visibility"].to_numpy()
    kt = ir.clearness_index(data["ghi"].to_numpy(), 90 - st["solar_elevation"].to_numpy(),
                            data["dni_extra"].to_numpy() if "dni_extra" in data else 1361.0)
    return wd, states, data, raw_vis, kt, st


G = {"ground": "grey", "angular": "cie_overcast"}     # the CIE overcast cloud light: the rows before issue 39
C = {"angular": "cie_overcast"}
VARIANTS = (
    ("plain (today)", CLEAR_SHAPE),
    ("+ cloud spectrum (Ernst)", AllSkyOptions(cloud_absorption=False, cloud_vapour=False, cloud_rayleigh=False,
                                               partition="ernst", haze="clamp", circumsolar="none",
                                               **{**G, "angular": "clear"})),
    ("+ CIE overcast angular", AllSkyOptions(cloud_absorption=False, cloud_vapour=False, cloud_rayleigh=False,
                                             partition="ernst", haze="clamp", circumsolar="none", **G)),
    ("+ cloud droplets (Mie)", AllSkyOptions(cloud_vapour=False, cloud_rayleigh=False, partition="ernst",
                                           haze="clamp", circumsolar="none", **G)),
    ("+ cloud water vapour", AllSkyOptions(cloud_rayleigh=False, partition="ernst", haze="clamp", circumsolar="none",
                                           **G)),
    ("+ cloud-top Rayleigh", AllSkyOptions(partition="ernst", haze="clamp", circumsolar="none", **G)),
    ("+ sky-fraction partition", AllSkyOptions(haze="clamp", circumsolar="none", **G)),
    ("+ haze extension", AllSkyOptions(circumsolar="none", **G)),
    ("+ cloud circumsolar (Perez F1)", AllSkyOptions(**G)),
    ("+ vegetated ground", AllSkyOptions(**C)),
    ("+ Perez all-weather cloud light = all-sky", AllSkyOptions()),
)


def run_site(name, sky, sr, g173, g173_model, prefer="visibility", progress=True, cache=None, stride=1,
             sedes2=None):
    wl, edges = sky.wavelengths, sky.channel_edges
    w = np.diff(edges)
    wd, states, data, vis, kt, st = load_site(_site_file(name), sky, prefer, stride)
    t0 = time.perf_counter()
    tilt, azimuth = abs(wd.site.latitude), 180.0 if wd.site.latitude >= 0 else 0.0
    cfile = None if cache is None else Path(cache) / f"allsky_clear_{name}_{prefer}_{stride}.npz"
    if cfile is not None and cfile.is_file():
        z = np.load(cfile)
        clear = ClearPlaneSpectra(*(z[k] for k in ClearPlaneSpectra._fields))
    else:
        clear = clear_plane_spectra(sky, states, tilt, azimuth, progress=progress)
        if cfile is not None:
            cfile.parent.mkdir(parents=True, exist_ok=True)
            with atomic_write(cfile) as tmp:
                np.savez(tmp, **clear._asdict())
    patches = clear_patch_broadband(sky, states)      # the clear light's patches: the Perez cloud light's share
    t_sky = time.perf_counter() - t0
    dni, dhi, ghi = (data[c].to_numpy() for c in ("dni", "dhi", "ghi"))
    tdew = data["temp_dew"].to_numpy() if "temp_dew" in data else None
    vmin = float(np.min(sky.model.visibility_range))
    ref = {k: (s * g173 * w).sum() / (g173 * w).sum() for k, s in sr.items()}
    # (*) the model's own G173 state, with the ground of each variant (grey, or vegetated as the default)
    ref_model = {g: {k: (s * m * w).sum() / (m * w).sum() for k, s in sr.items()} for g, m in g173_model.items()}
    rows, times, spectra = [], {}, {}
    shape = vegetation_albedo_shape(wl)
    snow = data["snow_depth"].to_numpy() if "snow_depth" in data else None
    for label, opt in VARIANTS:
        t1 = time.perf_counter()
        f = allsky_factors(edges, clear.dni, clear.dhi, states.sun_elevation, dni, dhi, ghi=ghi,
                           visibility=vis, temp_dew=tdew, min_visibility=vmin, options=opt,
                           albedo=states.albedo, earth_sun_distance=states.earth_sun_distance)
        times[label] = time.perf_counter() - t1
        ground = {} if opt.ground == "grey" else {"albedo_shape": shape, "channel_edges": edges,
                                                  "vegetated": vegetated_steps(states.albedo, snow)}
        ratio = cloud_poa_ratio(f, states.sun_direction, tilt, azimuth, clear=(*patches, clear.dhi, edges))
        poa = plane_poa(clear, f.dni_scale, f.diffuse_scale, states.albedo, overcast_dhi=f.overcast_dhi,
                        circumsolar_dhi=f.circumsolar_dhi, overcast_ratio=ratio, **ground)
        E = poa["poa_global"]
        tot = (E * w).sum()
        se = {k: ((E * s * w).sum() / tot) / ref[k] - 1.0 for k, s in sr.items()}
        se.update({k + "*": ((E * s * w).sum() / tot) / ref_model[opt.ground][k] - 1.0 for k, s in sr.items()})
        a = ape(E, wl, w)
        over = kt < 0.3
        rows.append((label, se, float(np.nanmedian(a)), float(ape(E[over].sum(0), wl, w)),
                     float(ape(E.sum(0), wl, w)), float((E @ w).sum() / 1000.0), f))
        spectra[label] = (E, a, poa["ghi"])
    # the ground: grey (AllSkyOptions(ground="grey")) against the default vegetated ground
    ground_rows = [("all-sky, grey ground", rows[-3][1]), ("all-sky, vegetated ground (default)", rows[-2][1]),
                   ("vegetated hours", float(np.mean(vegetated_steps(states.albedo, snow))))]
    sin_el = np.sin(np.radians(states.sun_elevation))
    g_clear = ((clear.dni * sin_el[:, None] + clear.dhi) * w).sum(1)
    kc_model = ghi / g_clear
    from widesky.irradiance.haze import relative_airmass
    am = relative_airmass(states.sun_elevation)
    pv_mask = (kc_model > 0.05) & (kc_model < 1.5) & (ghi > 20.0) & (states.sun_elevation > 5.0)
    ape_kc = {"plain": ape_by_kc(spectra["plain (today)"][2], kc_model, wl, w),
              "all-sky, Ernst partition": ape_by_kc(spectra["+ cloud-top Rayleigh"][2], kc_model, wl, w),
              "all-sky": ape_by_kc(spectra[VARIANTS[-1][0]][2], kc_model, wl, w)}
    if sedes2 is not None:
        es = sedes2_global_horizontal(sedes2, edges, clear.dni, clear.dhi, sin_el, ghi)
        ape_kc["SEDES2"] = ape_by_kc(es, kc_model, wl, w)
    pressure_ratio = wd.site.pressure / 101325.0
    kc_linke = linke_clearsky_index(wd.site, data.index, 90.0 - states.sun_elevation, ghi, am * pressure_ratio)
    return {"kc_model": kc_model, "am": am, "pressure_ratio": pressure_ratio, "kc_linke": kc_linke, "sky": sky, "ground_rows": ground_rows, "sin_el": sin_el, "pvspec_mask": pv_mask, "ape_kc": ape_kc, "name": name, "rows": rows, "t_sky": t_sky, "times": times, "n": len(states),
            "ape_g173": float(ape(g173, wl, w)), "kt": kt, "spectra": spectra, "states": st,
            "vis": vis, "clear": clear, "wl": wl, "w": w, "sr": sr, "ref": ref, "g173": g173, "tilt": tilt, "stride": stride}


def weighted_quantiles(x, weight, q):
    """Quantiles q of x with weights (the share of the weight at or below each value)."""
    o = np.argsort(x)
    c = np.cumsum(weight[o]) / weight.sum()
    return [float(x[o][min(np.searchsorted(c, p), len(x) - 1)]) for p in q]


def linke_clearsky_index(site, times, zenith, ghi, airmass_absolute):
    """GHI / clear-sky GHI of pvlib's Ineichen-Perez model with its monthly Linke turbidity climatology, the
    nearest available stand-in for the ESRA / Linke clear sky that PVSPEC's clear-sky index is defined with
    (Pelland et al. 2020); None without pvlib (a test dependency)."""
    try:
        import pvlib
    except ImportError:
        return None
    tl = pvlib.clearsky.lookup_linke_turbidity(times, site.latitude, site.longitude).to_numpy()
    extra = pvlib.irradiance.get_extra_radiation(times).to_numpy()
    cs = pvlib.clearsky.ineichen(np.asarray(zenith), np.asarray(airmass_absolute), tl, site.altitude, extra)
    return ghi / np.maximum(np.asarray(cs["ghi"]), 1.0)


def transposition_check(name, tilt, stride=1):
    """Annual plane-of-array irradiation [kWh m-2] of the same hours by pvlib's transposition models
    (an independent check of the angular part; pvlib is a test dependency)."""
    try:
        import pvlib
    except ImportError:
        return {}
    wd = ir.read_weather(_site_file(name))
    d, sp = wd.data, wd.solar_position()
    st = ir.sky_states(sp, d)
    up = (st["solar_elevation"] > ir.PragueSky().min_sun_elevation) & (d["ghi"] > 0)
    up &= np.isfinite(d["dni"]) & np.isfinite(d["dhi"])
    d, sp = d[up][::stride], sp[up][::stride]
    out = {}
    for model in ("isotropic", "haydavies", "perez"):
        kw = {}
        if model != "isotropic":
            kw["dni_extra"] = d["dni_extra"]
        if model == "perez":
            kw["airmass"] = pvlib.atmosphere.get_relative_airmass(sp["apparent_zenith"])
        r = pvlib.irradiance.get_total_irradiance(tilt, 180.0 if wd.site.latitude >= 0 else 0.0,
                                                  sp["apparent_zenith"], sp["azimuth"], d["dni"],
                                                  d["ghi"], d["dhi"], albedo=0.2, model=model, **kw)
        out[model] = float(r["poa_global"].sum() / 1000.0)
    return out


def report(res):
    techs = ("a-Si", "CdTe", "c-Si", "CIGS")
    print(f"\n== {res['name']}: {res['n']} daylight hours, south plane at latitude; APE(G173) "
          f"{res['ape_g173']:.3f} eV; sky evaluation {res['t_sky']:.1f} s")
    print(f"{'variant':34s} " + " ".join(f"{t:>6s}" for t in techs) + "  spread  APE med  APE ovc  APE ann  H [kWh m-2]")
    for label, se, a_med, a_ovc, a_ann, H, _ in res["rows"]:
        print(f"{label:34s} " + " ".join(f"{100 * se[t]:+6.2f}" for t in techs)
              + f"  {100 * (se['a-Si'] - se['CIGS']):6.2f}  {a_med:7.3f}  {a_ovc:7.3f}  {a_ann:7.3f}  {H:8.1f}")
    print(f"ground (irradiance.ground; the weather's broadband albedo kept; vegetated hours {res['ground_rows'][2][1]:.1%}):")
    for label, se in res["ground_rows"][:2]:
        print(f"{label:34s} " + " ".join(f"{100 * se[t]:+6.2f}" for t in techs) + f"  {100 * (se['a-Si'] - se['CIGS']):6.2f}")
    print("relative to the sky model's own spectrum at the G173 state (*):")
    for label, se, *_ in res["rows"]:
        print(f"{label:34s} " + " ".join(f"{100 * se[t + '*']:+6.2f}" for t in techs)
              + f"  {100 * (se['a-Si*'] - se['CIGS*']):6.2f}")
    tr = transposition_check(res["name"], res["tilt"], res["stride"])
    if tr:
        print("annual POA of pvlib's transpositions (same hours, albedo 0.2) [kWh m-2]: "
              + ", ".join(f"{k} {v:.1f}" for k, v in tr.items()))
    if res["name"] == "amsterdam":
        print(f"{'Dirnberger 2015, Freiburg':34s} " + " ".join(f"{DIRNBERGER_FREIBURG[t]:+6.2f}" for t in techs)
              + f"  {DIRNBERGER_FREIBURG['a-Si'] - DIRNBERGER_FREIBURG['CIGS']:6.2f}")
    base = res["times"]["plain (today)"]
    print("factor time: " + ", ".join(f"{k} {1e3 * v:.1f} ms ({v / base:.1f}x plain)" for k, v in res["times"].items()))
    f = res["rows"][-1][6]
    if f.haze is not None:
        h = f.haze
        low = res["states"]["visibility_clamped"].to_numpy()
        print(f"sky state clamped at the dataset's lowest visibility: {low.mean():.1%} of hours; extended {h.extended.mean():.1%}, "
              f"bounded by the measured beam {h.beam_bounded.mean():.1%}, fog (< 1 km) {h.fog.mean():.1%}, "
              f"sun hidden (not extended) {h.sun_hidden.mean():.1%}; median extra AOD550 where extended "
              f"{np.median(h.delta_aod550[h.extended]) if h.extended.any() else 0:.3f}")
    for label in ("plain (today)", VARIANTS[-1][0]):
        _, a, _ = res["spectra"][label]
        a = a[np.isfinite(a)]
        hist, edges = np.histogram(a, bins=np.arange(1.5, 2.3, 0.01))
        half = edges[:-1][hist >= hist.max() / 2]
        print(f"  hourly APE, {label}: mode {edges[np.argmax(hist)] + 0.005:.3f} eV, median "
              f"{np.median(a) - res['ape_g173']:+.3f} eV from G173, half width at half maximum "
              f"{(half.max() - half.min() + 0.01) / 2:.3f} eV")
    kt = res["kt"]
    E0, _, _ = res["spectra"]["plain (today)"]
    E1, _, _ = res["spectra"][VARIANTS[-1][0]]
    for lo, hi in ((0, 0.3), (0.3, 0.6), (0.6, 2)):
        m = (kt >= lo) & (kt < hi)
        if m.sum() == 0:
            continue
        out = []
        for E in (E0, E1):
            tot = (E[m] * res["w"]).sum()
            out.append(100 * (((E[m] * res["sr"]["a-Si"] * res["w"]).sum() / tot) / res["ref"]["a-Si"] - 1))
        print(f"  kt [{lo}, {hi}): {m.sum()} h, a-Si spectral effect plain {out[0]:+.1f} %, all-sky {out[1]:+.1f} %")
    pub = pvspec_published()
    if pub is not None:
        print("  PVSPEC form fitted to the hourly plane spectra (exponent a2 of the clear-sky index; published "
              "a2 in brackets, Pelland et al. 2020):")
        for label in ("plain (today)", "+ cloud water vapour", "+ cloud-top Rayleigh", VARIANTS[-1][0]):
            fit = pvspec_fit(res["spectra"][label][0], res["kc_model"], res["am"], res["sr"], res["pvspec_mask"])
            print(f"    {label:28s} " + ", ".join(f"{k} {fit[k][0]:+.4f} ({pub[k][0]:+.4f}; a3 {fit[k][1]:+.3f} ({pub[k][1]:+.3f}))" for k in fit))
            b = mismatch_by_kc(res["spectra"][label][0], res["kc_model"], res["sr"]["a-Si"], res["pvspec_mask"])
            print("      a-Si median mismatch relative to kc 0.9-1.1 (PVSPEC kc^a2 at the bin centre): " + ", ".join(
                f"[{lo:.1f}, {hi:.1f}) {v:.3f} ({c ** pub['a-Si'][0]:.3f})" for (lo, hi), c, v in b))
    weight = (res["spectra"][VARIANTS[-1][0]][0] * res["w"]).sum(1)
    for kc_label, kc in (("Linke (Ineichen-Perez) clear-sky index", res["kc_linke"]),
                         ("the model's clear-sky index", res["kc_model"])):
        pv = None if kc is None else pvspec_annual(kc, res["am"] * res["pressure_ratio"], weight)
        if pv is None:
            continue
        annual, clear = pv
        print(f"  PVSPEC's measured relation (Pelland et al. 2020) on these hours ({kc_label}, absolute air "
              "mass, weights = all-sky POA):")
        for label, d in (("PVSPEC at kc 1, AM 1.5", clear), ("PVSPEC, annual", annual)):
            print(f"    {label:30s} " + " ".join(f"{100 * d[t]:+6.2f}" for t in techs)
                  + f"  spread {100 * (d['a-Si'] - d['CIGS']):5.2f}")
        if kc is res["kc_linke"]:
            import pvlib
            E = res["spectra"][VARIANTS[-1][0]][0]
            am_abs = res["am"] * res["pressure_ratio"]
            clear_hours = (kc > 0.9) & (kc < 1.1) & (res["sin_el"] > np.sin(np.radians(5.0)))
            print("    clear hours (kc 0.9-1.1): median mismatch against G173 by absolute air mass, the model "
                  "(PVSPEC at kc 1 in brackets):")
            for t in ("a-Si", "CIGS"):
                print(f"      {t:5s} " + ", ".join(
                    f"[{lo:.1f}, {hi:.1f}) n {n} {v:.3f} ({float(pvlib.spectrum.spectral_factor_pvspec(c, 1.0, PVSPEC_TYPES[t])):.3f})"
                    for (lo, hi), c, n, v in mismatch_by_airmass(E, res["w"], res["sr"][t], res["ref"][t], am_abs,
                                                                  clear_hours)))
            kc_c = np.clip(kc, 0.05, 1.5)
            H = (E * res["w"]).sum(1)
            ok = (res["sin_el"] > np.sin(np.radians(5.0))) & (H > 20.0)
            print("    hourly mismatch against G173, energy-weighted quantiles 10/25/50/75/90 % (sun above 5 deg, "
                  "POA > 20 W m-2), the model | PVSPEC on the same hours, and their correlation:")
            for t in techs:
                m_mod = (E * res["sr"][t] * res["w"]).sum(1) / H / res["ref"][t]
                m_pv = np.asarray(pvlib.spectrum.spectral_factor_pvspec(am_abs, kc_c, PVSPEC_TYPES[t]), float)
                qm, qp = (weighted_quantiles(x[ok], H[ok], (0.1, 0.25, 0.5, 0.75, 0.9)) for x in (m_mod, m_pv))
                print(f"      {t:5s} " + " ".join(f"{v:.3f}" for v in qm) + " | " + " ".join(f"{v:.3f}" for v in qp)
                      + f" | r {np.corrcoef(m_mod[ok], m_pv[ok])[0, 1]:.2f}")
            trend = spctrl2_airmass_trend(res["sky"], res["sr"], res["tilt"])
            print("    SPCTRL2 (clear, AOD500 0.084, the sun in the plane's azimuth) against G173 on the same plane: "
                  + ", ".join(f"AM {am:.2f} a-Si {d['a-Si']:+.2f} % CIGS {d['CIGS']:+.2f} %" for _, am, d in trend))
    for label, ap in res["ape_kc"].items():
        print(f"  median hourly APE (horizontal) by clear-sky index, {label}: "
              + ", ".join(f"[{lo:.1f}, {hi:.1f}) {v:.3f}" for (lo, hi), v in ap))


def figure(results, path, diffuse=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    techs = ("a-Si", "CdTe", "c-Si", "CIGS")
    ams = next(r for r in results if r["name"] == "amsterdam")
    fig, axes = plt.subplots(2, 3, figsize=(15, 9.2))
    axes = axes.ravel()
    ax = axes[0]
    x = np.arange(len(techs))
    rows = ams["rows"]
    bars = [("all-sky (vegetated ground), vs G173", {t: 100 * rows[-1][1][t] for t in techs}, "C1"),
            ("all-sky, grey ground, vs G173", {t: 100 * ams["ground_rows"][0][1][t] for t in techs}, "C2"),
            ("all-sky, vs the model at the G173 state", {t: 100 * rows[-1][1][t + "*"] for t in techs}, "C4")]
    pv = None if ams["kc_linke"] is None else pvspec_annual(
        ams["kc_linke"], ams["am"] * ams["pressure_ratio"], (ams["spectra"][VARIANTS[-1][0]][0] * ams["w"]).sum(1))
    if pv is not None:
        bars.append(("PVSPEC's measured relation on these hours", {t: 100 * pv[0][t] for t in techs}, "C9"))
    bars.append(("Freiburg, measured (Dirnberger 2015)", DIRNBERGER_FREIBURG, "0.35"))
    bw = 0.8 / len(bars)
    for i, (label, se, colour) in enumerate(bars):
        ax.bar(x + (i - (len(bars) - 1) / 2) * bw, [se[t] for t in techs], bw, color=colour,
               label=label if "Freiburg" in label or "PVSPEC" in label else f"Amsterdam, {label}")
    top = max(max(se[t] for t in techs) for _, se, _ in bars)
    ax.set_ylim(-1.5, top + 3.5)
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xticks(x, [f"{t}\nplain {100 * rows[0][1][t]:+.1f}" for t in techs])
    ax.set_xlabel("(plain: the clear-sky shape scaled to the weather, before the all-sky model)", fontsize=8)
    ax.set_ylabel("annual spectral effect [%]")
    ax.set_title("Annual spectral effect, south plane tilted at latitude")
    ax.legend(fontsize=7, loc="upper right")
    ax = axes[1]
    bins = np.linspace(1.6, 2.2, 61)
    kt = ams["kt"]
    for label, short in ((rows[0][0], "plain"), (rows[-1][0], "all-sky")):
        _, a, _ = ams["spectra"][label]
        ax.hist(a[kt < 0.3], bins=bins, histtype="step", lw=1.5, label=f"{short}, kt < 0.3")
        ax.hist(a[kt >= 0.6], bins=bins, histtype="step", lw=1.0, ls="--", label=f"{short}, kt >= 0.6")
    ax.axvline(ams["ape_g173"], color="k", lw=1, label="G173 global tilt")
    ax.set_xlabel("average photon energy 340-1060 nm [eV]")
    ax.set_ylabel("hours")
    ax.set_title("Hourly APE on the plane, Amsterdam IWEC")
    ax.legend(fontsize=7)
    ax = axes[2]
    wl = ams["wl"]
    over = np.argmin(np.abs(kt - 0.15) + 10 * (ams["states"]["solar_elevation"].to_numpy() < 25))
    for label, short in ((rows[0][0], "plain (today)"), (rows[-1][0], "all-sky")):
        E, _, _ = ams["spectra"][label]
        e = E[over]
        ax.plot(wl, e / (e * ams["w"]).sum() * 1000, label=short)
    g = ams["g173"]
    ax.plot(wl, g / (g * ams["w"]).sum() * 1000, "k:", label="G173 global tilt")
    ax.set_xlim(280, 1400)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("spectral irradiance per 1000 W m-2 [W m-2 nm-1]")
    ax.set_title(f"One overcast hour (kt {kt[over]:.2f}) on the plane")
    ax.legend(fontsize=8)
    ax = axes[3]
    if diffuse is not None:
        for k, style in (("G173", "k:"), ("SPCTRL2", "C2-"), ("model", "C0-"), ("model, vegetated ground", "C1--")):
            ax.plot(diffuse["wl"], diffuse[k], style,
                    label={"model": "sky model (dataset), grey ground"}.get(k, "sky model, " + k[7:] if k.startswith("model, ") else k))
        ax.set_xlim(280, 1400)
        ax.set_xlabel("wavelength [nm]")
        ax.set_ylabel("diffuse on the plane [W m-2 nm-1]")
        ax.set_title("Diffuse on the 37 deg plane at the G173 state")
        ax.legend(fontsize=8)
    ax = axes[4]
    pub = pvspec_published()
    kcs = np.linspace(0.1, 1.2, 50)
    for label, short in ((rows[0][0], "plain"), ("+ cloud water vapour", "Ernst partition, no cloud-top Rayleigh"),
                         ("+ cloud-top Rayleigh", "Ernst partition"), (rows[-1][0], "all-sky")):
        b = mismatch_by_kc(ams["spectra"][label][0], ams["kc_model"], ams["sr"]["a-Si"], ams["pvspec_mask"])
        cen, med = [c for _, c, _ in b], [v for _, _, v in b]
        ax.plot(cen, med, "o-", label=short)
    if pub is not None:
        ax.plot(kcs, kcs ** pub["a-Si"][0], "k--", label="PVSPEC a-Si (Pelland et al. 2020)")
    ax.set_xlabel("clear-sky index GHI / GHI_clear")
    ax.set_ylabel("a-Si mismatch relative to kc 0.9-1.1")
    ax.set_title("a-Si spectral mismatch vs clear-sky index (plane)")
    ax.legend(fontsize=7)
    ax = axes[5]
    for label, ap in ams["ape_kc"].items():
        ax.plot([0.5 * (lo + min(hi, 1.2)) for (lo, hi), _ in ap], [v for _, v in ap], "o-", label=label)
    ax.axhline(ams["ape_g173"], color="k", lw=1, ls=":", label="G173 global tilt")
    ax.set_xlabel("clear-sky index GHI / GHI_clear")
    ax.set_ylabel("median hourly APE 340-1060 nm [eV]")
    ax.set_title("APE of global horizontal spectra vs clear-sky index")
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_write(path) as tmp:
        fig.savefig(tmp, dpi=110)
    print(f"figure written: {path}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sites", default="amsterdam", help="amsterdam, all, or a comma list of " + ", ".join(SITES))
    ap.add_argument("--prefer", default="aod", choices=("visibility", "aod"),
                    help="aerosol input of the sky state: the weather file's AOD column where valid (default) or its station visibility")
    ap.add_argument("--figure", default=None, help="write the study figure (PNG)")
    ap.add_argument("--stride", type=int, default=1,
                    help="keep every n-th daylight hour (a quicker sample of the year; 1 = all)")
    ap.add_argument("--sedes2", default=None,
                    help="CSV of SEDES2 cloud cover modifier coefficients (wavelength_nm,A1,A2,B1,B2,C1,C2) to "
                         "compare with (not shipped; see docs/all-sky.md)")
    ap.add_argument("--cache", default=None,
                    help="folder to keep the clear-sky spectra in between runs (reused when present)")
    args = ap.parse_args(argv)
    if args.sedes2 is not None and not Path(args.sedes2).is_file():
        ap.error(f"--sedes2: {args.sedes2!r} is not a file")
    names = list(SITES) if args.sites == "all" else args.sites.split(",")
    sky = ir.PragueSky()
    g173 = g173_channels(np.asarray(sky.channel_edges))
    sr = spectral_response(generic_eqe(sky.wavelengths), sky.wavelengths)
    g173_model = {g: model_at_g173(sky, ground=g) for g in ("grey", "vegetation")}
    w = np.diff(sky.channel_edges)
    for g, m in g173_model.items():
        print(f"the sky model at the G173 state ({g} ground) against G173 (spectral effect of the model's "
              "reference spectrum, %): " + ", ".join(f"{k} {100 * (((m * s * w).sum() / (m * w).sum()) / ((g173 * s * w).sum() / (g173 * w).sum()) - 1):+.2f}"
                                              for k, s in sr.items()) + f"; APE {ape(m, sky.wavelengths, w):.3f} eV")
    decomposition, diffuse = g173_decomposition(sky, sr)
    print("where the difference sits (spectral effects against G173 unless named, %):")
    for label, v in decomposition.items():
        print(f"  {label:34s} " + ", ".join(f"{k} {x:+.2f}" for k, x in v.items()))
    results = []
    for n in names:
        if n not in SITES:
            raise SystemExit(f"--sites: {n!r} is not one of {', '.join(SITES)}")
        res = run_site(n, sky, sr, g173, g173_model, prefer=args.prefer, cache=args.cache,
                       stride=args.stride, sedes2=args.sedes2)
        report(res)
        results.append(res)
    if args.figure:
        figure(results, args.figure, diffuse)


if __name__ == "__main__":
    main()
