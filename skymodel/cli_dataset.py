"""``widesky dataset ...``: write synthetic datasets and subsets of datasets."""

from __future__ import annotations

import numpy as np


def register(sub):
    ds = sub.add_parser("dataset", help="dataset tools")
    dsub = ds.add_subparsers(dest="dataset_command", metavar="SUBCOMMAND")
    dsub.required = True
    s = dsub.add_parser("synthetic", help="write a synthetic dataset (for tests and benchmarks; not a physical sky)")
    s.add_argument("output")
    s.add_argument("--visibilities", default="20,60,131.8", help="comma-separated [km]")
    s.add_argument("--albedos", default="0,0.5,1", help="comma-separated [1]")
    s.add_argument("--altitudes", default="0", help="comma-separated [m]")
    s.add_argument("--elevations", type=int, default=12, help="number of solar elevations (-4.2..90 deg)")
    s.add_argument("--channels", type=int, default=55)
    s.add_argument("--rank", type=int, default=4)
    s.add_argument("--knots", default="24,24,16", help="sun,zenith,emphasis knot counts")
    s.add_argument("--polarisation", action="store_true")
    s.add_argument("--seed", type=int, default=0)
    s.set_defaults(func=_synthetic)


def _floats(text):
    return tuple(float(x) for x in text.split(",") if x.strip())


def _synthetic(args):
    from .dataset import load_dataset
    from .synthetic import write_synthetic_dataset

    ns, nz, ne = (int(x) for x in args.knots.split(","))
    n = max(int(args.elevations), 3)
    elev = np.concatenate([[-4.2, 0.0], np.geomspace(1.0, 90.0, n - 2)])
    path = write_synthetic_dataset(args.output, visibilities=_floats(args.visibilities),
                                   albedos=_floats(args.albedos), altitudes=_floats(args.altitudes),
                                   elevations=tuple(elev), n_channels=args.channels, rank=args.rank, n_sun=ns,
                                   n_zen=nz, n_emph=ne, polarisation=args.polarisation, seed=args.seed)
    print(load_dataset(path).describe())
    return 0
