"""The documentation site (mkdocs.yml) builds with every warning an error, and its API pages come from
the docstrings: a broken link, a missing page or a docstring mkdocstrings cannot render fails here.
Its tables pages list every column of every scenario, and its tutorial pages render the notebooks
in a real browser (headless Chromium). Without the ``docs`` extra (pip install -e '.[docs]') these
tests skip; with it, a missing Chromium fails them."""

import html
import inspect
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="the docs extra is not installed (pip install -e '.[docs]')")
pytest.importorskip("mkdocs_jupyter", reason="the docs extra is not installed (pip install -e '.[docs]')")

from dronefleet import api, scenarios  # noqa: E402 (after the skip: the docs extra first)

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "docs" / "tutorials").glob("*.ipynb"))


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built by ``mkdocs build --strict`` into a temporary folder (a few seconds)."""
    out = tmp_path_factory.mktemp("site")
    # Not --quiet: mkdocs 1.6 then counts no warnings and --strict passes a broken link.
    # NO_MKDOCS_2_WARNING: mkdocs-material's banner about MkDocs 2, printed on every build.
    built = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                            "--config-file", str(ROOT / "mkdocs.yml"), "--site-dir", str(out)],
                           cwd=ROOT, capture_output=True, text=True, timeout=300,
                           env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert built.returncode == 0, built.stdout + built.stderr
    return out


def section(page: str, anchor: str, next_anchor: str) -> str:
    """The HTML of ``page`` from the heading ``id=anchor`` to the heading ``id=next_anchor``."""
    start = page.index(f'id="{anchor}"')
    return page[start:page.index(f'id="{next_anchor}"', start)]


def test_the_sweep_page_documents_every_parameter_of_dronefleet_sweep(site):
    page = (site / "api" / "api" / "index.html").read_text(encoding="utf-8")
    sweep = section(page, "dronefleet.api.sweep", "dronefleet.api.Run")
    names = list(inspect.signature(api.sweep).parameters)
    assert {"grid", "seeds", "base", "set", "jobs"} <= set(names)  # the signature is the list under test
    documented = {name for name in names if re.search(rf"<code>\s*{name}\s*</code>", sweep)}
    assert documented == set(names)
    # the docstring's own words, and its Sphinx roles made code spans rather than shown verbatim
    assert "Processes of this machine to run on" in sweep
    assert ":func:" not in page and ":mod:" not in page


def test_the_results_page_carries_its_figures(site):
    results = (site / "results" / "index.html").read_text(encoding="utf-8")
    figures = re.findall(r'<img [^>]*src="([^"]+\.png)"', results)
    assert "fig09/fig09.png" in figures
    assert all((site / "results" / figure).is_file() for figure in figures)


def test_model_pages_link_to_the_results_page_on_the_site(site):
    experiments = (site / "delivery-experiments" / "index.html").read_text(encoding="utf-8")
    assert 'href="../results/"' in experiments


def test_comments_document_constants_and_protocol_members(site):
    # ``#:`` above a constant and a trailing comment after a protocol member are their docstrings
    contract = (site / "api" / "contract" / "index.html").read_text(encoding="utf-8")
    optional = section(contract, "dronefleet.contract.OPTIONAL", "dronefleet.contract.Field")
    assert "<code>format_bounds(config) -&gt; str</code>" in optional
    name = section(contract, "dronefleet.contract.ScenarioContract.NAME", "dronefleet.contract.ScenarioContract.SCHEMA")
    assert "its name in the registry" in name


def test_the_tables_pages_list_every_column_with_its_unit(site):
    for name, scenario in scenarios.SCENARIOS.items():
        page = (site / "tables" / name / "index.html").read_text(encoding="utf-8")
        documented = scenario.columns()
        for table, schema in scenario.table_schemas().items():
            start = page.index(f'id="{table}"')
            end = page.find("<h2", start + 1)
            part = page[start:end if end > 0 else None]  # to the next table, or the end
            rows = dict(re.findall(r"<tr>\s*<td><code>([^<]+)</code></td>\s*<td><code>[^<]*</code></td>\s*<td>([^<]*)</td>",
                                   part))
            for field in schema:
                assert rows[field.name] == (documented[table][field.name].unit or "-"), (name, table, field.name)
    index = (site / "tables" / "index.html").read_text(encoding="utf-8")
    assert 'href="lunar/#recharge_triggers"' in index


def test_every_notebook_is_a_page_of_the_tutorials_section(site):
    assert {path.stem for path in NOTEBOOKS} >= {"delivery-sweep", "replenishment", "lunar"}
    home = (site / "index.html").read_text(encoding="utf-8")
    for path in NOTEBOOKS:
        assert (site / "tutorials" / path.stem / "index.html").is_file()
        assert f'href="tutorials/{path.stem}/"' in home  # in the navigation
    # the tutorials' index links the pages, not the raw notebooks
    index = (site / "tutorials" / "index.html").read_text(encoding="utf-8")
    assert 'href="lunar/"' in index and ".ipynb" not in re.sub(r"<code>[^<]*</code>", "", index)


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def rendered(page: Path, profile: Path) -> str:
    """The DOM of ``page`` after headless Chromium loaded it offline (every name lookup fails, so a
    page that fetched anything from elsewhere would log an error); fails on any console line."""
    assert CHROMIUM, "Chromium is not installed (Debian: apt-get install chromium): the site's pages are not tested"
    done = subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={profile}", "--host-resolver-rules=MAP * ~NOTFOUND", "--enable-logging=stderr", "--v=0",
         "--window-size=1200,800", "--virtual-time-budget=5000", "--dump-dom", page.as_uri()],
        capture_output=True, text=True, timeout=300)
    console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    assert not console, console
    return done.stdout


def test_the_lunar_tutorial_renders_in_chromium(site, tmp_path):
    dom = rendered(site / "tutorials" / "lunar" / "index.html", tmp_path / "profile")
    notebook = nbformat.read(ROOT / "docs" / "tutorials" / "lunar.ipynb", as_version=4)
    # every cell of the notebook, in its order, as a cell of the page
    shown = re.findall(r'class="jp-Cell jp-(Code|Markdown)Cell[^"]*" id="cell-id=([^"]+)"', dom)
    assert shown == [(cell.cell_type.capitalize(), cell.id) for cell in notebook.cells]
    assert re.search(r"<h1[^>]*>Lunar foraging: runs, layouts, the beacon network and a replay<", dom)
    # code cells highlighted as Python, not shown as raw text
    assert re.search(r'<span class="n">dronefleet</span><span class="o">\.</span><span class="n">run</span>', dom)


def test_no_page_of_the_site_names_an_unshipped_document_or_an_issue(site):
    # the API pages too, made from the docstrings: every page as a reader sees its text
    from test_docs import unshipped_references

    wrong = {}
    for page in sorted(site.rglob("*.html")):
        markup = re.sub(r"<(script|style)\b.*?</\1>", "", page.read_text(encoding="utf-8"), flags=re.DOTALL)
        if found := unshipped_references(html.unescape(re.sub(r"<[^>]+>", " ", markup))):
            wrong[page.relative_to(site).as_posix()] = sorted(set(found))
    assert not wrong
