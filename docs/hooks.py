"""MkDocs and griffe hooks of the documentation site (mkdocs.yml): the results page, the tables
pages, the tutorials, Sphinx roles.

results/README.md and its figures live beside the results they describe, not in docs/; they are
added to the site as the page ``results/README.md`` (served as results/). Links between docs/ and
results/ are written relative to the repository, so that they work when browsing it
(``docs/delivery-experiments.md`` -> ``../results/README.md``); on the site, where docs/ is the
root, they are pointed at the same pages.

The pages ``tables/<scenario>.md`` are written here, one per registered scenario, from its
``table_schemas()`` (the columns and their types) and its ``columns()`` (what each holds, with its
unit): a column without a description stops the build. Every notebook of ``docs/tutorials/`` is a
page of the section "Tutorials" (mkdocs-jupyter renders it), in the order of its file name.

The docstrings name objects with Sphinx roles (``:func:`run```), which Markdown would show
verbatim, and document constants and protocol members with comments (``#:`` above a constant, as
Sphinx reads them; a trailing ``# ...`` after a declaration in a class body), which mkdocstrings
would not show at all. :class:`SphinxRoles`, a griffe extension, makes the roles code spans
(``run``) and the comments docstrings before mkdocstrings renders them.
"""

from __future__ import annotations

import posixpath
import re
from pathlib import Path

from griffe import Docstring, Extension, Object
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
#: Files of the repository outside docs/ that the site carries, at the same path (below results/).
RESULTS = "results"
#: A Markdown link or image target: ``](target)`` or ``](target#anchor)``, no URL scheme.
LINK = re.compile(r"\]\((?![a-z][a-z0-9+.-]*:|#|/)([^)\s#]+)(#[^)\s]*)?\)")
#: A Sphinx role: ``:func:`run```, ``:class:`~dronefleet.api.Run``` (``~``: show the last name only).
ROLE = re.compile(r":(?:py:)?[a-z]+:`(~?)([^`]+)`")
#: A declaration without a value in a class body and its trailing comment: ``NAME: str  # its name``.
DECLARATION = re.compile(r"^\s*\w+\s*:[^=#]+#\s?(.+)$")


def _results_files() -> list[str]:
    """The results page and the figures it shows, as repository paths (``results/fig09/fig09.png``)."""
    page = ROOT / RESULTS / "README.md"
    figures = {posixpath.normpath(posixpath.join(RESULTS, target))
               for target, _ in LINK.findall(page.read_text(encoding="utf-8"))}
    # a link back into docs/ is a page the site has already (on_page_markdown points it there)
    return [f"{RESULTS}/README.md", *sorted(f for f in figures if f.startswith(f"{RESULTS}/") and (ROOT / f).is_file())]


#: The folder of the generated table pages, and of the notebooks, inside the site.
TABLES, TUTORIALS = "tables", "tutorials"
#: The nav section the notebooks are added to, after its index page.
TUTORIALS_SECTION = "Tutorials"


def on_config(config):
    """The notebooks of docs/tutorials/ (by file name) appended to the nav's Tutorials section."""
    notebooks = [f"{TUTORIALS}/{path.name}" for path in sorted((ROOT / "docs" / TUTORIALS).glob("*.ipynb"))]
    for section in config["nav"]:
        for entry in section.get("User guide", []) if isinstance(section, dict) else []:
            if isinstance(entry, dict) and TUTORIALS_SECTION in entry:
                index = entry[TUTORIALS_SECTION]
                entry[TUTORIALS_SECTION] = [*([index] if isinstance(index, str) else index), *notebooks]
    return config


def on_files(files: Files, config) -> Files:
    for path in _results_files():
        files.append(File(path, src_dir=str(ROOT), dest_dir=config["site_dir"],
                          use_directory_urls=config["use_directory_urls"]))
    for name, text in table_pages().items():
        files.append(File.generated(config, f"{TABLES}/{name}.md", content=text))
    return files


