"""Benchmark: a 20-zone office block with context buildings, hourly, gains and loads end to end.

The block: 5 storeys x 4 perimeter zones (30 m x 15 m x 3.5 m, WWR 0.4, 0.8 m overhangs), two
neighbouring blocks as context, Denver TMY3. Stages timed:

* ``integrator``: widesky's poa_irradiance with the spectral-angular glazing Response (rays + sky +
  products), scaled to the file's measured DNI/DHI;
* ``loads``: per-surface gains and the 5R1C model for all 20 zones;
* ``zone_model``: the 5R1C recursion alone, per zone-year, for 1 zone and for 20 zones at once;
* baseline measured in the same run: the weather-only route (Hay-Davies, no shading) for the same
  building, and the ratio integrator / baseline.

Run: ``python benchmarks/bench_thermal.py [--days 365] [--jobs 2]``; prints a JSON line.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--days", type=int, default=365)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)

    import trimesh
    from widesky.irradiance import Simulation, dni_extra, read_epw
    from widesky.core.paths import runtime_file
    from widesky.thermal.building import ZoneSpec, box_building
    from widesky.thermal.gains import (building_scene, glazing_response, irradiance_by_surface,
                                       window_gain_by_surface)
    from widesky.thermal.loads import building_loads, zone_parameters
    from widesky.thermal.study import _constructions, standard_units
    from widesky.thermal.surface import sky_temperature, surface_irradiance
    from widesky.thermal.zone import simulate_5r1c

    w = read_epw(runtime_file("weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"))
    n = 24 * args.days
    import dataclasses
    w = dataclasses.replace(w, data=w.data.iloc[:n])
    data = w.data
    b = box_building(30.0, 15.0, 3.5, floors=5, wwr=0.4, overhang=0.8,
                     zone_use=ZoneSpec("use", air_changes=0.7, internal_gains=1125.0))
    ctx = [trimesh.creation.box((30.0, 15.0, 20.0)).apply_translation((15.0, -25.0, 10.0)),
           trimesh.creation.box((20.0, 20.0, 12.0)).apply_translation((55.0, 7.5, 6.0))]
    unit = standard_units()["low-e"]
    cons = _constructions("low-e", unit)
    t_sky = sky_temperature(np.maximum(data["ghi_infrared"].to_numpy(), 1.0))
    ta = data["temp_air"].to_numpy()
    out = {"zones": len(b.zones), "surfaces": len(b.surfaces), "steps": n}

    t0 = time.perf_counter()
    scene, labels = building_scene(b, ctx)
    sim = Simulation(scene, weather=w, n_jobs=args.jobs)
    res = sim.run([glazing_response(unit, "low-e:spectral")])
    irr = irradiance_by_surface(res, labels)
    wg = window_gain_by_surface(res, labels, b, cons, "spectral")
    t1 = time.perf_counter()
    building_loads(b, cons, data.index, ta, irr, temp_sky=t_sky, window_gain=wg)
    t2 = time.perf_counter()
    out.update(faces=int(scene.n_faces), integrator_s=t1 - t0, loads_s=t2 - t1,
               end_to_end_s=t2 - t0, integrator_timings={k: round(v, 2) for k, v in
                                                         res.timings.items()
                                                         if isinstance(v, float)})

    # baseline in the same run: weather-only route, same building and loads
    t3 = time.perf_counter()
    surf = [s for s in b.surfaces if s.kind != "shading"]
    sp = w.site.solar_position(data.index, w.label, w.step)
    irr_w = surface_irradiance([s.tilt for s in surf], [s.azimuth for s in surf],
                               sp["zenith"].to_numpy(), sp["azimuth"].to_numpy(),
                               data["dni"].to_numpy(), data["dhi"].to_numpy(), data["ghi"].to_numpy(),
                               dni_extra(sp["earth_sun_distance"].to_numpy()))
    building_loads(b, cons, data.index, ta, irr_w, temp_sky=t_sky)
    t4 = time.perf_counter()
    out.update(baseline_weather_route_s=t4 - t3, ratio_integrator_to_baseline=(t2 - t0) / (t4 - t3))

    # the zone model alone, per zone-year
    p = zone_parameters(b, cons)
    sol = np.tile(np.maximum(0, 3000 * np.sin(np.arange(8760) / 24 * 2 * np.pi)), (20, 1)).T
    te = np.resize(ta, 8760)
    t5 = time.perf_counter()
    simulate_5r1c(p, te, 1125.0, sol, 20.0, 26.0)
    t6 = time.perf_counter()
    from widesky.thermal.zone import ZoneParameters
    p1 = ZoneParameters(*(np.asarray(getattr(p, k))[0] for k in
                          ("floor_area", "h_tr_w", "h_tr_op", "h_ve", "heat_capacity", "mass_area")))
    simulate_5r1c(p1, te, 1125.0, sol[:, 0], 20.0, 26.0)
    t7 = time.perf_counter()
    out.update(zone_model_20_zones_s=t6 - t5, zone_model_per_zone_year_s=(t6 - t5) / 20,
               zone_model_one_zone_s=t7 - t6)
    print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in out.items()}))


if __name__ == "__main__":
    main()
