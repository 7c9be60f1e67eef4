"""The documentation site builds offline with warnings as errors (Sphinx, pydata theme, myst, gallery).

Built from a copy of docs/ (sphinx-gallery writes its generated pages into the source tree) with one extra
top-level page, to check that pages added to docs/ join the site through the globbed toctree. Skips cleanly
when the [docs] extra is not installed (``.ci/run`` installs it).
"""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx")
pytest.importorskip("pydata_sphinx_theme")
pytest.importorskip("sphinx_gallery")
pytest.importorskip("myst_parser")

DOCS = Path(__file__).resolve().parents[1] / "docs"
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    root = tmp_path_factory.mktemp("docs")
    src = root / "docs"
    shutil.copytree(DOCS, src, ignore=shutil.ignore_patterns("_build", "gallery", "__pycache__"))
    (src / "zz-added-page.md").write_text("# A page added later\n\nJoins the site by the glob.\n")
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
    p, out = site
    index = (out / "index.html").read_text()
    for md in [p for p in DOCS.glob("*.md") if p.name != "index.md"] + [Path("zz-added-page.md")]:
        assert (out / (md.stem + ".html")).is_file(), md.name
        assert f'href="{md.stem}.html"' in index, md.name
    for page in ("guide/quickstart", "guide/concepts", "guide/howto", "guide/explorer", "guide/cases"):
        assert (out / (page + ".html")).is_file(), page


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
