"""Benchmark: NREL SPA solar position, vectorised over a year vs a per-timestamp loop.

Run: ``python benchmarks/bench_solarposition.py [--repeat N]``. Prints times and the ratio
against the baseline measured in the same run (the same SPA called once per timestamp, as a
scalar implementation would be used).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from widesky.irradiance.location import Site
from widesky.irradiance.solarposition import solar_position, spa


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    lat, lon, alt = 52.3, 4.77, 0.0
    hourly = pd.date_range("2021-01-01", "2022-01-01", freq="1h", tz="UTC", inclusive="left")
    minutes = pd.date_range("2021-01-01", "2022-01-01", freq="1min", tz="UTC", inclusive="left")
    ut = hourly.as_unit("s").asi8.astype(float)

    t_vec = best_of(lambda: spa(ut, lat, lon, alt), args.repeat)
    t_df = best_of(lambda: solar_position(hourly, lat, lon, alt), args.repeat)
    site = Site(lat, lon, alt, tz="UTC")
    t_site = best_of(lambda: site.solar_position(hourly, label="right", step="1h"), args.repeat)
    n_loop = 876  # a tenth of the year; scaled to 8760 below
    t_loop = best_of(lambda: [spa(u, lat, lon, alt) for u in ut[:n_loop]], 1) * (len(ut) / n_loop)
    t_min = best_of(lambda: spa(minutes.as_unit("s").asi8.astype(float), lat, lon, alt), 1)

    print(f"NREL SPA, {len(hourly)} hourly positions (one core, numpy {np.__version__})")
    print(f"  baseline: scalar loop, one spa() call per timestamp : {t_loop * 1e3:9.1f} ms "
          f"(timed on {n_loop}, scaled)")
    print(f"  spa() vectorised arrays                              : {t_vec * 1e3:9.1f} ms "
          f"({t_loop / t_vec:6.0f}x the baseline)")
    print(f"  solar_position() DataFrame                           : {t_df * 1e3:9.1f} ms")
    print(f"  Site.solar_position() with mid-interval shift        : {t_site * 1e3:9.1f} ms")
    print(f"  per position (vectorised)                            : {t_vec / len(ut) * 1e6:9.2f} us")
    print(f"{len(minutes)} one-minute positions (a year)              : {t_min:9.2f} s "
          f"({len(minutes) / t_min / 1e6:.2f} M positions/s)")


if __name__ == "__main__":
    main()
