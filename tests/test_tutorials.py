"""The tutorial notebooks (docs/tutorials/) run: executed cell by cell in a Jupyter kernel, and
their code cells as one unguarded ``python file.py``, each in a fresh working folder; and they are
stored clean (nbformat 4, no outputs), so what the repository holds is what a reader runs."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="the docs extra is not installed (pip install -e '.[docs]')")
NotebookClient = pytest.importorskip("nbclient", reason="the docs extra is not installed").NotebookClient

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.ipynb"))
#: Seconds a cell may take: the first run on a machine compiles the kernels (~40-90 s under load).
CELL_TIMEOUT = 600


def names(paths):
    return [path.stem for path in paths]


def test_there_is_a_tutorial_of_every_study():
    assert {"delivery-sweep", "replenishment", "items", "lunar"} <= set(names(TUTORIALS))


@pytest.mark.parametrize("path", TUTORIALS, ids=names(TUTORIALS))
def test_a_tutorial_is_stored_clean(path):
    notebook = nbformat.read(path, as_version=nbformat.NO_CONVERT)
    nbformat.validate(notebook)
    assert notebook.nbformat == 4
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert code and all(not cell.outputs and cell.execution_count is None for cell in code)
    # no magics or shell escapes: the code cells are a Python script as they stand
    assert not any(line.lstrip().startswith(("%", "!")) for cell in code for line in cell.source.splitlines())


#: The kernel the notebooks run in: this interpreter, whatever kernels the machine has installed.
KERNEL = "dronefleet-tests"


@pytest.fixture
def this_interpreters_kernel(tmp_path_factory, monkeypatch):
    """A kernel spec :data:`KERNEL` of this interpreter, found first (``JUPYTER_PATH``): the
    'python3' spec of a user's or the system's Jupyter may start another Python, without dronefleet."""
    folder = tmp_path_factory.mktemp("jupyter")
    (folder / "kernels" / KERNEL).mkdir(parents=True)
    spec = {"argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
            "display_name": "dronefleet tests", "language": "python"}
    (folder / "kernels" / KERNEL / "kernel.json").write_text(json.dumps(spec), encoding="utf-8")
    monkeypatch.setenv("JUPYTER_PATH", str(folder))
    return KERNEL


@pytest.mark.parametrize("path", TUTORIALS, ids=names(TUTORIALS))
def test_a_tutorial_runs_as_a_notebook(path, tmp_path, this_interpreters_kernel):
    """Every cell, in a kernel of this interpreter: a cell that raises fails the test, naming it."""
    notebook = nbformat.read(path, as_version=4)
    client = NotebookClient(notebook, timeout=CELL_TIMEOUT, kernel_name=this_interpreters_kernel,
                            resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    produced = {output.get("name") or output.output_type for cell in notebook.cells if cell.cell_type == "code"
                for output in cell.outputs}
    assert "error" not in produced
    # progress bars draw as widgets (ipywidgets, of the docs extra), not as a warning that they cannot
    printed = "".join(output.get("text", "") for cell in notebook.cells if cell.cell_type == "code"
                      for output in cell.outputs)
    assert "IProgress not found" not in printed
    assert (tmp_path / "tutorial-output").is_dir()


@pytest.mark.parametrize("path", TUTORIALS, ids=names(TUTORIALS))
def test_a_tutorials_code_runs_as_an_unguarded_script(path, tmp_path):
    """The code cells, concatenated, as ``python tutorial.py`` (no ``__main__`` guard): a sweep's
    workers must not run the script again."""
    notebook = json.loads(path.read_text(encoding="utf-8"))
    code = "\n\n".join("".join(cell["source"]) for cell in notebook["cells"] if cell["cell_type"] == "code")
    script = tmp_path / f"{path.stem}.py"
    script.write_text(code + "\n", encoding="utf-8")
    done = subprocess.run([sys.executable, script.name], cwd=tmp_path, capture_output=True, text=True,
                          timeout=CELL_TIMEOUT * 2, stdin=subprocess.DEVNULL, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    written = {file.suffix for file in (tmp_path / "tutorial-output").rglob("*")}
    assert {".png", ".pdf", ".svg", ".html"} <= written
