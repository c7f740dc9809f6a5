"""Citations of the model descriptions ("docs/delivery-model.md section 7") point at sections that exist,
and the links of the README and the docs at files that exist."""

import re
from pathlib import Path

from dronefleet import scenarios

ROOT = Path(__file__).resolve().parents[1]
CITATION = re.compile(r"docs/([\w-]+\.md)(?: sections? (\d+(?:\.\d+)?(?:(?:, | and |-)\d+(?:\.\d+)?)*))?")
CITING = ("README.md", "docs/guide/*.md", "CONTRIBUTING.md", "dronefleet/**/*.py", "dronefleet/**/*.toml", "configs/**/*.toml",
          "tests/**/*.py", "tests/**/*.md", "experiments/*", "results/README.md")


def sections(text):
    """Section numbers of a model description: "## N." and "### N.M" headings, and the items of
    section 11's numbered list as "11.K"."""
    found, current = set(), None
    for line in text.splitlines():
        heading = re.match(r"#{2,3} (\d+(?:\.\d+)?)\.? ", line)
        if heading:
            current = heading.group(1)
            found.add(current)
        elif line.startswith("## "):
            current = None
        elif current == "11" and (item := re.match(r"(\d+)\. ", line)):
            found.add(f"11.{item.group(1)}")
    return found


def citations():
    """(citing file, cited doc, cited section numbers) for every citation in the repository."""
    for pattern in CITING:
        for path in sorted(ROOT.glob(pattern)):
            if path.is_file() and path.resolve() != Path(__file__).resolve():
                for match in CITATION.finditer(path.read_text(encoding="utf-8")):
                    numbers = re.split(r", | and |-", match.group(2)) if match.group(2) else []
                    yield path.relative_to(ROOT).as_posix(), match.group(1), numbers


def test_model_descriptions_keep_the_numbering_the_code_cites():
    delivery = sections((ROOT / "docs" / "delivery-model.md").read_text(encoding="utf-8"))
    replenishment = sections((ROOT / "docs" / "replenishment-model.md").read_text(encoding="utf-8"))
    assert {str(n) for n in range(1, 12)} <= delivery
    assert {str(n) for n in range(1, 12)} | {"5.1", "5.2", "5.3", "5.4"} <= replenishment
    assert {f"11.{k}" for k in range(1, 16)} <= replenishment


def test_sections_parse_headings_and_section_11_items():
    text = "## 4. Motion\n1. not an item\n## 11. Ambiguities\n1. **Rate.**\n2. **Bias.**\n### 5.2 Events\n"
    assert sections(text) == {"4", "11", "11.1", "11.2", "5.2"}


def test_every_citation_names_a_section_that_exists():
    wrong = []
    for cited_from, doc, numbers in citations():
        if not (ROOT / "docs" / doc).is_file():
            wrong.append(f"{cited_from}: docs/{doc} does not exist")
            continue
        missing = set(numbers) - sections((ROOT / "docs" / doc).read_text(encoding="utf-8"))
        if missing:
            wrong.append(f"{cited_from}: docs/{doc} has no section {', '.join(sorted(missing))}")
    assert not wrong, "\n".join(wrong)


#: A Markdown link's target: ``[text](target)``, the target without its ``#anchor``.
LINK = re.compile(r"\[[^\]]*\]\(([^)#\s]*)(?:#[^)\s]*)?\)")


def links(path):
    """The relative link targets of the Markdown file ``path`` (web addresses and anchors left out)."""
    text = re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.MULTILINE | re.DOTALL)
    return [target for target in LINK.findall(text) if target and not re.match(r"[a-z]+:", target)]


def test_links_finds_relative_targets_only():
    text = "[a](b.md#c) [d](https://e) [f](#g) `[h](i.md)`\n```\n[j](k.md)\n```\n[l](../m.md)"
    path = ROOT / "tests" / ".links-example.md"
    try:
        path.write_text(text, encoding="utf-8")
        assert links(path) == ["b.md", "i.md", "../m.md"]
    finally:
        path.unlink()


def test_every_link_of_the_readme_and_docs_resolves():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]

    def resolves(page, target):
        # the site's hook (docs/hooks.py) publishes results/ beside docs/: docs/index.md links it as results/;
        # it writes the tables pages (docs/tables/) too
        at = (page.parent / target).resolve()
        if at.is_relative_to((ROOT / "docs" / "tables").resolve()):
            return at.stem in {"index", *scenarios.SCENARIOS}
        site_results = (ROOT / "docs" / "results").resolve()
        return at.exists() or (at.is_relative_to(site_results)
                               and (ROOT / "results" / at.relative_to(site_results)).exists())

    broken = [f"{page.relative_to(ROOT)}: {target}" for page in pages for target in links(page)
              if not resolves(page, target)]
    assert not broken, "\n".join(broken)


