"""``widesky sky ...``: render the sky model and describe datasets."""

from __future__ import annotations

import sys
import time
import warnings


def register(sub):
    sky = sub.add_parser("sky", help="render the sky model, describe a dataset",
                         description="The Prague Sky Model on its own: render a fisheye image of sky radiance, sun "
                                     "radiance, polarisation or transmittance for one sky state (render), or "
                                     "describe a dataset's grids, channels and sizes (info).")
    ssub = sky.add_subparsers(dest="sky_command", metavar="SUBCOMMAND")
    ssub.required = True

    r = ssub.add_parser("render", help="fisheye render of sky radiance, sun radiance, polarisation or "
                                       "transmittance (PNG and spectral OpenEXR)")
    r.add_argument("--dataset", default=None, help="dataset file (default: the embedded default dataset)")
    r.add_argument("--elevation", type=float, default=30.0, help="solar elevation [deg] (default 30)")
    r.add_argument("--azimuth", type=float, default=180.0,
                   help="solar azimuth [deg], clockwise from north (default 180, south)")
    r.add_argument("--visibility", type=float, default=50.0, help="ground-level visibility [km] (default 50)")
    r.add_argument("--albedo", type=float, default=0.3, help="ground albedo [1] (default 0.3)")
    r.add_argument("--altitude", type=float, default=0.0, help="observer altitude [m] (default 0)")
    r.add_argument("--quantity", choices=["sky", "sun", "polarisation", "transmittance"], default="sky",
                   help="what to render (default sky radiance)")
    r.add_argument("--channel", default="rgb",
                   help="'rgb' (sRGB composite of the visible channels; the EXR keeps every channel), a "
                        "channel index, or a wavelength such as 550nm")
    r.add_argument("--view", choices=["up", "side"], default="up", help="up-facing or side-facing fisheye")
    r.add_argument("--view-azimuth", type=float, default=180.0,
                   help="azimuth the side view looks towards [deg] (default 180)")
    r.add_argument("--resolution", type=int, default=512, help="image size [pixels] (default 512)")
    r.add_argument("--exposure", type=float, default=0.0, help="exposure adjustment [EV] for the PNG")
    r.add_argument("--output", "-o", default="sky.png",
                   help="output file, .png or .exr (default sky.png; a .png also gets a spectral .exr beside it "
                        "unless --no-exr)")
    r.add_argument("--no-exr", action="store_true", help="with a .png output, do not write the .exr")
    r.add_argument("--exr-type", choices=("auto", "half", "float"), default="auto",
                   help="EXR pixels: 'half' (16-bit, relative error <= 4.9e-4), 'float' (32-bit), 'auto' (default: "
                        "half where every value fits its range)")
    r.add_argument("--exr-compression", choices=("rle", "none", "zips", "zip", "piz", "zstd"), default="rle",
                   help="EXR compression, all lossless (default rle: fast; zip: about 2.5x smaller, several times "
                        "slower; none: fastest, largest)")
    r.add_argument("--below-horizon", choices=("auto", "model", "dark"), default="auto",
                   help="sky below the horizon: 'dark' for ground-level datasets by default (no data there)")
    r.set_defaults(func=_render)

    i = ssub.add_parser("info", help="describe a dataset: grids, channels, sections, sizes")
    i.add_argument("dataset", nargs="?", default=None, help="dataset file (default: the embedded default)")
    i.add_argument("--load", action="store_true", help="decode the coefficients and report the resident size")
    i.set_defaults(func=_info)


def _parse_channel(model, text):
    """(channels, wavelengths) for ``--channel``, checked against the model's channels."""
    from widesky.skymodel.evaluate import channel_indices

    text = str(text).strip().lower()
    if text == "rgb":
        return None, None
    try:
        channels, wavelengths = (None, [float(text[:-2])]) if text.endswith("nm") else ([int(text)], None)
        channel_indices(model, channels, wavelengths)
    except ValueError as exc:
        lo, hi = model.wavelength_range
        raise ValueError(f"--channel {text!r}: expected 'rgb', a channel index in [0, {model.n_channels - 1}] or a "
                         f"wavelength in [{lo:g}, {hi:g}) nm like 550nm ({exc})") from None
    return channels, wavelengths


# Physically meaningful ranges of the render options. A value inside its range but outside the dataset's
# grid is clamped to the dataset's range with a warning (as the reference does); outside it is an error. The sun
# elevation is the exception: outside the dataset's elevations it is an error (a clamped sun is drawn elsewhere).
RENDER_RANGES = {
    "elevation": (-90.0, 90.0, "deg"), "azimuth": (-360.0, 360.0, "deg"), "view_azimuth": (-360.0, 360.0, "deg"),
    "visibility": (1e-3, 1e4, "km"), "albedo": (0.0, 1.0, ""), "altitude": (0.0, 1e5, "m"),
    "exposure": (-100.0, 100.0, "EV"),
}
MAX_RESOLUTION = 20000


