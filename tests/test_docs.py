"""The documentation site builds offline with warnings as errors (Sphinx, pydata theme, myst, gallery).

Built from a copy of docs/ (sphinx-gallery writes its generated pages into the source tree). The site's
structure is explicit (tutorials, how-to guides, explanation, validation, reference, development notes: the
toctrees of docs/index.md), so a page that no toctree names makes Sphinx warn and the build fail. Skips
cleanly when the [docs] extra is not installed (``.ci/run`` installs it); the structure checks that need no
build (first command, purpose paragraphs, page lengths) run without it.
"""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
pytestmark = pytest.mark.slow

# user pages that other work in progress (issues 35, 36 and 40) is still editing and whose development history is
# still to be moved to docs/dev/: exempt from the length limit until then (three are over it today)
MAX_USER_PAGE_LINES = 420  # "no page over about 400 lines of user documentation"


def _pages():
    """Every Markdown source page of the site (not the generated gallery, the example data or READMEs)."""
    skip = {"_build", "gallery", "example-data", "figures", "_static", "generated"}  # generated/: included fragments
    return sorted(p for p in DOCS.rglob("*.md")
                  if p.name != "README.md" and not skip & set(p.relative_to(DOCS).parts[:-1]))


def _first_command(text):
    return re.search(r"```bash\n(.*?)\n", text).group(1).strip()


def test_the_docs_index_gives_the_readme_first_command():
    assert _first_command((DOCS / "index.md").read_text()) == _first_command((ROOT / "README.md").read_text())
    assert _first_command((DOCS / "guide" / "quickstart.md").read_text()) == _first_command(
        (ROOT / "README.md").read_text())


def test_every_page_states_its_purpose_first():
    """Under the title, the first paragraph is prose (not code, a table, a figure or a list)."""
    for page in _pages():
        lines = page.read_text().split("\n")
        assert lines[0].startswith("# "), page
        first = next(line for line in lines[1:] if line.strip())
        assert not first.startswith(("```", "|", "!", "-", "*", "#", "<")), (page, first)


SCREEN_COLUMNS = 120


def _screen_lines(text):
    """Lines a page takes on a screen of :data:`SCREEN_COLUMNS` columns: a prose line longer than that counts as
    the lines it wraps to (so packing a paragraph into one long line does not shorten a page); a table row counts
    once (its cells wrap inside the table)."""
    return sum(1 if line.lstrip().startswith("|") else max(1, -(-len(line) // SCREEN_COLUMNS))
               for line in text.split("\n"))


def test_screen_lines_count_long_prose_lines():
    assert _screen_lines("a\n" + "x" * 121 + "\n| " + "y" * 300 + " |") == 1 + 2 + 1


def test_user_pages_stay_short():
    for page in _pages():
        rel = page.relative_to(DOCS)
        n = _screen_lines(page.read_text())
        if rel.parts[0] == "dev":
            continue                      # development notes may be long
        assert n <= MAX_USER_PAGE_LINES, f"{rel}: {n} lines of user documentation at {SCREEN_COLUMNS} columns (limit {MAX_USER_PAGE_LINES})"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    for mod in ("sphinx", "pydata_sphinx_theme", "sphinx_gallery", "myst_parser"):
        pytest.importorskip(mod)
    root = tmp_path_factory.mktemp("docs")
    src = root / "docs"
    shutil.copytree(DOCS, src, ignore=shutil.ignore_patterns("_build", "gallery", "__pycache__"))
    out = root / "html"
    p = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(src), str(out)],
                       capture_output=True, text=True, timeout=600, env={**__import__("os").environ,
                                                                        "OMP_NUM_THREADS": "1"})
    return p, out


def test_site_builds_without_warnings(site):
    p, out = site
    assert p.returncode == 0, p.stderr[-4000:]
    assert (out / "index.html").is_file()


def test_every_markdown_page_is_in_the_site(site):
    """Every page is built, and every entry of the index's toctrees is linked from the index, in the index's
    order (tutorials first, development notes last)."""
    p, out = site
    for md in _pages():
        assert (out / md.relative_to(DOCS).with_suffix(".html")).is_file(), md
    index = (out / "index.html").read_text()
    entries = re.findall(r"^([a-z][\w/-]*)$", (DOCS / "index.md").read_text(), re.M)
    assert entries[0] == "guide/quickstart" and entries[-1] == "dev/index", entries
    positions = []
    for entry in entries:
        href = f'href="{entry}.html"'
        assert href in index, entry
        positions.append(index.index(href))
    assert positions == sorted(positions), entries


def test_api_reference_is_generated_from_the_docstrings(site):
    _, out = site
    sky = (out / "api" / "skymodel.html").read_text()
    for name in ("widesky.skymodel.sky_radiance", "widesky.skymodel.load_dataset", "widesky.skymodel.render.render_sky"):
        assert f'id="{name}"' in sky, name
    irr = (out / "api" / "irradiance.html").read_text()
    for name in ("widesky.irradiance.poa_irradiance", "widesky.irradiance.Site", "widesky.irradiance.POAResult"):
        assert f'id="{name}"' in irr, name
    assert "[W m-2 sr-1 nm-1]" in sky                       # the units of the docstrings are on the page


def test_gallery_examples_ran(site):
    _, out = site
    gallery = out / "gallery"
    pages = sorted(gallery.glob("plot_*.html"))
    assert len(pages) >= 3
    for page in pages:
        html = page.read_text()
        assert "sphx_glr_" in html and ".png" in html, page.name          # each example produced a figure
    assert "kWh m-2" in (gallery / "plot_clear_sky_day.html").read_text()  # its printed output is on the page


def test_site_is_offline(site):
    _, out = site
    import re
    for page in [out / "index.html", out / "guide" / "quickstart.html"]:
        html = page.read_text()
        # no script or stylesheet from another origin
        assert not re.search(r'<(script|link)[^>]+(src|href)="https?://', html), page
