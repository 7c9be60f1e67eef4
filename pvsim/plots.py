"""Figures of the cell-technology library (matplotlib, imported on use; written atomically)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_write

from .module import reference_currents
from .spectra import am15g, channel_edges
from .technologies import TECHNOLOGIES, TandemTechnology, get_technology

__all__ = ["save_figure", "plot_technologies"]


def save_figure(fig, path, dpi=130):
    """Write a matplotlib figure to ``path`` atomically (:func:`widesky.core.atomic.atomic_write`), and
    close it. A ``path`` without a suffix is written as PNG."""
    import matplotlib.pyplot as plt
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_write(p) as tmp:
            fig.savefig(tmp, dpi=dpi, format=None if p.suffix else "png")
    finally:
        plt.close(fig)
    return p


def plot_technologies(path, technologies=None, reference_path=None, data_dir=None):
    """EQE of each technology over the AM1.5G spectrum (the layout of Fig. 2 of Vevoda et al. 2022).

    Parameters
    ----------
    path : str or Path
        Output PNG.
    technologies : list of str, optional
        Preset names (default all).
    reference_path : str or Path, optional
        ASTM G173 file (default the copy shipped in the package).

    Returns
    -------
    pathlib.Path
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(technologies or TECHNOLOGIES)
    w_ref, g_ref = am15g(reference_path, data_dir)
    w = np.arange(280.0, 2481.0, 2.0)
    fig, ax = plt.subplots(figsize=(11, 5.6))
    ax2 = ax.twinx()
    k = (w_ref >= 280) & (w_ref <= 2480)
    ax2.fill_between(w_ref[k], g_ref[k], color="0.85", lw=0, zorder=0)
    ax2.set_ylabel("AM1.5G (ASTM G173-03) [W m-2 nm-1]")
    ax2.set_ylim(0, 2.0)
    ax.set_zorder(ax2.get_zorder() + 1)
    ax.patch.set_visible(False)
    cmap = plt.get_cmap("tab20")
    edges = channel_edges()
    for i, name in enumerate(names):
        t = get_technology(name)
        jref = reference_currents(t, edges, reference_path=reference_path)
        col = cmap(i % 20)
        for j, (sub, qe) in enumerate(t.subcell_qe(w).items()):
            tag = sub.split(":")[-1] if isinstance(t, TandemTechnology) else ""
            lab = f"{t.label}{' ' + tag if tag else ''} ({jref[sub] / 10:.1f} mA cm-2)"
            ax.plot(w, qe, color=col, lw=1.6, ls="--" if j else "-", label=lab)
    ax.set_xlim(280, 2480)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("external quantum efficiency [1]")
    for e in edges[::5]:
        ax.axvline(e, color="0.9", lw=0.5, zorder=-1)
    ax.set_title("pvsim cell technologies (cell EQE; Jsc under AM1.5G on the 55 PSM channels)")
    ax.legend(fontsize=7.5, ncol=1, loc="upper right", frameon=False)
    fig.tight_layout()
    return save_figure(fig, path)
