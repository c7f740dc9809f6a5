"""The documentation site (mkdocs.yml) builds with every warning an error, and its API pages come from
the docstrings: a broken link, a missing page or a docstring mkdocstrings cannot render fails here."""

import inspect
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from dronefleet import api

ROOT = Path(__file__).resolve().parents[1]


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