def table_pages() -> dict[str, str]:
    """``{page name: Markdown}``: ``index`` and one page per registered scenario, each of its
    tables a section with a row per column (name, type, unit, meaning)."""
    from dronefleet import scenarios

    index = ["# Tables and their columns", "",
             "Every run writes its tables as parquet files (`dronefleet run --out`, `Run.save`; a sweep writes "
             "one dataset per table), and `dronefleet.run` returns them as pandas DataFrames. Each page lists "
             "every column of a scenario's tables: its type, its unit and what it holds. A unit `count` is a "
             "number of events or things, `index` a number that names one, `1` a plain ratio; a column without "
             "a unit holds words, flags or a seed.", "",
             "| scenario | tables |", "|---|---|"]
    pages = {}
    for name, scenario in scenarios.SCENARIOS.items():  # the built-in ones: what this package ships
        schemas, documented = scenario.table_schemas(), scenario.columns()
        lines = [f"# {name}: tables", "",
                 f"The tables of a `{name}` run (`dronefleet run {name}`), made from the scenario's "
                 f"`table_schemas()` and `columns()`.", ""]
        for table, schema in schemas.items():
            lines += [f"## {table}", "", "| column | type | unit | what it holds |", "|---|---|---|---|"]
            for field in schema:
                column = documented.get(table, {}).get(field.name)
                if column is None or not column.doc.strip():
                    raise PluginError(f"the column {field.name!r} of the {name} table {table!r} has no "
                                      f"description: add it to the scenario's columns()")
                lines.append(f"| `{field.name}` | `{field.type}` | {column.unit or '-'} | "
                             f"{column.doc.replace('|', '&#124;')} |")
            lines.append("")
        pages[name] = "\n".join(lines)
        index.append(f"| [{name}]({name}.md) | {', '.join(f'[`{t}`]({name}.md#{t})' for t in schemas)} |")
    pages["index"] = "\n".join(index) + "\n"
    return pages


def on_page_markdown(markdown: str, page, config, files: Files) -> str:
    """Links of a page that leave docs/ for results/ (or come back) -> the same page on the site."""
    # where the page lives in the repository: docs/x.md, or results/README.md
    repository_path = page.file.src_uri if page.file.src_uri.startswith(f"{RESULTS}/") else f"docs/{page.file.src_uri}"
    here = posixpath.dirname(repository_path)

    def site_link(match: re.Match) -> str:
        target = posixpath.normpath(posixpath.join(here, match.group(1)))
        if target.startswith("docs/"):
            target = target.removeprefix("docs/")
        elif not target.startswith(f"{RESULTS}/"):
            return match.group(0)  # a file the site does not carry: left for the strict build to report
        relative = posixpath.relpath(target, posixpath.dirname(page.file.src_uri) or ".")
        return f"]({relative}{match.group(2) or ''})"

    return LINK.sub(site_link, markdown)


class SphinxRoles(Extension):
    """Sphinx roles of the docstrings -> Markdown code spans (the module doc)."""

    def on_object(self, *, obj: Object, **kwargs) -> None:
        if obj.is_attribute and obj.docstring is None and (comment := attribute_comment(obj)):
            obj.docstring = Docstring(comment, lineno=obj.lineno, parent=obj)
        if obj.docstring is not None:
            obj.docstring.value = ROLE.sub(
                lambda role: f"`{role.group(2).rsplit('.', 1)[-1] if role.group(1) else role.group(2)}`",
                obj.docstring.value)


def attribute_comment(attribute: Object) -> str | None:
    """The ``#:`` lines right above ``attribute``, else its trailing comment in a class body; None if neither."""
    if attribute.lineno is None or attribute.filepath is None:
        return None
    lines = attribute.lines_collection[attribute.filepath]
    above = []
    for line in reversed(lines[:attribute.lineno - 1]):
        if not line.strip().startswith("#:"):
            break
        above.insert(0, line.strip().removeprefix("#:").removeprefix(" "))
    if above:
        return "\n".join(above)
    declaration = DECLARATION.match(lines[attribute.lineno - 1])
    return declaration.group(1).strip() if declaration and attribute.parent.is_class else None
