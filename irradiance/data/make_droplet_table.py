"""Regenerate ``droplet_mie_r10_v0.1.csv``: Mie optics of water-cloud droplets (docs/all-sky.md, section 1).

``widesky.irradiance.cloud_optics.mie_droplet_table`` for the default droplets (effective radius 10 um, effective
variance 0.1) from the OPAC water-cloud refractive index in the data directory; about 3 minutes on one core:

    python irradiance/data/make_droplet_table.py [--data-dir DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from widesky.core.atomic import atomic_write
from widesky.irradiance.cloud_optics import DEFAULT_DROPLET_RADIUS, DROPLET_VARIANCE, mie_droplet_table

OUT = Path(__file__).with_name("droplet_mie_r10_v0.1.csv")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", default=None, help="data directory (default WIDESKY_DATA_DIR or ../shared/data)")
    args = ap.parse_args(argv)
    t = mie_droplet_table(DEFAULT_DROPLET_RADIUS, DROPLET_VARIANCE, args.data_dir)
    with atomic_write(OUT) as tmp, open(tmp, "w") as fh:
        fh.write("# Mie optics of water droplets, gamma distribution r_eff 10 um, v_eff 0.1, 320 radii 0.5-40 um; "
                 "computed by irradiance/data/make_droplet_table.py from the OPAC water-cloud refractive index\n")
        fh.write("wavelength_nm,extinction_efficiency,coalbedo,asymmetry\n")
        for row in t:
            fh.write(f"{row[0]:.0f},{row[1]:.6f},{row[2]:.6e},{row[3]:.6f}\n")
    print(f"written: {OUT}")


if __name__ == "__main__":
    main()