def test_the_user_guide_links_only_inside_docs():
    # The documentation site is built from docs/ alone: a link out of it is a broken page there.
    docs = (ROOT / "docs").resolve()
    outside = [f"{page.relative_to(ROOT)}: {target}" for page in sorted((ROOT / "docs" / "guide").glob("*.md"))
               for target in links(page) if docs not in (page.parent / target).resolve().parents]
    assert not outside, "\n".join(outside)


# ------------------------------------------------------------------ what every page may name

#: Units a column's name promises by its ending (``duration_s``: seconds).
UNIT_OF_SUFFIX = {"_s": "s", "_m": "m", "_j": "J", "_wh": "Wh", "_kg": "kg", "_pct": "%", "_minutes": "min",
                  "_weeks": "week"}


def test_every_column_of_every_scenarios_tables_is_documented_with_its_unit():
    import pyarrow as pa

    for name, scenario in scenarios.SCENARIOS.items():
        documented = scenario.columns()
        schemas = scenario.table_schemas()
        assert set(documented) == set(schemas), name
        for table, schema in schemas.items():
            assert set(documented[table]) == set(schema.names), (name, table)
            for field in schema:
                column = documented[table][field.name]
                assert len(column.doc.split()) >= 2, (name, table, field.name)  # a phrase, not a word
                numeric = pa.types.is_integer(field.type) or pa.types.is_floating(field.type)
                if numeric and field.name != "seed":
                    assert column.unit, f"{name} {table}.{field.name} has no unit"
                for suffix, unit in UNIT_OF_SUFFIX.items():
                    if field.name.endswith(suffix):
                        assert column.unit == unit, (name, table, field.name, column.unit)


#: The pages a user reads: the docs (the site) and the results page beside the figures.
USER_PAGES = ["docs/**/*.md", "docs/**/*.ipynb", "results/README.md"]
#: Words that point at what a user cannot open: the specification the models were written from, the
#: issue tracker, its numbered lists (``A12``), its numbered rules (``row 5``).
UNSHIPPED = re.compile(r"(?i:\bspec(?:s|ification)?\b|§|\bissues?\b|#\d+\b|\brows? \d+\b)|\bA\d{1,2}\b")


def unshipped_references(text: str) -> list[str]:
    """What ``text`` names that a user cannot open: the matches of :data:`UNSHIPPED`, and every
    ``name.md`` that is not a file of the repository."""
    shipped = {path.name for path in ROOT.rglob("*.md") if not {".venv", "site"} & set(path.parts)}
    found = [match.group(0) for match in UNSHIPPED.finditer(text)]
    return found + [name for name in re.findall(r"[\w.-]+\.md\b", text) if name not in shipped]


def test_unshipped_references_finds_each_kind():
    text = ("see the spec, LUNAR-FORAGING.md section 3, A12 and row 5 (issue 30, #12); "
            "docs/items-model.md and lunar-readings.md are fine, notes.md is not; the specs too; Table A1")
    assert unshipped_references(text) == ["spec", "A12", "row 5", "issue", "#12", "specs", "A1",
                                          "LUNAR-FORAGING.md", "notes.md"]
    assert unshipped_references("Issues of the SPEC, Rows 3") == ["Issues", "SPEC", "Rows 3"]


def test_no_user_page_names_an_unshipped_document_or_an_issue():
    wrong = [f"{path.relative_to(ROOT)}: {', '.join(sorted(set(found)))}"
             for pattern in USER_PAGES for path in sorted(ROOT.glob(pattern))
             if (found := unshipped_references(path.read_text(encoding="utf-8")))]
    assert not wrong, "\n".join(wrong)


# ------------------------------------------------------------------ the help names the four studies

STUDIES = {"delivery": "D4.4", "replenishment": "D4.4", "items": "Liemhetcharat", "lunar": "Angyal"}


def test_help_of_dronefleet_run_names_every_scenario_and_its_study():
    import pydoc

    import dronefleet

    text = pydoc.render_doc(dronefleet.run, renderer=pydoc.plaintext)
    for name, study in STUDIES.items():
        assert f'"{name}"' in text and study in text, name


def test_the_command_lines_help_names_every_scenario():
    import subprocess
    import sys

    shown = subprocess.run([sys.executable, "-m", "dronefleet", "--help"], capture_output=True, text=True,
                           check=True).stdout
    assert all(re.search(rf"\b{name}\b", shown) for name in STUDIES)


def test_the_package_description_and_citation_name_the_four_studies():
    import tomllib

    import yaml

    description = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["description"]
    assert all(study in description for study in ("D4.4", "Liemhetcharat", "Angyal"))
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    titles = {reference["title"] for reference in citation["references"]}
    assert {"Multi-Robot Item Delivery and Foraging: Two Sides of a Coin",
            "Feasibility study of Energetics in Nature-inspired Foraging for Lunar Resource Exploitation",
            "Deliverable 4.4: Virtual Machines for Swarm Control and Learning"} <= titles
