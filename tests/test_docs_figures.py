"""The figures docs/pvsim.md quotes for the defaults are generated, current and reproducible.

docs/generated/pvsim_*.md are written by benchmarks/docs_pvsim_figures.py (a scene built there, the default sky
under the Amsterdam IWEC weather file, the Prague clear-sky year) and docs/pvsim.md includes them. Checked here:

* the page includes the generated files and holds no hand-copied rows of their tables;
* the prose quotes the generated numbers (a-Si spectral factor, 2T current mismatch, the sweep's optimum);
* each file's stamp names the current ``widesky.SKY_DEFAULTS`` (a change of the defaults fails here until the
  script is rerun);
* a fresh run (the reference data's Amsterdam IWEC year, one unshaded 35 deg south plane, three technologies,
  about 10 s) reproduces the quoted spectral factors within 0.01 and their order a-Si > CdTe > c-Si with a
  margin of 0.005 each -- the direction Dirnberger et al. (Sol. Energy Mater. Sol. Cells 132 (2015) 431)
  measured over 3.5 years at Freiburg: +3.4 % a-Si, +2.4 % CdTe, +1.4 % c-Si against AM1.5G.
"""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGE = DOCS / "pvsim.md"
GENERATED = {"compare": DOCS / "generated" / "pvsim_compare.md", "sweep": DOCS / "generated" / "pvsim_sweep.md"}
REGENERATE = "rerun `python benchmarks/docs_pvsim_figures.py` (it rewrites docs/generated/pvsim_*.md)"
AMS_G173 = "Amsterdam IWEC, default sky, G173 ref."


def _table(path):
    """The first Markdown table of ``path`` as {row label: {column header: cell text}}."""
    lines = [ln for ln in path.read_text().split("\n") if ln.startswith("|")]
    head = [c.strip() for c in lines[0].strip("|").split("|")]
    rows = {}
    for ln in lines[2:]:
        cells = [c.strip().strip("*") for c in ln.strip("|").split("|")]
        rows[cells[0]] = dict(zip(head[1:], cells[1:]))
    return rows


def _section4():
    text = PAGE.read_text()
    return text[text.index("## 4."):text.index("## 5.")]


def _pages():
    """(page, its generated files, how to regenerate them) for every page that includes generated tables."""
    return [(PAGE, GENERATED, REGENERATE), (THERMAL_PAGE, THERMAL_GENERATED, THERMAL_REGENERATE)]


@pytest.mark.parametrize("which", [0, 1], ids=["pvsim", "thermal"])
def test_page_includes_the_generated_tables(which):
    page, generated, regenerate = _pages()[which]
    text = page.read_text()
    for path in generated.values():
        assert path.is_file(), f"{path} missing: {regenerate}"
        assert re.search(r"```\{include\} generated/" + re.escape(path.name) + r"\n```", text), \
            f"docs/{page.name} does not include generated/{path.name}"
        rows = [ln for ln in path.read_text().split("\n") if ln.startswith("| ") and not ln.startswith("|---")]
        assert len(rows) >= 4, f"{path.name} holds no tables: {regenerate}"
        copied = [ln for ln in rows if ln in text]
        assert not copied, f"docs/{page.name} holds a hand-copied row of {path.name}: {copied[0]}"


@pytest.mark.parametrize("which", [0, 1], ids=["pvsim", "thermal"])
def test_stamps_name_the_current_sky_defaults(which):
    import widesky
    _, generated, regenerate = _pages()[which]
    for path in generated.values():
        m = re.search(r"SKY_DEFAULTS: `(.*?)`", path.read_text())
        assert m, f"{path.name} has no SKY_DEFAULTS stamp: {regenerate}"
        assert m.group(1) == repr(widesky.SKY_DEFAULTS), (
            f"{path.name} was generated under {m.group(1)}, the defaults are now {widesky.SKY_DEFAULTS!r}: "
            f"{regenerate}")


