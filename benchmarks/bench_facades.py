"""Facades and tilted planes under measured weather: the all-sky model against pvlib's Perez transposition.

Issue 39. For each weather year, every daylight hour (sun above the dataset's lowest elevation, GHI > 0,
DNI and DHI measured), the default dataset's clear sky at the step's state (aerosol from the file's AOD
column, as ``widesky.Simulation`` does), and unobstructed planes (``widesky.irradiance.allsky_plane``: the
integrator's own sky quadrature, no ray casting): horizontal, vertical and 30 deg tilted facing S, N, E, W.
Annual plane-of-array irradiation of the direct and sky parts (circumsolar light included, no ground)
for the all-sky model with the cloud light as the CIE overcast sky plus the Perez F1 circumsolar share
traced with the sun (``AllSkyOptions(angular="cie_overcast")``, the default until 2026-12-05), with the Perez
all-weather sky (``angular="perez"``, the default since) and with the plain path (clear-sky shape scaled to
the measured DNI/DHI); pvlib 0.16's ``get_total_irradiance`` (Perez 1990 "allsitescomposite1990" and
Hay-Davies) on the same hours, DNI, DHI, sun position, extraterrestrial irradiance and Kasten-Young air mass.

Usage:  python benchmarks/bench_facades.py [--sites all|denver,...] [--stride N] [--monthly]

Prints per site a table of annual kWh m-2 and the ratios to pvlib's Perez. The sky evaluation dominates
(about a minute per site-year on one core).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import widesky.irradiance as ir
from widesky.irradiance.allsky import CLEAR_SHAPE, AllSkyOptions, allsky_factors
from widesky.irradiance.allsky_plane import ClearPlaneSpectra, cloud_poa_ratio, plane_poa
from widesky.irradiance.integrator import IntegratorSettings, patch_radiance
from widesky.irradiance.overcast_sky import overcast_poa_ratio
from widesky.irradiance.patches import cosine_weights, direction_from_angles, reinhart

SITES = {
    "amsterdam": "NLD_Amsterdam062400_IWEC.epw",
    "chicago": "USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw",
    "denver": "USA_CO_Denver.Intl.AP.725650_TMY3.epw",
    "san_francisco": "USA_CA_San.Francisco.Intl.AP.724940_TMY3.epw",
}

PLANES = (("H", 0.0, 180.0), ("S90", 90.0, 180.0), ("N90", 90.0, 0.0), ("E90", 90.0, 90.0), ("W90", 90.0, 270.0),
          ("S30", 30.0, 180.0), ("N30", 30.0, 0.0), ("E30", 30.0, 90.0), ("W30", 30.0, 270.0))

VARIANTS = (("plain", CLEAR_SHAPE, True), ("cie+F1", AllSkyOptions(angular="cie_overcast"), True),
            ("cloud=perez93", AllSkyOptions(angular="perez"), False),
            ("perez93", AllSkyOptions(angular="perez"), True))


def site_inputs(path, sky, stride=1):
    """States, weather rows and sun geometry of a weather year's daylight hours."""
    from widesky.core.paths import data_reference
    wd = ir.read_weather(data_reference(f"data:weather/{path}"))
    st = ir.sky_states_for(wd, model=sky.model, prefer="aod", warn=False)
    d = wd.data.loc[st.times]
    keep = ((st.sun_elevation > sky.min_sun_elevation) & (d["ghi"].to_numpy() > 0)
            & np.isfinite(d["dni"].to_numpy()) & np.isfinite(d["dhi"].to_numpy()))
    idx = np.nonzero(keep)[0][::stride]
    return wd, st.take(idx), d.iloc[idx]


def clear_planes(sky, states, planes, settings, chunk=256):
    """Clear-sky spectra of every plane in one pass of the sky: dict name -> ClearPlaneSpectra."""
    patches = reinhart(settings.mf)
    normals = np.stack([direction_from_angles(90.0 - t, a) for _n, t, a in planes])
    w_h = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]
    w_p = cosine_weights(patches, normals)                                  # (F, P)
    T, C, F = len(states), sky.n_channels, len(planes)
    dni, dhi, circ = (np.zeros((T, C)) for _ in range(3))
    psky = np.zeros((F, T, C))
    lbb, cbb = np.zeros((T, patches.n_patches)), np.zeros(T)
    wc = np.diff(sky.channel_edges)
    sin_el = np.sin(np.radians(np.maximum(states.sun_elevation, 0.0)))
    for c0 in range(0, T, chunk):
        idx = np.arange(c0, min(T, c0 + chunk))
        Lp, dn, cs = patch_radiance(sky, patches, states.take(idx), None, settings)
        dni[idx], circ[idx] = dn, cs
        dhi[idx] = np.einsum("p,tpc->tc", w_h, Lp) + cs * sin_el[idx, None]
        psky[:, idx] = np.einsum("fp,tpc->ftc", w_p, Lp)
        lbb[idx], cbb[idx] = Lp @ wc, cs @ wc
    out = {}
    s = states.sun_direction
    for i, (name, tilt, _az) in enumerate(planes):
        cos_aoi = np.where(states.sun_elevation > 0, np.maximum(s @ normals[i], 0.0), 0.0)
        ratio = float(overcast_poa_ratio(w_p[i], w_h, patches.directions[:, 2]))
        vg = 0.5 * (1.0 - np.cos(np.radians(tilt)))
        out[name] = ClearPlaneSpectra(dni, dhi, circ, psky[i], cos_aoi, sin_el, ratio, vg)
    out["_patches"] = (lbb, cbb, dhi, sky.channel_edges)
    return out


