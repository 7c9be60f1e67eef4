"""Cost of the all-sky model inside the integrator: poa_irradiance(measured=..., spectral_model=...).

A 4 x 3 m roof tilted 30 deg south on the shipped two-week sample weather file
(irradiance/data/sample_golden_june.epw, 336 hourly steps), the default dataset, default settings, one
ray-casting process. Times the plain measured path ("clear", the baseline) and the all-sky path in the
same run and prints the ratio of the sky phase and of the whole call. The all-sky path contracts the sky
to 1 + C columns (C = 55 channels) before applying its per-channel factors, against the responses'
columns for the plain path.

Usage:  python benchmarks/bench_allsky_poa.py [--repeat 2]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import trimesh

import widesky.irradiance as ir


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=2, help="runs of each path (the fastest is kept)")
    args = ap.parse_args(argv)
    epw = Path(ir.__file__).parent / "data" / "sample_golden_june.epw"
    wd = ir.read_weather(epw)
    sky = ir.PragueSky()
    states = ir.sky_states_for(wd, model=sky.model, warn=False)
    d = wd.data.loc[states.times]
    t = np.radians(30.0)
    v = np.array([[0, 0, 1.0], [4, 0, 1.0], [4, 3 * np.cos(t), 1 + 3 * np.sin(t)], [0, 3 * np.cos(t), 1 + 3 * np.sin(t)]])
    v[:, 1] *= -1                                               # rising toward the north: faces south
    scene = ir.make_scene(trimesh.Trimesh(v, [[0, 2, 1], [0, 3, 2]], process=False), ground_z=0.0)
    weather = ir.AllSkyWeather(d["dni"].to_numpy(), d["dhi"].to_numpy(), ghi=d["ghi"].to_numpy(),
                               visibility=d["visibility"].to_numpy() if "visibility" in d else None,
                               temp_dew=d["temp_dew"].to_numpy() if "temp_dew" in d else None)
    best = {}
    for model in ("clear", "allsky"):
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            res = ir.poa_irradiance(scene, sky, states,
                                    weather=ir.MeasuredSky(measured=weather, spectral_model=model),
                                    run=ir.RunOptions(n_jobs=1))
            wall = time.perf_counter() - t0
            sky_t = res.timings["sky"]
            if model not in best or wall < best[model][0]:
                best[model] = (wall, sky_t, float(np.nansum(res.poa_global[:, 0])) / 1000.0)
    lit = int(np.sum(states.sun_elevation > 0))
    print(f"{len(states)} steps ({lit} lit), {scene.n_faces} faces, {sky.n_channels} channels")
    for model, (wall, sky_t, H) in best.items():
        print(f"  {model:6s}: total {wall:6.2f} s, sky {sky_t:6.2f} s, roof irradiation {H:.1f} kWh m-2")
    (w0, s0, _), (w1, s1, _) = best["clear"], best["allsky"]
    print(f"all-sky / plain: total {w1 / w0:.2f}x, sky phase {s1 / s0:.2f}x")


if __name__ == "__main__":
    main()
