"""Regenerate the tables of docs/thermal.md section "The spectral treatment: effective g and its effect on loads".

Runs (the CLI, ``python -m widesky``, in this process's environment, default options except those named): for
each TMY3 year below, ``thermal study --weather FILE --solar-control --output DIR --jobs N`` -- the office box
of ``widesky.thermal.study.office_box`` with each of the four units of ``standard_units(solar_control=True)``
(clear, low-e, low-e #2, solar-control), the default sky under a weather file (``widesky.SKY_DEFAULTS``: the
all-sky model). One integrator run per climate gives both routes, **spectral** (g by angle and wavelength) and
**rated** (the unit's AM1.5-weighted g by angle on broadband light); ``--solar-control`` only adds the fourth
unit, so the three other units' figures are those of the plain command.

* Denver (``data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw``, shipped with widesky);
* San Francisco and Chicago (``weather/USA_CA_San.Francisco.Intl.AP.724940_TMY3.epw``,
  ``weather/USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw``: reference data, see ``widesky.core.paths``);
  without the reference data folder they are skipped with that reason, the tables are printed and
  docs/generated is not rewritten (the docs include both files whole: only complete ones are written).

Reads ``annual.csv`` (window gain, cooling, heating [kWh], peak cooling [W] per unit and route) and
``effective_g.csv`` (effective g per unit, orientation and month [1]) of each run and writes, each stamped with
the commit and ``SKY_DEFAULTS`` (the stamp helper of benchmarks/docs_pvsim_figures.py; docs/thermal.md includes
them and tests/test_docs_figures.py checks the stamp against the current defaults):

* docs/generated/thermal_glazing.md -- clear, low-e, low-e #2: monthly spectral effect per facade and annual
  gains and loads per climate;
* docs/generated/thermal_glazing_solar_control.md -- the solar-control unit, the same figures and cooling peaks;
* docs/figures/thermal_effective_g.png -- effective g per month of the south and north facades, both routes
  (:func:`widesky.thermal.figures.fig_study` on the same runs).

Run: ``nice python benchmarks/docs_glazing_study.py [--jobs 2]`` (about 1-2 min per climate on a quiet
2-core machine).

``--trace`` instead decomposes the clear unit's annual spectral-vs-rated difference (Denver, the same office box
and integrator run) by the part of the light (beam, sky, ground reflected) and by cause: the rating band (AM1.5G
over 280-4000 nm against 280-2480 nm), the spectrum at normal incidence (the unit's spectral g at 0 deg times the
rated angular shape) and the coupling of angle and wavelength; under the default sky, with a grey ground and with
the clear-sky spectra (the sky before the all-sky default). About 15 s per sky.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
import docs_pvsim_figures as pvfig  # noqa: E402  (the stamp, CLI-runner and writer of the pvsim figures)

ROOT = pvfig.ROOT
GENERATED = ROOT / "docs" / "generated"
SCRIPT = "benchmarks/docs_glazing_study.py"
CLIMATES = {"Denver": "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw",
            "San Francisco": "weather/USA_CA_San.Francisco.Intl.AP.724940_TMY3.epw",
            "Chicago": "weather/USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw"}
BASIC = ("clear", "low-e", "low-e #2")
SOLAR = ("solar-control",)
ORIENT = ("north", "east", "south", "west")


def _diff(s, r, digits):
    return f"{100 * (s / r - 1):+.{digits}f} %"


def annual_table(annual: dict, units, peak=False) -> str:
    """Markdown table: one row per climate and unit; window gain, cooling, heating [MWh] spectral / rated."""
    head = ("| climate | unit | window gain spectral / rated [MWh] | diff | cooling spectral / rated [MWh] | diff "
            "| heating spectral / rated [MWh] | diff |" + (" cooling peak spectral / rated [kW] |" if peak else "")
            + "\n|---|---|---|---|---|---|---|---|" + ("---|" if peak else "") + "\n")
    rows = []
    for climate, df in annual.items():
        for u in units:
            s, r = df.loc[(u, "spectral")], df.loc[(u, "rated")]
            cells = [climate, u]
            for col in ("window_gain_kWh", "cooling_kWh", "heating_kWh"):
                cells += [f"{s[col] / 1000:.2f} / {r[col] / 1000:.2f}", _diff(s[col], r[col], 2)]
            if peak:
                cells.append(f"{s['peak_cooling_W'] / 1000:.1f} / {r['peak_cooling_W'] / 1000:.1f}")
            rows.append("| " + " | ".join(cells) + " |")
    return head + "\n".join(rows) + "\n"


def monthly_table(eff: dict, units) -> str:
    """Markdown table: per unit and facade, the range over the months of spectral / rated route - 1 [%], one
    range per climate (in the order of the climates, separated by ' / ')."""
    head = "| unit | " + " | ".join(ORIENT) + " |\n|---|" + "---|" * len(ORIENT) + "\n"
    rows = []
    for u in units:
        cells = []
        for o in ORIENT:
            rng = []
            for df in eff.values():
                d = df.loc[(u, o)]
                x = 100 * (d["spectral"] / d["rated_route"] - 1)
                rng.append(f"{x.min():+.1f}..{x.max():+.1f}")
            cells.append(" / ".join(rng) + " %")
        rows.append(f"| {u} | " + " | ".join(cells) + " |")
    return head + "\n".join(rows) + "\n"


def body(annual, eff, units, peak) -> str:
    climates = " / ".join(annual)
    return (f"Spectral effect per month and facade, spectral / rated route - 1 (range over the months; "
            f"{climates}):\n\n{monthly_table(eff, units)}\n"
            f"Annual window gains and loads of the building, both routes (diff: spectral / rated - 1):\n\n"
            f"{annual_table(annual, units, peak)}")


def write_md(path: Path, text: str, log) -> None:
    """pvsim's writer with this script's name in the header and stamp."""
    prefix = pvfig.STAMP_PREFIX
    pvfig.STAMP_PREFIX = f"Generated by `{SCRIPT}`"
    try:
        pvfig.write_md(path, text, log)
    finally:
        pvfig.STAMP_PREFIX = prefix
    path.write_text(path.read_text().replace("rerun benchmarks/docs_pvsim_figures.py", f"rerun {SCRIPT}")
                    .replace("(scene files written by the script; ", "("), encoding="utf-8")


def trace(jobs=1) -> str:
    """Markdown table: the clear unit's annual spectral / rated - 1 in Denver, by part and cause, for three skies."""
    import warnings
    from dataclasses import replace

    import numpy as np

    from widesky.irradiance import Response, Simulation, SpectralAngularTable, read_weather
    from widesky.irradiance.simulation import SKY_DEFAULTS, weather_path
    from widesky.thermal.gains import building_scene, glazing_response, group_weights, rated_glazing_response
    from widesky.thermal.glazing import ANGLES, WAVELENGTHS, read_solar_spectrum
    from widesky.thermal.loads import glazing_g_table
    from widesky.thermal.study import office_box, standard_units

    u = standard_units()["clear"]
    sw, se = read_solar_spectrum()
    band = sw <= 2480.0
    _, g_full, *_ = glazing_g_table(u, sw, se)
    g0 = np.clip(u.optics(ANGLES, WAVELENGTHS)["shgc"][0], 0.0, None)
    resp = [glazing_response(u, "spectral"), rated_glazing_response(u, sw, se, "rated"),
            rated_glazing_response(u, sw[band], se[band], "rated_band"),
            Response("normal", WAVELENGTHS, np.ones_like(WAVELENGTHS), unit="weight",
                     angular=SpectralAngularTable(ANGLES, WAVELENGTHS, g0[None, :] * (g_full / g_full[0])[:, None])),
            Response("light", np.array([280.0, 2500.0]), np.ones(2), unit="weight")]
    b = office_box()
    scene, labels = building_scene(b)
    wins = [s for s in b.surfaces if s.kind == "window"]
    w = read_weather(weather_path(CLIMATES["Denver"]))
    skies = {"default (all-sky, vegetation ground)": SKY_DEFAULTS,
             "all-sky, grey ground": replace(SKY_DEFAULTS, ground_spectrum="grey"),
             "clear-sky spectra (before the all-sky default)": replace(SKY_DEFAULTS, spectral_model="clear")}
    lines = ["| sky | part | share of the light | spectral / rated - 1 | rating band | spectrum at 0 deg | angle x "
             "wavelength | contribution to the total |", "|---|---|---|---|---|---|---|---|"]
    for label, opts in skies.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = Simulation(scene, weather=w, sky=opts, n_jobs=jobs).run(resp)
        m = group_weights(res, [s.label for s in wins]) * np.array([s.area for s in wins])
        v = {p: {r.name: float((res.get(r.name, p) @ m).sum()) for r in resp}
             for p in ("direct", "sky_diffuse", "ground_diffuse", "global")}
        for p, x in v.items():
            pct = lambda a, c: f"{100 * (a / c - 1):+.2f} %"    # noqa: E731
            lines.append(f"| {label} | {p.replace('_', ' ')} | {100 * x['light'] / v['global']['light']:.1f} % | "
                         f"{pct(x['spectral'], x['rated'])} | {pct(x['rated_band'], x['rated'])} | "
                         f"{pct(x['normal'], x['rated_band'])} | {pct(x['spectral'], x['normal'])} | "
                         f"{100 * (x['spectral'] - x['rated']) / v['global']['rated']:+.2f} % |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--trace", action="store_true", help="decompose the clear unit's difference instead (Denver)")
    a = ap.parse_args(argv)
    if a.trace:
        print(trace(a.jobs))
        return 0
    from widesky.core.paths import data_file, has_data
    weather = {}
    for climate, f in CLIMATES.items():
        if f.startswith("data:"):
            weather[climate] = f
        elif has_data():
            weather[climate] = data_file(f)
        else:
            print(f"skipping {climate}: no reference data folder ({f} is reference data, see widesky.core.paths)")
    tmp = Path(tempfile.mkdtemp(prefix="docs_glazing_"))
    pvfig._TMP[0] = tmp
    try:
        annual, eff, log = {}, {}, []
        for climate, w in weather.items():
            out = tmp / climate.lower().replace(" ", "_")
            pvfig._cli(["thermal", "study", "--weather", w, "--solar-control", "--output", out,
                        "--jobs", a.jobs], log)
            annual[climate] = pd.read_csv(out / "annual.csv", index_col=[0, 1]).sort_index()
            eff[climate] = pd.read_csv(out / "effective_g.csv", index_col=[0, 1, 2]).sort_index()
        basic, solar = body(annual, eff, BASIC, False), body(annual, eff, SOLAR, True)
        if len(annual) == len(CLIMATES):
            from widesky.thermal.figures import fig_study
            write_md(GENERATED / "thermal_glazing.md", basic, log)
            write_md(GENERATED / "thermal_glazing_solar_control.md", solar, log)
            fig_study(ROOT / "docs" / "figures", [tmp / c.lower().replace(" ", "_") for c in annual],
                      names=list(annual))
        else:
            print(basic, solar, "partial run: docs/generated not rewritten", sep="\n")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
