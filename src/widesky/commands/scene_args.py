"""Mesh inputs of the simulating commands (``poa``, ``pv``), read and checked before any computation: each mesh
file named in messages, the analysis points bounded, the ground below the analysed faces."""

from __future__ import annotations

import math
import sys

import numpy as np

#: Largest ``--samples-per-face`` (a 100 x 100 subdivision of every triangle).
MAX_SAMPLES_PER_FACE = 10_000
#: Largest number of analysis points (faces x samples per face) a command starts. Measured on this project's
#: integrator at the default settings: about 600 rays and 15 KB of memory per point (20,000 points: 11.9 M rays,
#: 5.5 s of ray casting on one core, 0.3 GB), so the bound is about 0.6 G rays, 15 GB and 5 core-minutes of rays.
MAX_POINTS = 1_000_000
RAYS_PER_POINT = 600
BYTES_PER_POINT = 15e3


def load_meshes(paths, option):
    """The trimesh meshes of ``paths`` (:func:`widesky.irradiance.scene.load_mesh`: a missing, empty or
    unreadable file is one line naming it); ``option`` names the argument in messages."""
    from widesky.irradiance.scene import load_mesh
    out = []
    for p in paths:
        try:
            out.append(load_mesh(str(p)))
        except ValueError as exc:
            raise ValueError(f"{option}: {exc}") from None
    return out


def check_samples(samples_per_face, n_faces, two_sided=False):
    """Refuse a ``--samples-per-face`` that is not a square number, or whose analysis points exceed the bounds,
    with an estimate of the work and how to lower it."""
    k = int(round(math.sqrt(max(samples_per_face, 0))))
    if samples_per_face < 1 or k * k != samples_per_face:
        raise ValueError(f"--samples-per-face {samples_per_face}: must be a square number (1, 4, 9, 16 ...)")
    n = n_faces * samples_per_face * (2 if two_sided else 1)
    if samples_per_face > MAX_SAMPLES_PER_FACE or n > MAX_POINTS:
        rays = n * RAYS_PER_POINT
        raise ValueError(
            f"--samples-per-face {samples_per_face}: {n_faces:,} face(s){' x 2 sides' if two_sided else ''} x "
            f"{samples_per_face:,} = {n:,} analysis points, about {rays:.2g} rays and {n * BYTES_PER_POINT / 1e9:,.0f} "
            f"GB of memory; the bounds are {MAX_SAMPLES_PER_FACE:,} per face and {MAX_POINTS:,} points in all: "
            "lower --samples-per-face (1, 4, 9 ...) or give a coarser mesh")


def check_ground(scene, ground_z):
    """Refuse a ``--ground-z`` above every analysis point (every face would be under the ground and read 0); warn
    when it is above some of them."""
    if ground_z is None:
        return
    z = scene.points[:, 2] + scene.origin[2]
    tol = 1e-6 * max(1.0, float(np.abs(z).max(initial=0.0)))    # a face on the ground (the default) is above it
    if z.size and ground_z > z.max() + tol:
        raise ValueError(f"--ground-z {ground_z:g}: above every analysed face (their points lie at {z.min():.2f} to "
                         f"{z.max():.2f} m), so every face would be under the ground; valid: at most {z.max():.2f} m "
                         "(default: the scene's lowest vertex)")
    below = int(np.count_nonzero(z < ground_z - tol))
    if below:
        print(f"widesky: warning: --ground-z {ground_z:g}: {below} of {z.size} analysis points lie below the ground "
              "and read 0", file=sys.stderr)


def add_reflectance_argument(p):
    """``--reflectance GROUP=VALUE`` (repeatable) and ``--reflections N`` on a simulating command's parser."""
    p.add_argument("--reflections", type=int, default=3, metavar="N",
                   help="reflections followed per light path, 1-20 (default 3; 1 is a single bounce; "
                        "docs/irradiance-integrator.md, 'Multiple reflections')")
    p.add_argument("--reflectance", action="append", default=[], metavar="GROUP=VALUE",
                   help="diffuse (broadband) reflectance [1] of an analysis mesh's faces, GROUP its group name as the output gives it "
                        "(repeatable; default 0.1); CONTEXT=VALUE sets every --context mesh's (default 0.2)")


def reflectances(items, groups, default=0.1, context_default=0.2):
    """(per analysis mesh, context) diffuse reflectances [1] from ``--reflectance GROUP=VALUE`` items."""
    refl, ctx = {g: default for g in groups}, context_default
    for item in items:
        name, sep, value = item.rpartition("=")
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not sep or not name:
            raise ValueError(f"--reflectance {item!r}: expected GROUP=VALUE (GROUP: {', '.join(groups)} or CONTEXT)")
        if not (math.isfinite(v) and 0.0 <= v <= 1.0):
            raise ValueError(f"--reflectance {item!r}: the value must be a broadband reflectance in [0, 1] "
                             "(a spectral reflectance file is not supported for scene surfaces)")
        if name == "CONTEXT":
            ctx = v
        elif name in refl:
            refl[name] = v
        else:
            raise ValueError(f"--reflectance {item!r}: no analysis mesh {name!r}; valid groups: "
                             f"{', '.join(groups)}, CONTEXT")
    return [refl[g] for g in groups], ctx


def integrator_settings(args):
    """The integrator's settings of ``--tolerance`` and ``--reflections`` (checked: one line naming the option)."""
    from dataclasses import replace

    from widesky.irradiance.integrator import IntegratorSettings
    if not 1 <= args.reflections <= 20:
        raise ValueError(f"--reflections {args.reflections}: must be an integer in [1, 20]")
    return replace(IntegratorSettings.for_tolerance(args.tolerance), reflections=args.reflections)