def pvlib_planes(wd, states, data, planes):
    """pvlib's Perez and Hay-Davies direct + sky [W m-2] per plane: dict model -> name -> (T,)."""
    import pvlib
    zen = 90.0 - states.sun_elevation
    az = states.sun_azimuth
    e0 = 1361.0 / states.earth_sun_distance ** 2
    am = pvlib.atmosphere.get_relative_airmass(zen, model="kastenyoung1989")
    out = {}
    for model in ("perez", "haydavies"):
        out[model] = {}
        for name, tilt, paz in planes:
            r = pvlib.irradiance.get_total_irradiance(tilt, paz, zen, az, data["dni"].to_numpy(),
                                                      data["ghi"].to_numpy(), data["dhi"].to_numpy(),
                                                      dni_extra=e0, airmass=am, model=model, albedo=0.0)
            out[model][name] = np.nan_to_num(np.asarray(r["poa_direct"]) + np.asarray(r["poa_sky_diffuse"]))
    return out


def psm93_planes(states, data, planes, settings):
    """The Perez (1993) sky on its own, broadband: DNI cos(aoi) + DHI x its patch shape on the plane [W m-2]."""
    from widesky.irradiance.perez_sky import perez_clearness_brightness, perez_patch_shape
    p = reinhart(settings.mf)
    dni, dhi = data["dni"].to_numpy(), data["dhi"].to_numpy()
    eps, delta, ok = perez_clearness_brightness(dhi, dni, states.sun_elevation, 1361.0 / states.earth_sun_distance ** 2)
    shape = perez_patch_shape(p, states.sun_direction, eps, delta, ok)
    out = {}
    for name, tilt, paz in planes:
        n = direction_from_angles(90.0 - tilt, paz)
        cos = np.where(states.sun_elevation > 0, np.maximum(states.sun_direction @ n, 0.0), 0.0)
        out[name] = dni * cos + dhi * (shape @ cosine_weights(p, n.reshape(1, 3))[0])
    return out


def widesky_planes(sky, states, data, clear, planes, options, settings, share=True):
    """Broadband direct + sky [W m-2] per plane of one all-sky variant: dict name -> (T,)."""
    w = np.diff(sky.channel_edges)
    first = clear[planes[0][0]]
    f = allsky_factors(sky.channel_edges, first.dni, first.dhi, states.sun_elevation, data["dni"].to_numpy(),
                       data["dhi"].to_numpy(), ghi=data["ghi"].to_numpy(), temp_dew=data["temp_dew"].to_numpy(),
                       min_visibility=float(np.min(sky.model.visibility_range)), options=options,
                       albedo=states.albedo, earth_sun_distance=states.earth_sun_distance)
    out = {}
    for name, tilt, paz in planes:
        ratio = cloud_poa_ratio(f, states.sun_direction, tilt, paz, settings,
                                clear=clear["_patches"] if share else None)
        p = plane_poa(clear[name], f.dni_scale, f.diffuse_scale, 0.0, overcast_dhi=f.overcast_dhi,
                      circumsolar_dhi=f.circumsolar_dhi, overcast_ratio=ratio)
        out[name] = (p["poa_direct"] + p["poa_sky_diffuse"]) @ w
    out["_ghi"] = p["ghi"] @ w
    return out


def run_site(site, sky, stride=1, settings=None, monthly=False):
    settings = settings or IntegratorSettings()
    t0 = time.perf_counter()
    wd, states, data = site_inputs(SITES[site], sky, stride)
    clear = clear_planes(sky, states, PLANES, settings)
    t1 = time.perf_counter()
    ref = pvlib_planes(wd, states, data, PLANES)
    res = {"PSM93 alone": psm93_planes(states, data, PLANES, settings)}
    res.update({label: widesky_planes(sky, states, data, clear, PLANES, opt, settings, sh) for label, opt, sh in VARIANTS})
    k = stride / 1000.0
    print(f"\n{site}: {len(states)} hours (stride {stride}), sky {t1 - t0:.0f} s, all-sky {time.perf_counter() - t1:.0f} s;"
          f" GHI measured {data['ghi'].sum() * k:.1f}, all-sky {res['perez93']['_ghi'].sum() * k:.1f} kWh m-2")
    names = ["PSM93 alone"] + [v for v, *_ in VARIANTS]
    print("| plane | pvlib Perez | Hay-Davies / Perez | " + " | ".join(f"{v} / Perez" for v in names) + " |")
    print("|---|---|---|" + "---|" * len(names))
    rows = {}
    for name, _t, _a in PLANES:
        p = ref["perez"][name].sum()
        r = [res[v][name].sum() / p for v in names]
        rows[name] = r
        print(f"| {name} | {p * k:.1f} | {ref['haydavies'][name].sum() / p:.3f} | "
              + " | ".join(f"{x:.3f}" for x in r) + " |")
    if monthly:
        month = data.index.month
        print("monthly perez93 / Perez:")
        for name, _t, _a in PLANES:
            m = [res["perez93"][name][month == i].sum() / max(ref["perez"][name][month == i].sum(), 1e-9)
                 for i in range(1, 13)]
            print(f"  {name}: " + " ".join(f"{x:.3f}" for x in m))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sites", default="all")
    ap.add_argument("--stride", type=int, default=1)
    ap.add_argument("--monthly", action="store_true")
    a = ap.parse_args(argv)
    sites = list(SITES) if a.sites == "all" else a.sites.split(",")
    sky = ir.PragueSky()
    for s in sites:
        run_site(s, sky, a.stride, monthly=a.monthly)


if __name__ == "__main__":
    main()
