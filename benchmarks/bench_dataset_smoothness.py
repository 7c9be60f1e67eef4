"""Smoothness check of a dataset (skymodel.generator.smoothness) and a contact sheet of its renders.

Prints the check's summary (every grid state and the states between grid points, all channels with measurable
energy) with its wall time, and draws a contact sheet: up-facing fisheye renders for solar elevations 0-90 deg
(columns) x the sRGB composite and single channels (rows), at 30 km and albedo 0.3 (between grid points of the
default dataset). With ``--before OLD.dat`` the sheet shows OLD's row block above DATASET's.

With ``--issue-renders PATH`` it draws the three renders issue 11 names (the sRGB sky at 8 deg sun, 30 km; the
side view toward azimuth 200 deg at 540 nm, 8 deg sun, 50 km; the 1260 nm sky at 45 deg sun, 40 km; albedo 0.3, as
``widesky sky render`` gives them), before above after when ``--before`` is given.

The check allows, per profile, the turning points the solver's own sky has there (the sidecar's
``smoothness_reference`` rows, written by the build; ``--no-reference`` for the limits alone); both counts are
printed. Between grid points the pairs that the build solved at their own state (``smoothness_between_reference``)
are judged against that solve, and the count by the bracketing grid states alone is printed beside it.
``--hysteresis-ladder`` reruns the failing states with a hysteresis of 0.75-3 % (how large the spurious reversals
are).

Run:  python benchmarks/bench_dataset_smoothness.py skymodel/data/default.dat --json /tmp/smooth.json \
          --sheet docs/figures/dataset_contact_sheet.png [--before old.dat] [--issue-renders PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

ELEVATIONS = (0.0, 2.0, 5.0, 8.0, 13.5, 25.0, 45.0, 70.0, 90.0)
ROWS = ("sRGB", 540.0, 1260.0, 2220.0)


ISSUE_RENDERS = (  # (title, render_sky keywords) of the renders issue 11 names
    ("sRGB, sun 8 deg, 30 km", {"sun_elevation": 8.0, "visibility": 30.0}),
    ("side view to 200 deg, 540 nm, sun 8 deg, 50 km",
     {"sun_elevation": 8.0, "visibility": 50.0, "view": "side", "view_azimuth": 200.0, "wavelengths": [540.0]}),
    ("1260 nm, sun 45 deg, 40 km", {"sun_elevation": 45.0, "visibility": 40.0, "wavelengths": [1260.0]}),
)


def issue_renders(models, labels, path, resolution=300):
    """The renders of :data:`ISSUE_RENDERS` for each of ``models`` (rows labelled ``labels``) to ``path`` [PNG]."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from widesky.skymodel.colour import srgb_encode
    from widesky.skymodel.render import render_sky

    fig, axes = plt.subplots(len(models), len(ISSUE_RENDERS), figsize=(3.2 * len(ISSUE_RENDERS), 3.3 * len(models)),
                             squeeze=False)
    for i, (model, label) in enumerate(zip(models, labels)):
        for j, (title, kw) in enumerate(ISSUE_RENDERS):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = render_sky(model, albedo=0.3, resolution=resolution, threads=1, **kw)
            if "wavelengths" in kw:
                lum = r.values[..., 0].astype(float)
                rgb = np.repeat(lum[..., None], 3, axis=-1)
            else:
                lum, rgb = r.luminance_like(), r.rgb_linear()
            v = lum[r.mask]
            ref = np.percentile(v[v > 0], 99.0) if np.any(v > 0) else 1.0
            img = np.clip(srgb_encode(rgb / ref), 0, 1)
            img[~r.mask] = 0.0
            ax = axes[i, j]
            ax.imshow(img)
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(title, fontsize=8)
            if j == 0:
                ax.set_ylabel(label, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _image(model, elevation, row, visibility, albedo, resolution):
    from widesky.skymodel.colour import srgb_encode
    from widesky.skymodel.render import render_sky

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # clamping at the grid's edge (sun at 0 deg) is what a user sees too
        if row == "sRGB":
            r = render_sky(model, sun_elevation=elevation, visibility=visibility, albedo=albedo,
                           resolution=resolution, threads=1)
            lum = r.luminance_like()
            rgb = r.rgb_linear()
        else:
            r = render_sky(model, sun_elevation=elevation, visibility=visibility, albedo=albedo,
                           wavelengths=[row], resolution=resolution, threads=1)
            lum = r.values[..., 0].astype(float)
            rgb = np.repeat(lum[..., None], 3, axis=-1)
    v = lum[r.mask]
    ref = np.percentile(v[v > 0], 99.0) if np.any(v > 0) else 1.0
    out = srgb_encode(rgb / ref)
    out[~r.mask] = 0.0
    return np.clip(out, 0, 1)


def contact_sheet(models, labels, path, visibility=30.0, albedo=0.3, resolution=150):
    """Draw the sheet of ``models`` (list of SkyModel) with row-block ``labels`` to ``path`` [PNG]."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nr = len(ROWS) * len(models)
    fig, axes = plt.subplots(nr, len(ELEVATIONS), figsize=(1.45 * len(ELEVATIONS), 1.5 * nr + 0.4))
    for b, (model, label) in enumerate(zip(models, labels)):
        for i, row in enumerate(ROWS):
            for j, e in enumerate(ELEVATIONS):
                ax = axes[b * len(ROWS) + i, j]
                ax.imshow(_image(model, e, row, visibility, albedo, resolution))
                ax.set_xticks([])
                ax.set_yticks([])
                if b * len(ROWS) + i == 0:
                    ax.set_title(f"sun {e:g} deg", fontsize=8)
                if j == 0:
                    name = row if row == "sRGB" else f"{row:.0f} nm"
                    ax.set_ylabel(f"{label}\n{name}", fontsize=7)
    fig.suptitle(f"up-facing renders, visibility {visibility:g} km, albedo {albedo:g} (north up, sun in the south)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    from widesky.skymodel import load_dataset
    from widesky.skymodel.generator.smoothness import check_dataset, reference_from_entries, summarise

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--json", default=None, help="write the summary here")
    ap.add_argument("--sheet", default=None, help="contact sheet PNG")
    ap.add_argument("--before", default=None, help="a second dataset drawn above (the sheet's 'before')")
    ap.add_argument("--no-check", action="store_true", help="only draw the sheet")
    ap.add_argument("--reference", default=None,
                    help="sidecar JSON whose 'smoothness_reference' rows (the solver's own turning points at the grid "
                         "states) the check allows; default: DATASET.json when it has them")
    ap.add_argument("--no-reference", action="store_true", help="the limits alone (no solver reference)")
    ap.add_argument("--hysteresis-ladder", action="store_true",
                    help="also count how many failing pairs still fail with a hysteresis of 0.75-3 %% (their size)")
    ap.add_argument("--issue-renders", default=None, help="PNG of the three renders issue 11 names")
    ap.add_argument("--visibility", type=float, default=30.0, help="visibility of the sheet [km]")
    ap.add_argument("--albedo", type=float, default=0.3, help="ground albedo of the sheet [1]")
    a = ap.parse_args(argv)
    try:
        model = load_dataset(a.dataset)
    except (OSError, ValueError) as exc:   # DatasetError is a ValueError
        sys.exit(str(exc))
    if not a.no_check:
        ref = None
        side = a.reference or a.dataset + ".json"
        if a.reference and a.no_reference:
            sys.exit("--reference and --no-reference exclude each other: give one of them")
        if a.reference and not os.path.exists(a.reference):
            sys.exit(f"--reference {a.reference}: no such file")
        if not a.no_reference and os.path.exists(side):
            try:
                meta = json.load(open(side))
            except (OSError, ValueError) as exc:
                sys.exit(f"{side}: not a readable sidecar JSON ({exc})")
            rows = meta.get("smoothness_reference", {}).get("rows")
            if rows is None and a.reference:
                sys.exit(f"--reference {a.reference}: holds no 'smoothness_reference' rows")
            between = meta.get("smoothness_between_reference")
            if rows is not None:
                ref = reference_from_entries(rows, (model.visibilities, model.elevations, model.albedos), between)
                print(f"solver reference: {len(rows)} profiles from {side}" + (
                    f"; {len(between['examined'])} between-grid pairs solved at their own state" if between else ""))
        if ref is None:
            print("no solver reference: the limits alone")
        t0 = time.perf_counter()
        summary = summarise(check_dataset(model, reference=ref), model.wavelengths)
        summary["seconds"] = round(time.perf_counter() - t0, 1)
        for g in ("grid", "between"):
            s = summary.get(g)
            if s:
                print(f"{g}: {s['states']} states, {s['checked_pairs']} checked (state, channel) pairs, "
                      f"{s['failing_pairs']} failing ({s['failing_states']} states; by the limits alone "
                      f"{s['failing_pairs_by_limits']}); by the limits: almucantar >1 turning point "
                      f"{s['almucantar_tp_gt1']}, vertical >2 {s['vertical_tp_gt2']}, aureole ray >1 "
                      f"{s['aureole_tp_gt1']}, zenith spot {s['zenith_spot_pairs']} (max "
                      f"{100 * s['max_zenith_spot']:.1f} %)")
                if "failing_pairs_by_bracketing_states" in s:
                    print(f"  {g}: by the bracketing grid states' allowance alone "
                          f"{s['failing_pairs_by_bracketing_states']} failing")
        print(f"check: {summary['seconds']} s")
        if a.hysteresis_ladder:
            from widesky.skymodel.generator.smoothness import between_grid_states, check_states, grid_states
            # how far back the failing profiles turn: the same check with a larger hysteresis, failing states only
            for g, states in (("grid", grid_states(model)), ("between", between_grid_states(model))):
                rows0 = check_states(model, states, reference=ref)
                fail = [(st, r["fails"]) for st, r in zip(states, rows0) if r["fails"].any()]
                counts = []
                for tol in (0.0075, 0.01, 0.015, 0.02, 0.03):
                    rr = check_states(model, [st for st, _ in fail], rel_tol=tol, reference=ref) if fail else []
                    counts.append(f"{100 * tol:g} %: {sum(int((r['fails'] & f).sum()) for r, (_, f) in zip(rr, fail))}")
                print(f"  {g}: failing pairs that still fail with the hysteresis at " + ", ".join(counts))
        if a.json:
            with open(a.json, "w") as f:
                json.dump(summary, f, indent=1)
    if a.sheet:
        models, labels = [model], ["after" if a.before else ""]
        if a.before:
            models, labels = [load_dataset(a.before), model], ["before", "after"]
        contact_sheet(models, labels, a.sheet, a.visibility, a.albedo)
        print("wrote", a.sheet)
    if a.issue_renders:
        models, labels = [model], ["after" if a.before else ""]
        if a.before:
            models, labels = [load_dataset(a.before), model], ["before (first file)", "after (rebuilt)"]
        issue_renders(models, labels, a.issue_renders)
        print("wrote", a.issue_renders)


if __name__ == "__main__":
    main()
