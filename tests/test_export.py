"""Serialized programs (`msfd_jax._runtime.export`): stored, loaded, equal to the traced program.

The store is process-global state, so every test switches it on in a temporary directory
and off again (`store` fixture). The solver's program is compiled once here (about 13 s of
CPU on SMALL_MESH); the fallbacks are checked on the small critical-step program.
"""

import json
import subprocess
import sys

import equinox as eqx
import equinox._errors
import jax
import numpy as np
import pytest
from conftest import SMALL_MESH

import msfd_jax as m
from msfd_jax._model.state import critical_step
from msfd_jax._runtime import export as _export

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
from msfd_jax._runtime import export as _export
from msfd_jax._batched.simulate import _simulate, prepare

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
assert program.make_s is None  # a record without its making time (as before it was kept)
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
    # the loaded program carries what making it cost, as the exporting process measured it
    assert first.make_s > 0 and second.make_s == first.make_s
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


_SWEEP = """
import dataclasses
import json
import sys
from pathlib import Path

import equinox._errors
import jax

jax.config.update("jax_enable_x64", True)
equinox._errors.EQX_ON_ERROR = "nan"  # as the CLI, before anything is traced
import msfd_jax as m
from msfd_jax._runtime import export as _export
from msfd_jax._sweeps.sweep import SWEEP_SETTINGS

if sys.argv[1] != "-":
    _export.enable(Path(sys.argv[1]))
sources = []
compile_program = _export.compile_program


def recording(fn, *args, name):
    program = compile_program(fn, *args, name=name)
    sources.append([name, program.source, program.reason])
    return program


_export.compile_program = recording  # `_queue` and `_export.call` look it up when called
table = m.sweep(
    {"thickness_ratio": [1.0, 2.5, 4.0], "axial_constraint": [0, 1]},
    mesh=m.Mesh(6, 8, 2),
    settings=dataclasses.replace(SWEEP_SETTINGS, t_max=1.5),
    contact_smoothing=1e-3,
    workers=1,
)
columns = {
    k: [float(x) for x in v] for k, v in table.columns.items()
    if k != "wall_time_s" and getattr(v, "dtype", None) is not None and v.dtype.kind in "fiub"
}
print(json.dumps({"sources": sources, "columns": columns}))
"""


def _sweep_in_a_new_process(store) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", _SWEEP, str(store)],
        capture_output=True, text=True, timeout=900, cwd=store if store != "-" else None,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_a_sweep_stores_its_programs_and_a_new_process_loads_them(tmp_path):
    # issue 11: a new `msfd sweep` process traced the queue's programs again (its segment
    # alone, seconds per slot count); with the CLI's store they are loaded like `simulate`'s
    first = _sweep_in_a_new_process(tmp_path)
    names = {name for name, _, _ in first["sources"]}
    assert names == {
        "critical_chunk",
        "queue_segment",
        "queue_report",
        "queue_refill",
    }
    assert all(source == "exported" for _, source, _ in first["sources"]), first["sources"]
    second = _sweep_in_a_new_process(tmp_path)
    assert [n for n, _, _ in second["sources"]] == [n for n, _, _ in first["sources"]]
    assert all(source == "loaded" for _, source, _ in second["sources"]), second["sources"]
    traced = _sweep_in_a_new_process("-")  # no store: every program traced, as before
    assert all(source == "traced" for _, source, _ in traced["sources"])
    for run in (first, second):  # bitwise, every row (NaN equal to NaN)
        assert run["columns"].keys() == traced["columns"].keys()
        for key, values in traced["columns"].items():
            np.testing.assert_array_equal(run["columns"][key], values, err_msg=key)


def test_the_program_key_follows_every_layer_and_the_pruning_switch(monkeypatch):
    # a stored program must never outlive an edit of the solver: the source hash covers the
    # layers' modules (msfd_jax/_*/*.py), and the key records the pruning switch, which the
    # unpruned reference of the tests turns off
    from pathlib import Path

    from msfd_jax._batched import pruning

    root = Path(_export.__file__).parents[1]
    engine = root / "_batched" / "engine.py"
    monkeypatch.setattr(_export, "_source_hash", None)
    before = _export.source_hash()
    read = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda f: b"edited" if f == engine else read(f))
    monkeypatch.setattr(_export, "_source_hash", None)
    assert _export.source_hash() != before
    monkeypatch.undo()
    signature = ("tree", "()", "[]")
    pruned = _export._key_text("simulate", signature)
    monkeypatch.setattr(pruning, "SKIP_FAR_BLOCKS", False)
    assert _export._key_text("simulate", signature) != pruned
