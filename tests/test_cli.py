"""The ``msfd`` command line: JSON and table output, plots, exit codes, compile cache.

Every run here uses conftest's SMALL_MESH and SHORT settings (same static structure), so the
solver compiles once for this file and is shared with the other tests. ``--no-cache`` keeps
the persistent compile cache (global JAX state) out of the other tests; it has its own test.
"""

import contextlib
import io
import json
import re
from pathlib import Path

import equinox._errors
import jax
import numpy as np
import pytest

import msfd_jax as m
from msfd_jax._runtime import export as _export
from msfd_jax.cli import enable_compilation_cache, main
from msfd_jax.cli.common import dumps

SMALL = [
    "--ring-segments=6",
    "--beam-contact-segments=8",
    "--beam-outer-segments=2",
    "--t-max=1.5",
    "--history-points=31",
    "--shape-times=0.5",
    "--no-cache",
]


def strict_json(text: str):
    """Parse `text` as strict JSON: the bare NaN, Infinity, -Infinity of Python's json are
    refused (a strict parser, as in a browser or jq, refuses them too)."""

    def refuse(constant: str):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def _msfd(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["run", *SMALL, *args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def json_record():
    """One ``msfd run --json`` (stdout captured by hand: capsys is function-scoped)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["run", *SMALL, "--json"])
    assert code == 0, err.getvalue()
    return out.getvalue()


def test_json_is_one_object_with_the_required_keys(json_record):
    record = strict_json(json_record)  # fails on anything else printed on stdout
    assert set(m.FRACTION_KEYS) <= set(record["fractions"])
    for key in ("energy_balance_error", "t_end", "steps", "wall_time_s"):
        assert key in record
    assert record["steps"] > 0 and 0 < record["t_end"] <= 1.5


def test_json_fractions_close_the_energy_balance(json_record):
    record = strict_json(json_record)
    total = sum(record["fractions"].values())
    assert abs(total - 1.0 - record["energy_balance_error"]) < 1e-9
    assert abs(record["energy_balance_error"]) < 1e-2


def test_json_defaults_are_the_showcase(json_record):
    params = strict_json(json_record)["params"]
    assert params["thickness_ratio"] == 2.5 and params["mass_ratio"] == 10.0
    assert params["velocity"] == 0.82 and params["axial_constraint"] == 1.0


def test_table(capsys):
    code, out, err = _msfd(capsys)
    assert code == 0, err
    for text in ("beam_bending", "ring_bending", "%", "energy balance error", "dt_crit", "status"):
        assert text in out
    assert "compiling" in err or "compiles" in err


def test_si_input_prints_the_time_scale(capsys):
    code, out, err = _msfd(capsys, "--si")
    assert code == 0, err
    assert "time T" in out and "K0 " in out and "kJ" in out
    # The paper's SI base case is the non-dimensional showcase.
    assert "h_b/h_r = 2.5" in out and "g = 10," in out


def test_plot_writes_a_png(capsys, tmp_path):
    path = tmp_path / "collision.png"
    code, _, err = _msfd(capsys, "--plot", str(path))
    assert code == 0, err
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args, name",
    [
        (["--thickness-ratio", "-1"], "thickness"),
        (["--thickness-ratio", "nan"], "thickness"),
        (["--thickness-ratio", "1e9"], "thickness"),
        (["--ring-segments", "1"], "ring"),
        (["--frobnicate"], "frobnicate"),
        (["--mass-ratio", "abc"], "mass-ratio"),
        (["--span-ratio", "1.0"], "span"),
        (["--safety", "0"], "safety"),
        (["--t-max", "1.0", "--shape-times", "2.0"], "shape_times"),
        (["--contact-smoothing", "-1"], "contact_smoothing"),
        (["--si", "--density", "-1"], "density"),
        (["--si", "--thickness-ratio", "2"], "thickness"),
    ],
)
def test_bad_input_exits_2_naming_the_parameter(capsys, args, name):
    code, out, err = _msfd(capsys, *args)
    assert code == 2
    assert out == ""
    assert name in err and "error" in err
    assert "Traceback" not in err


def test_failed_solve_exits_3(capsys, monkeypatch):
    # The CLI's handling of a failed solve is what is tested here (a real blow-up, e.g.
    # --safety 4, changes the static step bound and would compile a second program).
    def fail(*args, **kwargs):
        raise m.SimulationError("the solve became non-finite at tau = 0.01; remedy: --safety")

    monkeypatch.setattr(m, "run", fail)
    code, out, err = _msfd(capsys)
    assert code == 3
    assert out == ""
    assert "non-finite" in err and "--safety" in err
    assert "Traceback" not in err


def test_help_exits_0(capsys):
    assert main(["run", "--help"]) == 0
    assert "--thickness-ratio" in capsys.readouterr().out


def test_compilation_cache_follows_msfd_cache_dir(monkeypatch, tmp_path):
    monkeypatch.setenv("MSFD_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("EQX_ON_ERROR", raising=False)
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", equinox._errors.EQX_ON_ERROR)
    names = (
        "jax_compilation_cache_dir",
        "jax_persistent_cache_min_compile_time_secs",
        "jax_persistent_cache_min_entry_size_bytes",
    )
    before = {n: getattr(jax.config, n) for n in names}
    store = _export.store()
    try:
        assert enable_compilation_cache() == tmp_path
        assert jax.config.jax_compilation_cache_dir == str(tmp_path)
        assert jax.config.jax_persistent_cache_min_compile_time_secs == 0
        # Host callbacks keep executables out of the cache (see enable_compilation_cache).
        assert equinox._errors.EQX_ON_ERROR == "nan"
        # serialized programs beside the compiled ones (tests/test_export.py)
        assert _export.store() == tmp_path / "exported"
    finally:
        for n, v in before.items():
            jax.config.update(n, v)
        _export.enable(store)


def test_strict_json_refuses_nan():
    with pytest.raises(ValueError, match="NaN"):
        strict_json('{"settings_dt": NaN}')
    assert strict_json(dumps({"a": float("nan"), "b": [float("inf")]})) == {
        "a": None,
        "b": [None],
    }
    with pytest.raises(ValueError):  # a NaN that gets past the conversion raises, not written
        dumps(object(), default=lambda _: float("nan"))


def test_bad_input_json_record_is_strict_json(capsys):
    code, out, _ = _msfd(capsys, "--thickness-ratio", "nan", "--json")
    assert code == 2
    record = strict_json(out)
    assert record["ok"] is False and record["status"] == "bad input"


def _nan_rows(*args, **kwargs):
    nan = float("nan")
    row = {"name": "x", "verdict": "as expected", "method": "verlet", "ok": True}
    return [{**row, "energy_balance_error": nan, "t": [nan]}]


@pytest.mark.parametrize("study", ["stability", "accuracy"])
def test_bench_json_is_strict_when_a_number_is_missing(capsys, monkeypatch, study):
    """A study's row with a NaN (a failed run's error, say) prints as null, not NaN."""
    from msfd_jax.cli import common
    from msfd_jax.studies import accuracy, stability

    monkeypatch.setattr(common, "enable_compilation_cache", lambda: None)
    monkeypatch.setattr(stability, "run_catalogue", _nan_rows)
    monkeypatch.setattr(accuracy, "study", lambda *a, **k: {"rows": _nan_rows(), "t": np.nan})
    code = main(["bench", study, "--quick", "--json"])
    record = strict_json(capsys.readouterr().out)
    assert code in (0, 1)
    assert record["rows"][0]["energy_balance_error"] is None


# Modules that write JSON a user reads: every one goes through `_provenance.dumps` (strict).
# stability.py's json.dumps is a child process's row, read back by json.loads, never shown.
# PENDING: not yet converted by their owners (issue 28 item 5); remove them when they are.
JSON_WRITERS_EXEMPT = {"msfd_jax/_collision/provenance.py", "msfd_jax/studies/stability.py"}
PENDING = {"optimise/_cli.py"}  # strict already: allow_nan=False raises on a NaN


def test_every_json_writer_is_strict():
    root = Path(__file__).resolve().parent.parent
    sources = [*root.joinpath("msfd_jax").rglob("*.py"), *root.joinpath("optimise").rglob("*.py")]
    lax = {
        path.relative_to(root).as_posix()
        for path in sources
        if "scripts" not in path.parts and re.search(r"\bjson\.dumps?\(", path.read_text())
    }
    assert lax - JSON_WRITERS_EXEMPT - PENDING == set()


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_beam_width_help_states_its_default_once(capsys, command):
    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    assert text.count("the ring width") == 1, "--beam-width states its default twice"


def test_bench_help_lists_every_study(capsys):
    from msfd_jax.cli import bench

    assert main(["--help"]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if s.strip().startswith("bench"))
    assert main(["bench", "--help"]) == 0
    text = capsys.readouterr().out
    for study in bench.BENCHES:
        assert study in line and study in text
    assert "default: none" not in text


def test_a_fold_has_its_own_result_code():
    """A run stopped by a fold (balance closed) is not "energy balance broken" (issue 28)."""
    assert m.RESULTS(5) is m.RESULTS.folded and m.RESULTS.folded.failed
    assert m.RESULTS.folded.status == "folded" and "pi" in m.RESULTS.folded.message
    assert [int(r) for r in m.RESULTS][:5] == [0, 1, 2, 3, 4]  # the output format kept
