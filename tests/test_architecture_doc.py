"""docs/architecture.md stays true: every module it names exists, and every module of the
layers, the command line and `optimise` is named there (a new module needs its line)."""

import re
from pathlib import Path

ROOT = Path(__file__).parents[1]
DOC = ROOT / "docs" / "architecture.md"
# A module as the page names it: a path relative to msfd_jax/ (`_model/scene.py`,
# `cli/run.py`) or to the repository (`optimise/_tune.py`, `tests/test_layout.py`).
NAMED = re.compile(r"`([\w/]+\.py)`")
REPO = ("msfd_jax", "optimise", "tests", "benchmarks")  # a path from the repository root
PACKAGES = ("_runtime", "_model", "_reference", "_batched", "_collision", "_sweeps", "cli")


def _named() -> set[Path]:
    found = set()
    for name in NAMED.findall(DOC.read_text(encoding="utf-8")):
        path = ROOT / name if name.split("/")[0] in REPO else None
        found.add(path if path is not None else ROOT / "msfd_jax" / name)
    return found


def _modules() -> set[Path]:
    out = {ROOT / "msfd_jax" / "_plot.py"}
    for package in PACKAGES:
        out.update(p for p in (ROOT / "msfd_jax" / package).glob("*.py") if p.name != "__init__.py")
    out.update(p for p in (ROOT / "optimise").glob("*.py") if p.name != "__init__.py")
    out.add(ROOT / "msfd_jax" / "cli" / "__init__.py")
    return out


def test_every_module_the_page_names_exists():
    named = _named()
    assert len(named) > 30  # the pattern finds the page's modules
    missing = sorted(str(p.relative_to(ROOT)) for p in named if not p.is_file())
    assert not missing, f"docs/architecture.md names modules that do not exist: {missing}"


def test_every_module_is_named_on_the_page():
    absent = sorted(str(p.relative_to(ROOT)) for p in _modules() - _named())
    assert not absent, f"modules missing from docs/architecture.md: {absent}"


def test_every_layer_folder_on_the_page_exists():
    text = DOC.read_text(encoding="utf-8")
    for package in PACKAGES[:-1]:
        assert f"msfd_jax/{package}/" in text and (ROOT / "msfd_jax" / package).is_dir()
