"""The report's charts: drawn with matplotlib, embedded in the HTML page as SVG data URIs (the page opens offline
and holds everything it shows), and their data kept for ``charts.json``.

Every chart is registered in a :class:`ChartBook` with the numbers it plots and the result file and columns those
numbers come from, so that a test (tests/test_cases.py, ``check_charts``) can recompute each chart from the result
files and catch a chart that does not show its data.
"""

from __future__ import annotations

import base64
import io
import json
from html import escape
from pathlib import Path

import numpy as np

__all__ = ["ChartBook", "group_colours"]

_RC = {"font.size": 9.0, "axes.titlesize": 10.5, "axes.labelsize": 9.5, "legend.fontsize": 8.5,
       "svg.fonttype": "none", "svg.hashsalt": "widesky-report", "axes.spines.top": False,
       "axes.spines.right": False, "axes.grid": True, "grid.color": "#e4e4e4", "grid.linewidth": 0.7,
       "axes.axisbelow": True}


def group_colours(names):
    """A colour per name (matplotlib colour specs), distinct for up to 20 names: tab10 for up to 10, tab20 for up
    to 20 (front/back pairs of one group, ``"x front"`` and ``"x back"``, get tab20's dark and light shade of one
    hue), then evenly spaced colours of the ``turbo`` map."""
    import matplotlib

    names = list(names)
    n = len(names)
    bases = [nm.rsplit(" ", 1)[0] for nm in names]
    sides = [nm.rsplit(" ", 1)[-1] if " " in nm else "" for nm in names]
    paired = n > 1 and all(s in ("front", "back") for s in sides) and len(set(bases)) <= 10
    if paired:
        tab20 = matplotlib.colormaps["tab20"].colors
        order = list(dict.fromkeys(bases))
        return {nm: tab20[2 * order.index(b) + (s == "back")] for nm, b, s in zip(names, bases, sides)}
    if n <= 10:
        cols = matplotlib.colormaps["tab10"].colors
    elif n <= 20:
        cols = matplotlib.colormaps["tab20"].colors
    else:
        cols = [matplotlib.colormaps["turbo"](v) for v in np.linspace(0.05, 0.95, n)]
    return {nm: cols[i] for i, nm in enumerate(names)}


def _jsonable(v):
    a = np.asarray(v)
    if a.dtype.kind == "M":
        return [str(t) for t in a.astype("datetime64[s]")]
    if a.dtype.kind in "fc":
        return [None if not np.isfinite(x) else float(x) for x in a.astype(float)]
    return a.tolist()


