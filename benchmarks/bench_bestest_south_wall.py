"""The BESTEST south wall's annual light, part by part: widesky's integrator against pvlib's Perez and Hay-Davies.

Issue 38 asks whether the thermal validation rests on a compensating error: the integrator route once put 8 %
more light on the south wall than pvlib's Perez model for the same weather. This script splits the annual
irradiation [kWh m-2] on the south glazing (and the opaque south wall) of the ASHRAE 140 room
(:func:`widesky.thermal.bestest_geometry.bestest_building`, Denver TMY3, ground albedo 0.2) into

* beam: the file's DNI times cos(angle of incidence), the same for every model;
* circumsolar: the diffuse light each model traces with the sun (Perez F1 and Hay-Davies' anisotropy index
  terms in pvlib; on the integrator route its ``direct`` part minus the beam: the all-sky model's circumsolar
  cloud light; the clear-sky aureole of the sky model stays in its sky patches and counts as sky);
* sky: the rest of the sky's diffuse light (Perez: isotropic and horizon band, also shown apart);
* ground reflected: light from the ground (and, on the integrator route, from the room's own surfaces);

for the same hours and solar positions (widesky's SPA at the middle of each hour, fed to pvlib too):

    widesky integrator (window, wall)   the default sky route of ``widesky thermal bestest --sky integrator``
    widesky Perez                       thermal.surface.surface_irradiance, the weather route of the command
                                        (``--sky weather``, its default ``--transposition perez``)
    widesky Hay-Davies                  the same with ``--transposition hay-davies``
    pvlib Hay-Davies, pvlib Perez       pvlib.irradiance.haydavies / perez (return_components), get_ground_diffuse

Usage:  python benchmarks/bench_bestest_south_wall.py [--jobs N] [--data-dir DIR] [--csv OUT.csv]

Needs the reference data folder (weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw) and pvlib (installed for
benchmarks and tests only). One integrator year: about a minute on one core. Re-run it after a change of the
all-sky distribution (irradiance/allsky_sky.py) to see how the south wall moves.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np
import pandas as pd

from widesky.irradiance import dni_extra, read_epw, solar_position, sun_times
from widesky.thermal.bestest import GROUND_REFLECTANCE, WEATHER_FILES, integrator_irradiance
from widesky.thermal.gains import irradiance_by_surface
from widesky.thermal.surface import surface_irradiance
from widesky.thermal.facade import atomic_write
from widesky.core.paths import data_file

SOUTH = (90.0, 180.0)          # tilt, azimuth [deg]


def pvlib_parts(weather, sp, dne):
    """Annual parts [kWh m-2] on the south wall from pvlib's Perez and Hay-Davies."""
    import pvlib
    zen, az = sp["zenith"], sp["azimuth"]
    dni, dhi, ghi = (weather[k].to_numpy() for k in ("dni", "dhi", "ghi"))
    up = zen < 90
    beam = pvlib.irradiance.beam_component(SOUTH[0], SOUTH[1], zen, az, dni)
    beam = np.where(up, beam, 0.0)
    ground = pvlib.irradiance.get_ground_diffuse(SOUTH[0], ghi, albedo=GROUND_REFLECTANCE)
    am = pvlib.atmosphere.get_relative_airmass(np.where(up, zen, 89.9))
    per = pvlib.irradiance.perez(SOUTH[0], SOUTH[1], dhi, dni, dne, zen, az, am, return_components=True)
    hd = pvlib.irradiance.haydavies(SOUTH[0], SOUTH[1], dhi, dni, dne, zen, az, return_components=True)
    k = 1e-3
    out = {}
    out["pvlib Perez"] = {"beam": beam.sum() * k, "circumsolar": np.nansum(per["poa_circumsolar"]) * k,
                          "sky": (np.nansum(per["poa_isotropic"]) + np.nansum(per["poa_horizon"])) * k,
                          "  of which horizon band": np.nansum(per["poa_horizon"]) * k,
                          "ground reflected": np.nansum(ground) * k}
    out["pvlib Hay-Davies"] = {"beam": beam.sum() * k, "circumsolar": np.nansum(hd["poa_circumsolar"]) * k,
                               "sky": np.nansum(hd["poa_isotropic"]) * k, "  of which horizon band": 0.0,
                               "ground reflected": np.nansum(ground) * k}
    return out, beam


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python benchmarks/bench_bestest_south_wall.py")
    ap.add_argument("--jobs", type=int, default=1, help="ray-casting processes (default 1)")
    ap.add_argument("--data-dir", default=None)
    ap.add_argument("--csv", default=None, help="also write the table here")
    args = ap.parse_args(argv)

    w = read_epw(data_file(WEATHER_FILES["tmy3"], args.data_dir))
    weather = w.data
    times = sun_times(weather.index, label="right")
    sp = solar_position(times, w.site.latitude, w.site.longitude, w.site.altitude)
    sp = {k: sp[k].to_numpy() for k in ("zenith", "azimuth", "earth_sun_distance")}
    dne = dni_extra(sp["earth_sun_distance"])
    cols, beam = pvlib_parts(weather, sp, dne)

    k = 1e-3
    for name, tr in (("widesky Perez", "perez"), ("widesky Hay-Davies", "hay-davies")):
        r = surface_irradiance([SOUTH[0]], [SOUTH[1]], sp["zenith"], sp["azimuth"], weather["dni"].to_numpy(),
                               weather["dhi"].to_numpy(), weather["ghi"].to_numpy(), dne, GROUND_REFLECTANCE,
                               transposition=tr)
        cols[name] = {"beam": beam.sum() * k, "circumsolar": (r["poa_direct"][:, 0] - beam).sum() * k,
                      "sky": r["poa_sky_diffuse"][:, 0].sum() * k,
                      "  of which horizon band": r["poa_horizon"][:, 0].sum() * k,
                      "ground reflected": r["poa_ground_diffuse"][:, 0].sum() * k}

    t0 = time.perf_counter()
    with warnings.catch_warnings():          # TMY3 visibilities beyond the sky model's range: clamped
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        poa = integrator_irradiance("tmy3", args.data_dir, n_jobs=args.jobs, geometry=("south", None))
    seconds = time.perf_counter() - t0
    res = poa["result"]
    for name, label in (("widesky integrator, window", "window:room:window"),
                        ("widesky integrator, wall", None)):
        if label is None:
            parts = {p: poa[f"poa_{p}"][:, 2] for p in ("direct", "sky_diffuse", "ground_diffuse")}
        else:
            irr = irradiance_by_surface(res, [label])
            parts = {p: irr[f"poa_{p}"][:, 0] for p in ("direct", "sky_diffuse", "ground_diffuse")}
        cols[name] = {"beam": beam.sum() * k, "circumsolar": (parts["direct"] - beam).sum() * k,
                      "sky": parts["sky_diffuse"].sum() * k, "  of which horizon band": np.nan,
                      "ground reflected": parts["ground_diffuse"].sum() * k}

    order = ["widesky integrator, window", "widesky integrator, wall", "widesky Perez", "widesky Hay-Davies",
             "pvlib Hay-Davies", "pvlib Perez"]
    table = pd.DataFrame({c: cols[c] for c in order})
    table.loc["total"] = table.drop(index="  of which horizon band").sum()
    table.loc["diffuse (circumsolar + sky)"] = table.loc["circumsolar"] + table.loc["sky"]
    table.loc["total / pvlib Perez - 1 [%]"] = 100 * (table.loc["total"] / table.loc["total", "pvlib Perez"] - 1)
    pd.set_option("display.width", 200)
    print(f"BESTEST south wall (tilt 90, azimuth 180), Denver TMY3, albedo {GROUND_REFLECTANCE}: annual "
          "irradiation [kWh m-2]")
    print("| part | " + " | ".join(table.columns) + " |")
    print("|---|" + "---|" * len(table.columns))
    for name, row in table.iterrows():
        cells = ["-" if np.isnan(v) else f"{v:.1f}" for v in row]
        print(f"| {name.strip()} | " + " | ".join(cells) + " |")
    print(f"integrator year: {seconds:.0f} s ({args.jobs} process(es))")
    if args.csv:
        text = table.to_csv().encode()
        atomic_write(args.csv, lambda fh: fh.write(text))
    return 0


if __name__ == "__main__":
    sys.exit(main())
