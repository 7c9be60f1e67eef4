"""Low sun: the plane-parallel DISORT sky against the same atmosphere in spherical shells (the build's split states).

For grid states of a build configuration whose low sun comes from split Monte Carlo states
(``mc_single_scatter_exact``; skymodel/data/default-dataset.json), prints per solar elevation and
visibility the ratio plane-parallel / spherical of the sky-diffuse horizontal irradiance (ground albedo 0) in a few channels and
summed over 300-2460 nm, and of the radiance at view zenith 87 deg toward the sun and away from it (580 nm). The
plane-parallel side is the DISORT state the build solved for that elevation (the 0 deg states hold the sky solved at
``min_solve_elevation_deg``; solved here once if not cached, about 20 s per state); the spherical side is the split
state (exact single scattering plus the Monte Carlo rest) from the build cache, which the build must have solved.

With ``--slabs`` it also shows that the difference is the geometry's, not the solver's: at 51.3 km and 580 nm the
Monte Carlo solver run in plane-parallel slabs (scalar, 4096 paths) against DISORT at the same (solved) elevation,
beside the spherical-shell radiance, at view zenith 60 and 87 deg toward the sun and away from it (about 10 s per
elevation), and the same at 10.5 and 13.5 deg, where DISORT gives the sky (there the spherical side is a
Monte Carlo run on these directions).

Run:  python benchmarks/bench_low_sun_spherical.py skymodel/data/default-dataset.json \
          [--visibilities 20 51.3 131.8] [--slabs]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

CHANNELS_NM = (380.0, 460.0, 580.0, 900.0, 1620.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", help="build configuration (JSON) with mc_single_scatter_exact")
    ap.add_argument("--visibilities", type=float, nargs="+", default=[20.0, 51.3, 131.8], help="[km]")
    ap.add_argument("--slabs", action="store_true", help="also the Monte Carlo in plane-parallel slabs vs DISORT")
    a = ap.parse_args(argv)
    if not Path(a.config).is_file():
        ap.error(f"config {a.config!r}: no such file")
    from widesky.skymodel.generator.cache import load_state, state_file
    from widesky.skymodel.generator.dataset_build import (_solve_job, direction_samples, load_config, state_radiance)
    from widesky.skymodel.generator.dataset_mc import mc_file, split_state

    cfg = load_config(a.config)
    low = [float(e) for e in cfg.elevations_deg if split_state(cfg, e)]
    if not low:
        sys.exit(f"{a.config}: no split Monte Carlo elevations (set mc_below_elevation_deg and "
                 "mc_single_scatter_exact)")
    have = [(v, e) for v in a.visibilities for e in low if mc_file(cfg, v, e).exists()]
    if not have:
        sys.exit(f"no split state of {a.config} in the build cache: run `widesky dataset build {a.config} -o ...` "
                 "first")
    ch = [int(round((x - 300.0) / 40.0)) for x in CHANNELS_NM]
    print("ratio plane-parallel / spherical of the sky-diffuse horizontal irradiance (albedo 0), and of the radiance "
          "at view zenith 87 deg, 580 nm, toward the sun (az 0) and away (az 180)")
    print(f"{'vis km':>7} {'sun deg':>7} " + " ".join(f"{x:>7.0f}" for x in CHANNELS_NM)
          + f" {'300-2460':>9} {'L87 az0':>8} {'L87 az180':>9}")
    for v, e in have:
        path = state_file(cfg, v, e)
        if not path.exists():
            _solve_job(("fit", cfg, v, e, None))
        pp = load_state(path)
        zs, azs, sph, solved = state_radiance(cfg, v, e, 0.0)
        w = direction_samples(zs, azs, solved)
        cos_z = np.cos(np.radians(zs))[:, None, None]
        wgt = w["weights"].reshape(len(zs), len(azs))[..., None]
        dhi_sph = np.sum(wgt * cos_z * sph, axis=(0, 1))
        dhi_pp = np.asarray(pp["dhi"], float)
        i87 = int(np.argmin(np.abs(zs - 87.0)))
        j87 = int(np.argmin(np.abs(np.asarray(pp["zenith"]) - 87.0)))
        l_sph, l_pp = sph[i87, [0, -1], ch[2]], np.asarray(pp["radiance"])[j87, [0, -1], ch[2]]
        print(f"{v:7.1f} {e:7.1f} " + " ".join(f"{dhi_pp[c] / dhi_sph[c]:7.3f}" for c in ch)
              + f" {dhi_pp[:55].sum() / dhi_sph.sum():9.3f} {l_pp[0] / l_sph[0]:8.3f} {l_pp[1] / l_sph[1]:9.3f}")

    if a.slabs:
        slabs(cfg, [e for v, e in have if v == 51.3])


def slabs(cfg, elevations):
    """Monte Carlo in plane-parallel slabs against DISORT, and the spherical shells, at 51.3 km and 580 nm."""
    from widesky.skymodel.generator.dataset_build import state_radiance
    from widesky.skymodel.generator.montecarlo import MonteCarloConfig, solve_sky_mc
    from widesky.skymodel.generator.solver import SkyState, solve_sky

    vz, az = np.array([60.0, 60.0, 87.0, 87.0]), np.array([0.0, 180.0, 0.0, 180.0])
    print("\n51.3 km, 580 nm, albedo 0.5, radiance [mW m-2 sr-1 nm-1] at (view zenith, azimuth) "
          + " ".join(f"({z:.0f},{x:.0f})" for z, x in zip(vz, az)))
    for e in list(elevations) + [10.5, 13.5]:
        solved = max(e, cfg.min_solve_elevation_deg)
        st = SkyState(solved, visibility_km=51.3, ground_albedo=0.5)
        d = solve_sky(st, cfg.spec(), vz, az, channels=[7], config=cfg.solver_config(), processes=1)
        m = solve_sky_mc(st, cfg.spec(), vz, az, [7], MonteCarloConfig(samples=4096, polarised=False,
                                                                          planet_radius_km=None, channels_per_batch=1))
        if e in elevations:
            zs, azs, sph, _ = state_radiance(cfg, 51.3, e, 0.5)
            i = [int(np.argmin(np.abs(zs - z))) for z in vz]
            j = [int(np.argmin(np.abs(azs - x))) for x in az]
            sph = sph[i, j, 7]
        else:  # above the split elevations: the spherical Monte Carlo on these directions alone
            sph = solve_sky_mc(st, cfg.spec(), vz, az, [7], MonteCarloConfig(samples=4096, polarised=False,
                                                                                channels_per_batch=1)).stokes[:, 0, 0]
        row = lambda x: " ".join(f"{1e3 * y:8.3f}" for y in x)  # noqa: E731
        print(f"sun {e:4.1f} deg (plane-parallel at {solved} deg)\n  DISORT            {row(d.radiance[:, 0])}\n"
              f"  MC slabs          {row(m.stokes[:, 0, 0])}   (+- {row(m.stderr[:, 0, 0])})\n"
              f"  spherical shells  {row(sph)}")


if __name__ == "__main__":
    main()
