"""Technology comparison under the same sky and geometry: tables (pandas), plots (PNG), a text
summary, and the tandem top-cell band-gap sweep.

Spectral factor (per step or summed over a period) = front effective irradiance / broadband (whole
spectrum) irradiance after the cover (the series' ``poa_global_cover`` [W m-2]): 1 under AM1.5G; > 1 a
spectral gain. Annual and monthly factors are energy-weighted (ratios of sums).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pandas as pd

from widesky.core.atomic import atomic_outputs, atomic_write
from widesky.irradiance.location import infer_step
from widesky.irradiance.skystate import interval_months

from .plots import save_figure
from .stream import simulate
from .system import WATERFALL_STAGES, YieldResult
from .technologies import perovskite_silicon_tandem

__all__ = ["summary_table", "monthly_spectral_factor", "visibility_spectral_factor", "hourly_spectral_factors",
           "waterfall_table", "period_text", "summary_text", "plot_comparison", "write_comparison", "bandgap_sweep"]

_MIN_POA = 50.0   # W m-2: hourly distributions only count steps above this


def _group(y: YieldResult, group):
    if group is None:
        return y.groups[0]
    if group not in y.groups:
        raise ValueError(f"group={group!r} not one of {y.groups}")
    return group


def _sf(s):
    den = s["poa_global_cover"].sum()
    return float(s["effective_irradiance_front"].sum() / den) if den > 0 else float("nan")


def summary_table(y: YieldResult, group=None):
    """One row per technology: rating and yield of ``group`` (default the first).

    Columns: ``label``, ``eta_stc`` [1], ``pdc0`` [W], ``dc_kwh``, ``ac_kwh`` [kWh],
    ``specific_yield`` [kWh/kWp] (AC), ``relative_yield`` [1] (to the technology with the highest
    specific yield), ``performance_ratio`` [1] (AC yield / unshaded POA reference yield),
    ``spectral_factor`` [1], ``angle_loss``, ``spectral_gain``, ``bifacial_gain``, ``low_irradiance_loss``,
    ``temperature_loss``, ``current_mismatch_loss`` [1].
    """
    g = _group(y, group)
    rows = {}
    for name, ty in y.technologies.items():
        s = ty.series[g]
        w = ty.waterfall[g]
        lo = ty.losses(g)
        rows[name] = {
            "label": ty.technology.label, "eta_stc": ty.eta_stc, "pdc0": ty.pdc0[g],
            "dc_kwh": ty.energy(g, "dc"), "ac_kwh": ty.energy(g, "ac"),
            "specific_yield": ty.specific_yield(g), "performance_ratio": w["ac"] / w["unshaded"]
            if w["unshaded"] > 0 else np.nan,
            "spectral_factor": _sf(s), "shading_loss": lo["poa"], "angle_loss": lo["cover"],
            "spectral_gain": -lo["effective"], "bifacial_gain": -lo["bifacial"],
            "low_irradiance_loss": lo["low_irradiance"], "temperature_loss": lo["temperature"],
            "current_mismatch_loss": ty.current_mismatch_loss[g]}
    df = pd.DataFrame.from_dict(rows, orient="index")
    df.index.name = "technology"
    best = df["specific_yield"].max()
    df.insert(6, "relative_yield", df["specific_yield"] / best if best > 0 else np.nan)
    return df


def waterfall_table(y: YieldResult, group=None):
    """Reference yields [kWh/kWp] per waterfall stage (rows) and technology (columns)."""
    g = _group(y, group)
    df = pd.DataFrame({n: [ty.waterfall[g][s] for s in WATERFALL_STAGES] for n, ty in y.technologies.items()},
                      index=list(WATERFALL_STAGES))
    df.index.name = "stage"
    return df


def _step(times):
    """The steps' interval [time] (1 h for a single step: one hour's month needs none with a "left" label)."""
    return infer_step(times) if len(times) > 1 else pd.Timedelta(hours=1)


def monthly_spectral_factor(y: YieldResult, group=None, label="left"):
    """Energy-weighted spectral factor [1] per calendar month (rows) and technology (columns); ``label``: what the
    steps' times label ("left" their interval's start, "right" its end as in an EPW or TMY3 file, "center"): a
    step's month is its interval's start's (the EPW hour ending 1 Feb 00:00 is January's)."""
    g = _group(y, group)
    out = {}
    for name, ty in y.technologies.items():
        s = ty.series[g]
        m = interval_months(s.index, label, _step(s.index))
        num = s["effective_irradiance_front"].groupby(m).sum()
        den = s["poa_global_cover"].groupby(m).sum()
        out[name] = num / den.where(den > 0)
    df = pd.DataFrame(out)
    df.index.name = "month"
    return df


def hourly_spectral_factors(y: YieldResult, group=None, min_poa=_MIN_POA):
    """dict technology -> (N,) per-step spectral factors [1] of steps with POA global > ``min_poa``
    [W m-2] (the distribution the mismatch plot shows)."""
    g = _group(y, group)
    out = {}
    for name, ty in y.technologies.items():
        s = ty.series[g]
        keep = (s["poa_global"] > min_poa) & np.isfinite(s["spectral_factor"])
        out[name] = s["spectral_factor"][keep].to_numpy()
    return out


def visibility_spectral_factor(y: YieldResult, group=None, bins=(20, 30, 40, 60, 80, 132)):
    """Energy-weighted spectral factor [1] per visibility bin [km] (rows) and technology (columns)."""
    g = _group(y, group)
    vis = pd.Series(y.visibility, index=y.times)
    labels = [f"{a:g}-{b:g}" for a, b in zip(bins[:-1], bins[1:])]
    cut = pd.cut(vis, bins=list(bins), labels=labels, include_lowest=True)
    out = {}
    for name, ty in y.technologies.items():
        s = ty.series[g]
        num = s["effective_irradiance_front"].groupby(cut.to_numpy(), observed=False).sum()
        den = s["poa_global_cover"].groupby(cut.to_numpy(), observed=False).sum()
        out[name] = num / den.where(den > 0)
    df = pd.DataFrame(out)
    df.index = [str(i) for i in df.index]
    df.index.name = "visibility_km"
    return df


def period_text(times):
    """The steps of a run as text: their number and the first and last timestamps (interval labels) as given;
    a series not in time order (a typical year, TMY or IWEC, whose months come from different years) says so
    and names its years, since its last label can come before its first."""
    n = 0 if times is None else len(times)
    if n == 0:
        return f"{n} steps"
    times = pd.DatetimeIndex(times)
    if times.is_monotonic_increasing:
        return f"{n} steps {times[0]} .. {times[-1]}"
    if times.year.min() == times.year.max():      # one year, out of order: its earliest and latest
        return f"{n} steps not in time order, {times.min()} .. {times.max()}"
    return (f"{n} steps of a typical year (records of {times.year.min()}..{times.year.max()}, not in time order; "
            f"in file order {times[0]} .. {times[-1]})")


def summary_text(y: YieldResult, group=None, note="", label="left"):
    """A short plain-text summary of the comparison (``label`` as :func:`monthly_spectral_factor`)."""
    g = _group(y, group)
    t = summary_table(y, g)
    mon = monthly_spectral_factor(y, g, label)
    lines = [f"widesky pv compare: group {g!r}, {period_text(y.times)}"
             + (f" ({note})" if note else "")]
    best = t["specific_yield"].idxmax()
    lines.append(f"highest specific yield: {t.loc[best, 'label']} {t.loc[best, 'specific_yield']:.0f} kWh/kWp")
    for name, r in t.sort_values("specific_yield", ascending=False).iterrows():
        lines.append(f"  {r['label']:28s} {r['specific_yield']:7.0f} kWh/kWp  PR {r['performance_ratio']:.3f}  "
                     f"spectral {100 * (r['spectral_factor'] - 1):+5.1f} %  temperature {-100 * r['temperature_loss']:+.1f} %"
                     + (f"  2T current mismatch -{100 * r['current_mismatch_loss']:.1f} %"
                        if r["current_mismatch_loss"] > 0 else ""))
    summer, winter = mon.loc[mon.index.isin([6, 7, 8])].mean(), mon.loc[mon.index.isin([12, 1, 2])].mean()
    if np.isfinite(summer).any() and np.isfinite(winter).any():
        d = (summer - winter).sort_values()
        lines.append(f"seasonal swing of the spectral factor (Jun-Aug minus Dec-Feb): most negative "
                     f"{d.index[0]} {d.iloc[0]:+.3f}, most positive {d.index[-1]} {d.iloc[-1]:+.3f}")
    return "\n".join(lines) + "\n"


def plot_comparison(y: YieldResult, path, group=None, title=None, label="left"):
    """A 2 x 2 PNG: specific yield and spectral gain per technology; monthly spectral factor (``label`` as
    :func:`monthly_spectral_factor`); the distribution of hourly spectral factors; spectral factor per visibility
    bin."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    g = _group(y, group)
    t = summary_table(y, g)
    mon = monthly_spectral_factor(y, g, label)
    hours = hourly_spectral_factors(y, g)
    vis = visibility_spectral_factor(y, g)
    names = list(t.index)
    cmap = plt.get_cmap("tab20")
    col = {n: cmap(i % 20) for i, n in enumerate(names)}
    fig, axs = plt.subplots(2, 2, figsize=(13, 9))
    ax = axs[0, 0]
    x = np.arange(len(names))
    ax.bar(x, t["specific_yield"], color=[col[n] for n in names])
    for i, n in enumerate(names):
        ax.text(i, t.loc[n, "specific_yield"], f"{100 * (t.loc[n, 'spectral_factor'] - 1):+.1f}%",
                ha="center", va="bottom", fontsize=7)
    ax.set_xticks(x, [t.loc[n, "label"] for n in names], rotation=40, ha="right", fontsize=8)
    lo, hi = float(t["specific_yield"].min()), float(t["specific_yield"].max())
    if hi > 0:
        ax.set_ylim(max(0.0, lo - 0.6 * (hi - lo) - 0.02 * hi), hi + 0.25 * (hi - lo) + 0.01 * hi)
    ax.set_ylabel("specific yield (AC) [kWh/kWp]")
    ax.set_title("yield per rated power (labels: annual spectral gain)", fontsize=10)
    ax = axs[0, 1]
    for n in names:
        ax.plot(mon.index, mon[n], "o-", ms=3, color=col[n], label=t.loc[n, "label"])
    ax.axhline(1.0, color="0.5", lw=0.8)
    ax.set_xlabel("month")
    ax.set_ylabel("spectral factor [1]")
    ax.set_title("monthly spectral factor (energy-weighted)", fontsize=10)
    ax.legend(fontsize=6.5, ncol=2, loc="best")
    ax = axs[1, 0]
    ax.boxplot([hours[n] for n in names], showfliers=False)
    ax.set_xticks(np.arange(1, len(names) + 1), [t.loc[n, "label"] for n in names], rotation=40, ha="right",
                  fontsize=8)
    ax.axhline(1.0, color="0.5", lw=0.8)
    ax.set_ylabel("hourly spectral factor [1]")
    ax.set_title(f"distribution of hourly spectral factors (POA > {_MIN_POA:.0f} W m-2)", fontsize=10)
    ax = axs[1, 1]
    vis = vis.dropna(how="all")
    xv = np.arange(len(vis.index))
    for n in names:
        ax.plot(xv, vis[n], "o-", ms=3, color=col[n])
    ax.set_xticks(xv, vis.index, fontsize=8)
    ax.axhline(1.0, color="0.5", lw=0.8)
    ax.set_xlabel("visibility bin [km]")
    ax.set_ylabel("spectral factor [1]")
    ax.set_title("sensitivity to visibility (energy-weighted per bin)", fontsize=10)
    fig.suptitle(title or f"widesky pv compare: group {g}", fontsize=11)
    fig.tight_layout()
    return save_figure(fig, path)


