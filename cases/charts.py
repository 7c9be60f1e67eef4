"""Small inline SVG charts for the offline HTML reports (no plotting library needed)."""

from __future__ import annotations

from html import escape

import numpy as np

__all__ = ["line_chart", "bar_chart", "PALETTE"]

PALETTE = ("#1f5fa8", "#d9541e", "#2a9d4a", "#8e44ad", "#b8860b", "#17becf", "#e377c2", "#7f7f7f")
_W, _H, _L, _R, _T, _B = 720, 300, 64, 170, 14, 44


def _ticks(lo, hi, n=5):
    if hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / n
    mag = 10 ** np.floor(np.log10(raw))
    step = min((m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw), default=10 * mag)
    start = np.ceil(lo / step) * step
    return [float(v) for v in np.arange(start, hi + 0.5 * step, step)]


def _frame(title, xlabel, ylabel, y0, y1, xticks):
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {_W} {_H}" class="chart" role="img">',
             f"<title>{escape(title)}</title>",
             f'<rect x="{_L}" y="{_T}" width="{_W - _L - _R}" height="{_H - _T - _B}" fill="#fff" stroke="#999"/>']
    ys = lambda v: _H - _B - (v - y0) / (y1 - y0) * (_H - _T - _B)  # noqa: E731
    for v in _ticks(y0, y1):
        if y0 <= v <= y1:
            parts.append(f'<line x1="{_L}" x2="{_W - _R}" y1="{ys(v):.1f}" y2="{ys(v):.1f}" stroke="#eee"/>'
                         f'<text x="{_L - 6}" y="{ys(v) + 4:.1f}" text-anchor="end">{v:g}</text>')
    for x, text in xticks:
        parts.append(f'<text x="{x:.1f}" y="{_H - _B + 16}" text-anchor="middle">{escape(text)}</text>')
    parts.append(f'<text x="{(_L + _W - _R) / 2}" y="{_H - 6}" text-anchor="middle">{escape(xlabel)}</text>')
    parts.append(f'<text transform="translate(14 {(_T + _H - _B) / 2}) rotate(-90)" text-anchor="middle">'
                 f"{escape(ylabel)}</text>")
    return parts, ys


def _legend(parts, names):
    for i, name in enumerate(names):
        y = _T + 14 + 16 * i
        parts.append(f'<rect x="{_W - _R + 10}" y="{y - 9}" width="12" height="10" fill="{PALETTE[i % len(PALETTE)]}"/>'
                     f'<text x="{_W - _R + 28}" y="{y}">{escape(name)}</text>')


def line_chart(x, series, *, title, xlabel, ylabel, xticks=None):
    """SVG text of a line chart: ``x`` (N,) numbers, ``series`` name -> (N,) values (NaN breaks a line),
    ``xticks`` optional list of (x value, label)."""
    x = np.asarray(x, float)
    ally = np.concatenate([np.asarray(v, float) for v in series.values()]) if series else np.zeros(1)
    ally = ally[np.isfinite(ally)]
    y0, y1 = (min(0.0, float(ally.min())), float(ally.max())) if ally.size else (0.0, 1.0)
    y1 = y1 if y1 > y0 else y0 + 1.0
    x0, x1 = float(x.min()), float(x.max()) if x.size > 1 else float(x.min()) + 1.0
    xs = lambda v: _L + (v - x0) / (x1 - x0 if x1 > x0 else 1.0) * (_W - _L - _R)  # noqa: E731
    ticks = [(xs(v), lab) for v, lab in (xticks or [(v, f"{v:g}") for v in _ticks(x0, x1)])]
    parts, ys = _frame(title, xlabel, ylabel, y0, y1, ticks)
    for i, (name, vals) in enumerate(series.items()):
        pts, segs = [], []
        for xv, yv in zip(x, np.asarray(vals, float)):
            if np.isfinite(yv):
                pts.append(f"{xs(xv):.1f},{ys(yv):.1f}")
            elif pts:
                segs.append(pts)
                pts = []
        if pts:
            segs.append(pts)
        for s in segs:
            parts.append(f'<polyline fill="none" stroke="{PALETTE[i % len(PALETTE)]}" stroke-width="1.6" '
                         f'points="{" ".join(s)}"/>')
    _legend(parts, list(series))
    parts.append("</svg>")
    return "\n".join(parts)


def bar_chart(categories, series, *, title, xlabel, ylabel):
    """SVG text of a grouped bar chart: ``categories`` (K,) labels, ``series`` name -> (K,) values (>= 0)."""
    K, S = len(categories), max(len(series), 1)
    ally = np.concatenate([np.asarray(v, float) for v in series.values()]) if series else np.zeros(1)
    y1 = float(np.nanmax(ally)) if ally.size and np.nanmax(ally) > 0 else 1.0
    slot = (_W - _L - _R) / max(K, 1)
    ticks = [(_L + (k + 0.5) * slot, str(c)) for k, c in enumerate(categories)]
    parts, ys = _frame(title, xlabel, ylabel, 0.0, y1 * 1.05, ticks)
    bw = 0.8 * slot / S
    for i, (name, vals) in enumerate(series.items()):
        for k, v in enumerate(np.asarray(vals, float)):
            if not np.isfinite(v):
                continue
            x = _L + k * slot + 0.1 * slot + i * bw
            parts.append(f'<rect x="{x:.1f}" y="{ys(v):.1f}" width="{bw:.1f}" height="{ys(0) - ys(v):.1f}" '
                         f'fill="{PALETTE[i % len(PALETTE)]}"><title>{escape(name)}: {v:.4g}</title></rect>')
    _legend(parts, list(series))
    parts.append("</svg>")
    return "\n".join(parts)