def check_range(option, value, lo, hi, unit=""):
    """Raise ValueError naming ``option`` unless ``lo <= value <= hi`` (NaN fails)."""
    if not (lo <= value <= hi):
        raise ValueError(f"{option} {value!r}{' ' + unit if unit else ''} outside the valid range [{lo:g}, {hi:g}]"
                         + (f" {unit}" if unit else ""))
    return value


def _check_render_args(args):
    for name, (lo, hi, unit) in RENDER_RANGES.items():
        check_range("--" + name.replace("_", "-"), getattr(args, name), lo, hi, unit)
    check_range("--resolution", args.resolution, 1, MAX_RESOLUTION, "pixels")


def _render(args):
    from widesky import skymodel
    from widesky.core.atomic import atomic_outputs, check_output_path
    from widesky.skymodel.render import check_render_memory, render_sky, write_exr, write_png

    _check_render_args(args)
    out = check_output_path(args.output, "--output", (".png", ".exr"))
    targets = [out]
    if out.suffix.lower() == ".png" and not args.no_exr:
        targets.append(check_output_path(out.with_suffix(".exr"), "--output (its .exr)"))
    model = skymodel.load_dataset(_dataset_file(args.dataset, "--dataset"))
    lo, hi = model.elevation_range
    if not lo <= args.elevation <= hi:
        # a clamped sun elevation would render another sun position than the one asked for: refuse it (the other
        # sky-state values are clamped with a warning: they change the haze, not the geometry)
        raise ValueError(f"--elevation {args.elevation:g} deg: outside the dataset's range [{lo:g}, {hi:g}] deg "
                         f"({model.path.name}); the sky model has no data for a sun below {lo:g} deg")
    if model.is_synthetic:
        print(f"NOTE: {model.path.name} is a SYNTHETIC dataset (structure of the Prague Sky Model, not a physical "
              "sky); point --dataset at a real one for physical values.", file=sys.stderr)
    channels, wavelengths = _parse_channel(model, args.channel)
    n_ch = model.n_channels if channels is None and wavelengths is None else 1
    check_render_memory(args.resolution, n_ch, exr=len(targets) > 1 or out.suffix.lower() == ".exr",
                        option="--resolution", exr_compression=args.exr_compression)
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", skymodel.SkyStateClampedWarning)
        r = render_sky(model, sun_elevation=args.elevation, sun_azimuth=args.azimuth, visibility=args.visibility,
                       albedo=args.albedo, altitude=args.altitude, quantity=args.quantity, channels=channels,
                       wavelengths=wavelengths, view=args.view, view_azimuth=args.view_azimuth,
                       resolution=args.resolution, below_horizon=args.below_horizon)
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    dt = time.perf_counter() - t0
    with atomic_outputs(*targets) as temps:  # all or nothing: a failed EXR leaves no PNG behind
        for tmp, dest in zip(temps, targets):
            if dest.suffix.lower() == ".exr":
                write_exr(tmp, r, pixel_type=args.exr_type, compression=args.exr_compression)
            else:
                write_png(tmp, r, composite=channels is None and wavelengths is None and r.values.shape[-1] > 1
                          and args.quantity in ("sky", "sun"), exposure=args.exposure)
    written = targets
    n_px = int(r.mask.sum())
    print(f"{args.quantity} {args.view}-facing {args.resolution}x{args.resolution}, {r.values.shape[-1]} channel(s) "
          f"{r.wavelengths[0]:g}-{r.wavelengths[-1]:g} nm, sun elevation {args.elevation:g} deg azimuth "
          f"{args.azimuth:g} deg, visibility {args.visibility:g} km, albedo {args.albedo:g}: {n_px} directions "
          f"in {dt:.3f} s")
    for p in written:
        print(f"wrote {p}")
    return 0


def _dataset_file(path, option):
    """``path`` unchanged, or a ValueError naming ``option`` and what a dataset is, where no file is there."""
    from pathlib import Path

    if path is not None and not Path(path).expanduser().exists():
        raise ValueError(f"{option} {str(path)!r}: no such file; expected a Prague Sky Model dataset (.dat): leave it "
                         "out for the embedded one, or name your copy of an official dataset (not shipped: "
                         "docs/skymodel.md) or one of widesky's (skymodel/data/polarised.dat in a checkout)")
    return path


def _info(args):
    from widesky import skymodel

    model = skymodel.load_dataset(_dataset_file(args.dataset, "dataset"))
    if args.load:
        t0 = time.perf_counter()
        model.load()
        print(f"(decoded in {time.perf_counter() - t0:.2f} s)")
    print(model.describe())
    return 0