def _write_text(path, text):
    """Write ``text`` to ``path`` atomically (:func:`widesky.core.atomic.atomic_write`)."""
    with atomic_write(path) as tmp:
        tmp.write_text(text)


def write_comparison(y: YieldResult, outdir, group=None, note="", label="left"):
    """Write ``summary.csv``, ``waterfall.csv``, ``monthly_spectral_factor.csv`` (``label`` as
    :func:`monthly_spectral_factor`),
    ``visibility_spectral_factor.csv``, ``summary.txt`` and ``compare.png`` into ``outdir``
    (all six or none: renamed into place together once all are written, so an interrupt leaves neither a partial
    set nor a folder it created). Returns the list of paths."""
    out = Path(outdir)
    created = [d for d in (out, *out.parents) if not d.exists()]    # the folders this call makes, deepest first
    g = _group(y, group)
    tables = (("summary.csv", summary_table(y, g)), ("waterfall.csv", waterfall_table(y, g)),
              ("monthly_spectral_factor.csv", monthly_spectral_factor(y, g, label)),
              ("visibility_spectral_factor.csv", visibility_spectral_factor(y, g)))
    paths = [out / name for name, _ in tables] + [out / "summary.txt", out / "compare.png"]
    try:
        out.mkdir(parents=True, exist_ok=True)
        with atomic_outputs(*paths) as temps:
            for tmp, (_, df) in zip(temps, tables):
                tmp.write_text(df.to_csv(float_format="%.6g"))
            temps[4].write_text(summary_text(y, g, note, label))
            plot_comparison(y, temps[5], g, label=label)
    except BaseException:
        for d in created:               # only empty ones: the folders this call made, nothing of the user's
            with contextlib.suppress(OSError):
                d.rmdir()
        raise
    return paths