class ChartBook:
    """The charts of one report: :meth:`line` and :meth:`bars` draw a chart and return its HTML (an ``<img>`` with
    an SVG data URI inside a ``<figure>``); :meth:`write` saves every chart's data as JSON.

    Each chart records ``id`` (unique in the report), ``kind``, ``title``, axis labels with units, ``x`` or
    ``categories``, ``series`` (name -> values, in the axis unit) and ``source``: the result file the values come
    from and how (``file``, ``columns`` ...).
    """

    def __init__(self):
        self.charts = []

    # -- drawing --------------------------------------------------------------------------------------------
    def _figure(self, height=3.3):
        import matplotlib as mpl
        from matplotlib.figure import Figure

        with mpl.rc_context(_RC):
            fig = Figure(figsize=(8.6, height), dpi=100)
            ax = fig.add_subplot()
        return fig, ax

    def _finish(self, fig, ax, rec, legend=True, ncols=1):
        import matplotlib as mpl

        with mpl.rc_context(_RC):
            ax.set_title(rec["title"], loc="left")
            ax.set_xlabel(rec["xlabel"])
            ax.set_ylabel(rec["ylabel"])
            if legend and len(rec["series"]) > 0:
                ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, ncols=ncols,
                          title=rec.get("legend_title"))
            buf = io.StringIO()
            fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
        data = base64.b64encode(buf.getvalue().encode("utf-8")).decode()
        self.charts.append(rec)
        return (f'<figure class="chart" id="chart-{escape(rec["id"])}"><img src="data:image/svg+xml;base64,{data}" '
                f'alt="{escape(rec["title"])}"></figure>')

    def _record(self, chart_id, kind, title, xlabel, ylabel, series, source, meta):
        if any(c["id"] == chart_id for c in self.charts):
            raise ValueError(f"chart id {chart_id!r} used twice")
        return {"id": chart_id, "kind": kind, "title": title, "xlabel": xlabel, "ylabel": ylabel,
                "series": {k: _jsonable(v) for k, v in series.items()}, "source": dict(source),
                **({"meta": meta} if meta else {})}

    def line(self, chart_id, x, series, *, title, xlabel, ylabel, source, meta=None, legend_title=None,
             dates=False, ylim0=True):
        """A line chart of ``series`` (name -> (N,) values; NaN breaks a line) over ``x`` (N,) numbers, or dates
        (``dates=True``: numpy datetime64, naive local time; month ticks over long periods)."""
        import matplotlib as mpl
        import matplotlib.dates as mdates

        x = np.asarray(x)
        rec = self._record(chart_id, "line", title, xlabel, ylabel, series, source, meta)
        rec["x"] = _jsonable(x)
        if legend_title:
            rec["legend_title"] = legend_title
        colours = group_colours(series)
        with mpl.rc_context(_RC):
            fig, ax = self._figure()
            for name, v in series.items():
                ax.plot(x, np.asarray(v, float), color=colours[name], lw=1.3, label=name)
            if dates and len(x) > 1:
                span = (x.max() - x.min()) / np.timedelta64(1, "D")
                if span > 62:
                    ax.xaxis.set_major_locator(mdates.MonthLocator())
                    ax.xaxis.set_major_formatter(mdates.DateFormatter("%b"))
                    ax.xaxis.set_minor_locator(mdates.MonthLocator(bymonthday=15))
                else:
                    loc = mdates.AutoDateLocator(minticks=4, maxticks=10)
                    ax.xaxis.set_major_locator(loc)
                    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(loc))
                ax.set_xlim(x.min(), x.max())
            elif len(x) > 1:
                ax.set_xlim(float(np.min(x)), float(np.max(x)))
            if ylim0:
                ax.set_ylim(bottom=min(0.0, ax.get_ylim()[0]))
            return self._finish(fig, ax, rec, ncols=2 if len(series) > 12 else 1)

    def bars(self, chart_id, categories, series, *, title, xlabel, ylabel, source, meta=None, legend_title=None):
        """A grouped bar chart: ``categories`` (K,) labels, ``series`` name -> (K,) values."""
        import matplotlib as mpl

        rec = self._record(chart_id, "bars", title, xlabel, ylabel, series, source, meta)
        rec["categories"] = [str(c) for c in categories]
        if legend_title:
            rec["legend_title"] = legend_title
        colours = group_colours(series)
        K, S = len(categories), max(len(series), 1)
        with mpl.rc_context(_RC):
            fig, ax = self._figure()
            width = 0.84 / S
            xs = np.arange(K)
            for i, (name, v) in enumerate(series.items()):
                ax.bar(xs - 0.42 + (i + 0.5) * width, np.asarray(v, float), width=width, color=colours[name],
                       label=name, linewidth=0)
            ax.set_xticks(xs, [str(c) for c in categories])
            ax.grid(False, axis="x")
            ax.set_xlim(-0.6, K - 0.4)
            return self._finish(fig, ax, rec, ncols=2 if len(series) > 12 else 1)

    # -- output ---------------------------------------------------------------------------------------------
    def write(self, path):
        """Write ``charts.json``: {"charts": [...]} with every chart's data and source."""
        Path(path).write_text(json.dumps({"charts": self.charts}, indent=1), encoding="utf-8")
        return path
