"""Every notebooks/*.py (jupytext percent format) executes as a notebook without a cell error.

Each runs from its own folder, as Jupyter opens it: there a file ``notebooks/X.py`` is
importable as ``X`` and would shadow a package of that name (a notebook once called
``optimise.py`` broke ``import optimise``). Nothing may be left in the folder, and temporary
files go to the test's own folder (``TMPDIR``).

The kernel is this interpreter's: a throwaway ``python3`` kernelspec pointing at
``sys.executable`` is put first on ``JUPYTER_PATH``, so a user's own ``python3`` kernel (maybe
another Python without msfd_jax) is not picked up.
"""

import json
import re
import sys
from pathlib import Path

import jupytext
import nbclient
import pytest

NOTEBOOKS_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOKS_DIR.glob("*.py"))


@pytest.fixture(scope="session")
def kernel_name(tmp_path_factory):
    root = tmp_path_factory.mktemp("jupyter")
    spec = root / "kernels" / "python3"
    spec.mkdir(parents=True)
    argv = [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"]
    kernel = {"argv": argv, "display_name": "Python 3 (msfd tests)", "language": "python"}
    (spec / "kernel.json").write_text(json.dumps(kernel))
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("JUPYTER_PATH", str(root))
        patch.setenv("MPLBACKEND", "Agg")
        yield "python3"


def test_there_are_notebooks():
    assert NOTEBOOKS, "no notebooks/*.py found"


def test_no_notebook_shadows_a_module_it_imports():
    """Run from notebooks/, ``import X`` finds notebooks/X.py before the package X."""
    stems = {path.stem for path in NOTEBOOKS}
    for path in NOTEBOOKS:
        imported = set(re.findall(r"^(?:import|from) +(\w+)", path.read_text(), re.MULTILINE))
        assert not imported & stems, f"{path.name} imports {imported & stems}, a notebook's name"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs(path, kernel_name, tmp_path, monkeypatch):
    before = sorted(NOTEBOOKS_DIR.rglob("*"))
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # the kernel's tempfile folder
    notebook = jupytext.read(path)
    client = nbclient.NotebookClient(
        notebook,
        kernel_name=kernel_name,
        timeout=600,
        resources={"metadata": {"path": str(NOTEBOOKS_DIR)}},  # where Jupyter runs it
    )
    client.execute()  # raises CellExecutionError naming the failing cell
    assert sorted(NOTEBOOKS_DIR.rglob("*")) == before, "the notebook left files in notebooks/"
    errors = [
        output
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.get("outputs", [])
        if output.get("output_type") == "error"
    ]
    assert not errors
    # Figures from msfd_jax._plot display without pyplot (their _repr_png_).
    shown = [
        output
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.get("outputs", [])
        if "image/png" in output.get("data", {})
    ]
    assert shown or "plot_" not in path.read_text()
