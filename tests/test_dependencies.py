"""The installed versions satisfy the bounds declared in pyproject.toml.

Testing *at* the minimums needs its own environment, e.g.
``uv venv /tmp/min && uv pip install --resolution lowest-direct -e '.[test]' && pytest``.
"""

import importlib.metadata
import re
import tomllib
from pathlib import Path

import pytest

PYPROJECT = Path(__file__).resolve().parent.parent / "pyproject.toml"
DEPENDENCIES = tomllib.loads(PYPROJECT.read_text())["project"]["dependencies"]


def _numbers(version: str) -> tuple[int, ...]:
    return tuple(int(p) for p in re.findall(r"\d+", version.split("+")[0])[:3])


@pytest.mark.parametrize("requirement", DEPENDENCIES)
def test_installed_version_meets_the_declared_bounds(requirement):
    # `name>=min`, or `name>=min,<max` (ml_dtypes: an upper bound for start-up time)
    match = re.fullmatch(r"([A-Za-z0-9_.-]+)>=([0-9.]+)(?:,<([0-9.]+))?", requirement)
    name, minimum, below = match.groups()
    installed = importlib.metadata.version(name)
    assert _numbers(installed) >= _numbers(minimum), f"{name} {installed} < {minimum}"
    if below is not None:
        assert _numbers(installed) < _numbers(below), f"{name} {installed} >= {below}"


def test_the_features_behind_the_bounds_exist():
    import inspect

    import jax

    assert "check_vma" in inspect.signature(jax.shard_map).parameters


def test_version_is_the_package_metadata():
    import msfd_jax

    assert msfd_jax.__version__ == importlib.metadata.version("msfd-jax")


def test_the_suite_compiles_without_the_fusion_emitters_where_xla_knows_the_flag():
    """tests/conftest.py sets the flag for this process and every process it starts; an XLA
    that no longer knows it leaves XLA's default (the suite then compiles about 2x slower)."""
    import os
    import subprocess
    import sys

    from conftest import FAST_COMPILE_FLAG

    if os.environ.get("MSFD_TEST_FUSION_EMITTERS") == "1":
        pytest.skip("MSFD_TEST_FUSION_EMITTERS=1: XLA's default asked for")
    if FAST_COMPILE_FLAG not in os.environ.get("XLA_FLAGS", ""):
        pytest.skip(f"the installed XLA refused {FAST_COMPILE_FLAG}: the suite compiles slower")
    child = subprocess.run(
        [sys.executable, "-c", "import os; print(os.environ['XLA_FLAGS'])"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert FAST_COMPILE_FLAG in child.stdout  # what a docs block or a notebook kernel sees


@pytest.fixture(scope="module")
def _module_resource():
    return object()


def test_a_test_with_a_module_fixture_runs_in_its_module_s_group(request, _module_resource):
    """conftest's collection hook: under pytest-xdist a module-scoped fixture is made once,
    by one worker, because the tests that use it run in their module's group."""
    mark = request.node.get_closest_marker("xdist_group")
    assert mark is not None and mark.args == (__name__,)


def test_a_test_without_one_is_handed_out_alone(request):
    assert request.node.get_closest_marker("xdist_group") is None