def bandgap_sweep(scene, sky, states, gaps_ev=None, terminals=2, group=None, cover=None, settings=None,
                  weather=None, times=None, temp_air=25.0, wind_speed=1.0, run=None):
    """Annual yield of a perovskite/Si tandem against the top-cell band gap, one integrator run
    (``weather`` and ``run`` as :func:`widesky.pvsim.stream.simulate`).

    Parameters
    ----------
    gaps_ev : array_like, optional
        Top-cell band gaps [eV] in 1.5-1.8 (default 1.50, 1.52 ... 1.80).
    terminals : {2, 4}
    group : str, optional
        Module group (default the first).

    Returns
    -------
    pandas.DataFrame
        Index ``top_bandgap_ev``; columns ``eta_stc`` [1], ``dc_kwh_per_m2`` [kWh m-2] (DC energy per
        module area, the quantity whose maximum is the best gap for the site), ``specific_yield``
        [kWh/kWp], ``current_mismatch_loss`` [1].
    """
    gaps = np.round(np.arange(1.5, 1.8001, 0.02), 3) if gaps_ev is None else np.asarray(gaps_ev, float)
    base = perovskite_silicon_tandem(terminals)
    techs = [base.with_top_bandgap(g).replace(name=f"{base.name}_{g:.3f}", label=f"{g:.2f} eV") for g in gaps]
    _, y = simulate(scene, sky, states, techs, temp_air, wind_speed, cover=cover, settings=settings,
                    weather=weather, times=times, run=run, keep_currents=False)
    g = _group(y, group)
    rows = []
    for gap, t in zip(gaps, techs):
        ty = y.technologies[t.name]
        area = ty.pdc0[g] / (ty.eta_stc * 1000.0)
        rows.append({"top_bandgap_ev": gap, "eta_stc": ty.eta_stc,
                     "dc_kwh_per_m2": ty.energy(g, "dc") / area, "specific_yield": ty.specific_yield(g, "dc"),
                     "current_mismatch_loss": ty.current_mismatch_loss[g]})
    return pd.DataFrame(rows).set_index("top_bandgap_ev")
