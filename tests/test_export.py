"""Serialized programs (`msfd_jax._export`): stored, loaded, equal to the traced program.

The store is process-global state, so every test switches it on in a temporary directory
and off again (`store` fixture). The solver's program is compiled once here (about 13 s of
CPU on SMALL_MESH); the fallbacks are checked on the small critical-step program.
"""

import subprocess
import sys

import equinox as eqx
import equinox._errors
import jax
import numpy as np
import pytest
from conftest import SMALL_MESH

import msfd_jax as m
from msfd_jax import _export
from msfd_jax._dynamics import critical_step

_critical = eqx.filter_jit(critical_step)


@pytest.fixture
def store(tmp_path, monkeypatch):
    # as the CLI: equinox's runtime checks as NaN, not host callbacks (which cannot export)
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    before = _export.store()
    _export.enable(tmp_path)
    yield tmp_path
    _export.enable(before)


@pytest.fixture(scope="module")
def scene():
    return m.ring_on_beam(m.CollisionParams(thickness_ratio=1.5), SMALL_MESH)


def _assert_same(a, b):
    assert jax.tree_util.tree_structure(a) == jax.tree_util.tree_structure(b)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))  # the same program: bitwise


_SOLVER_ROUND_TRIP = """
import sys
from pathlib import Path

import equinox._errors
import jax
import numpy as np

jax.config.update("jax_enable_x64", True)
equinox._errors.EQX_ON_ERROR = "nan"  # as the CLI, before anything is traced
import msfd_jax as m
from msfd_jax import _export
from msfd_jax._simulate import _simulate, prepare

store = Path(sys.argv[1])
_export.enable(store)
mesh = m.Mesh(6, 8, 2)
scene = m.ring_on_beam(m.CollisionParams(thickness_ratio=1.5), mesh)
args = prepare(scene, m.Settings(t_max=1.5, history_points=31, shape_times=(0.5,)))
dynamic, rebuild, signature = _export._dynamic(args)
key = _export._key_text("simulate", signature)
# store without compiling (export only traces), then load
exported, template = _export._export(_simulate, dynamic, rebuild)
path = store / "simulate-test.jaxexport"
_export._save(path, key, bytes(exported.serialize()), template)
assert _export._load(path, key) is not None and _export._load(path, key + "x") is None
path.rename(_export._path("simulate", key))
program = _export.compile_program(_simulate, *args, name="simulate")
assert program.source == "loaded", program.reason
solution = program(*args)
traced = _simulate(*args)
assert jax.tree_util.tree_structure(solution) == jax.tree_util.tree_structure(traced)
for x, y in zip(jax.tree_util.tree_leaves(solution), jax.tree_util.tree_leaves(traced)):
    np.testing.assert_array_equal(np.asarray(x), np.asarray(y))  # the same program: bitwise
assert isinstance(solution, m.Solution) and int(solution.steps) > 0
print("round trip ok")
"""


def test_a_stored_solver_program_loads_and_equals_the_traced_one(tmp_path):
    # in a fresh process, as the CLI runs it: equinox's checks are switched to NaN before
    # anything is traced. In this process a solver trace cached by an earlier test holds
    # their host callbacks, which cannot be exported (the store then traces: correct, but
    # not what this test is about).
    done = subprocess.run(
        [sys.executable, "-c", _SOLVER_ROUND_TRIP, str(tmp_path)],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0 and "round trip ok" in done.stdout, done.stderr[-3000:]


def test_small_program_round_trip_and_fallbacks(store, scene, monkeypatch):
    traced = _critical(scene)
    first = _export.compile_program(_critical, scene, name="critical_step")
    assert first.source == "exported" and len(list(store.glob("critical_step-*"))) == 1
    second = _export.compile_program(_critical, scene, name="critical_step")
    assert second.source == "loaded"
    _assert_same(first(scene), traced)
    _assert_same(second(scene), traced)
    # an edited source is another key: traced and stored anew, never the old program
    monkeypatch.setattr(_export, "_source_hash", "edited")
    edited = _export.compile_program(_critical, scene, name="critical_step")
    assert edited.source == "exported" and len(list(store.glob("critical_step-*"))) == 2
    _assert_same(edited(scene), traced)
    # a file that does not read back (truncated, foreign) is replaced, not trusted
    for path in store.glob("critical_step-*"):
        path.write_bytes(b"not a program")
    broken = _export.compile_program(_critical, scene, name="critical_step")
    assert broken.source == "exported"
    _assert_same(broken(scene), traced)


def test_without_a_store_or_exportable_program_it_traces(store, scene, monkeypatch):
    _export.enable(None)
    assert _export.compile_program(_critical, scene, name="critical_step").source == "traced"
    _export.enable(store)
    # equinox's default checks are host callbacks: export refuses them, tracing serves
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "raise")

    @jax.jit
    def checked(x):
        return eqx.error_if(x, x < 0, "negative")

    program = _export.compile_program(checked, jax.numpy.ones(3), name="checked")
    assert program.source == "traced" and "export failed" in program.reason
    np.testing.assert_array_equal(program(jax.numpy.ones(3)), np.ones(3))


def test_call_memoises_and_steps_aside_under_transformations(store, scene):
    assert float(_export.call(_critical, scene, name="critical_step")) == float(_critical(scene))
    assert len(_export._programs) == 1
    _export.call(_critical, scene, name="critical_step")
    assert len(_export._programs) == 1  # the same program, not a second load
    # under jit the arguments are tracers: plain `fn(*args)`, nothing stored
    value = jax.jit(lambda s: _export.call(_critical, s, name="critical_step"))(scene)
    assert float(value) == float(_critical(scene)) and len(_export._programs) == 1