def test_prose_quotes_the_generated_numbers():
    sec = _section4()
    cmp = _table(GENERATED["compare"])
    a_si = cmp["amorphous Si"][AMS_G173].split("; ")[1]
    mismatch = re.search(r"mismatch ([0-9.]+ %)", cmp["perovskite/Si tandem 2T"][AMS_G173]).group(1)
    assert f"a-Si {a_si}" in sec, f"section 4 does not quote the generated a-Si spectral factor {a_si}"
    assert f"mismatch {mismatch}" in sec, f"section 4 does not quote the generated 2T mismatch {mismatch}"
    sw = _table(GENERATED["sweep"])
    col = "Amsterdam IWEC, default sky"
    best = max(sw, key=lambda g: float(sw[g][col].split(";")[0]))
    assert f"{best} eV" in sec, f"section 4 does not quote the generated optimum {best} eV"


@pytest.mark.reference
@pytest.mark.slow
def test_fresh_run_reproduces_the_quoted_spectral_factors(tmp_path):
    import pandas as pd
    import trimesh
    from widesky.core.paths import data_file
    t = np.radians(35.0)
    v = np.array([[0, 0, 5], [2, 0, 5], [2, 2 * np.cos(t), 5 + 2 * np.sin(t)], [0, 2 * np.cos(t), 5 + 2 * np.sin(t)]])
    trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False).export(tmp_path / "plane.obj")
    cmd = [sys.executable, "-m", "widesky", "pv", "compare", str(tmp_path / "plane.obj"), "--ground-z", "0",
           "--weather", str(data_file("weather/NLD_Amsterdam062400_IWEC.epw")), "--technology", "a_si",
           "--technology", "cdte", "--technology", "topcon", "--jobs", "1", "-o", str(tmp_path / "out")]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    sf = pd.read_csv(tmp_path / "out" / "summary.csv", index_col=0)["spectral_factor"]
    assert sf["a_si"] - sf["cdte"] > 0.005 and sf["cdte"] - sf["topcon"] > 0.005, dict(sf)
    quoted = _table(GENERATED["compare"])
    for tech, label in (("a_si", "amorphous Si"), ("cdte", "CdTe"), ("topcon", "mono c-Si TOPCon")):
        q = float(quoted[label][AMS_G173].split("; ")[1])
        assert abs(sf[tech] - q) < 0.01, f"{label}: fresh {sf[tech]:.3f}, docs {q:.3f}: {REGENERATE}"


# docs/thermal.md, "The spectral treatment": docs/generated/thermal_glazing*.md are written by
# benchmarks/docs_glazing_study.py (the office box of widesky.thermal.study, the default sky under the Denver, San
# Francisco and Chicago TMY3 years); the same checks as for pvsim, and the prose quotes the annual ranges.
THERMAL_PAGE = DOCS / "thermal.md"
THERMAL_GENERATED = {"glazing": DOCS / "generated" / "thermal_glazing.md",
                     "solar_control": DOCS / "generated" / "thermal_glazing_solar_control.md"}
THERMAL_REGENERATE = ("rerun `python benchmarks/docs_glazing_study.py` (it rewrites "
                      "docs/generated/thermal_glazing*.md)")


def _annual_rows(path):
    """The annual table of ``path`` (the one headed by 'climate') as a list of cell lists."""
    lines = [ln for ln in path.read_text().split("\n") if ln.startswith("| ")]
    start = next(i for i, ln in enumerate(lines) if ln.startswith("| climate |"))
    return [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[start + 1:]]


def _thermal_section():
    text = THERMAL_PAGE.read_text()
    return text[text.index("## The spectral treatment"):text.index("## A facade study")]


def test_thermal_prose_quotes_the_generated_ranges():
    sec = _thermal_section()
    rows = _annual_rows(THERMAL_GENERATED["glazing"])
    for unit in ("clear", "low-e", "low-e #2"):
        d = sorted((r[3] for r in rows if r[1] == unit), key=lambda s: float(s.split()[0]))
        quoted = f"{d[0].split()[0]} to {d[-1]} ({unit})"
        assert quoted in sec, f"the prose does not quote the generated window-gain range {quoted!r}"
    sc = _annual_rows(THERMAL_GENERATED["solar_control"])
    for col, what in ((3, "window gain"), (5, "cooling load")):
        d = sorted(abs(float(r[col].split()[0])) for r in sc)
        quoted = f"{what} by {d[0]:.2f}-{d[-1]:.2f} %"
        assert quoted in sec, f"the prose does not quote the generated solar-control range {quoted!r}"
