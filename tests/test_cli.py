"""The ``msfd`` command line: JSON and table output, plots, exit codes, compile cache.

Every run here uses conftest's SMALL_MESH and SHORT settings (same static structure), so the
solver compiles once for this file and is shared with the other tests. ``--no-cache`` keeps
the persistent compile cache (global JAX state) out of the other tests; it has its own test.
"""

import contextlib
import io
import json

import equinox._errors
import jax
import pytest

import msfd_jax as m
from msfd_jax import _export
from msfd_jax.cli import enable_compilation_cache, main

SMALL = [
    "--ring-segments=6",
    "--beam-contact-segments=8",
    "--beam-outer-segments=2",
    "--t-max=1.5",
    "--history-points=31",
    "--shape-times=0.5",
    "--no-cache",
]


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
    record = json.loads(json_record)  # fails on anything else printed on stdout
    assert set(m.FRACTION_KEYS) <= set(record["fractions"])
    for key in ("energy_balance_error", "t_end", "steps", "wall_time_s"):
        assert key in record
    assert record["steps"] > 0 and 0 < record["t_end"] <= 1.5


def test_json_fractions_close_the_energy_balance(json_record):
    record = json.loads(json_record)
    total = sum(record["fractions"].values())
    assert abs(total - 1.0 - record["energy_balance_error"]) < 1e-9
    assert abs(record["energy_balance_error"]) < 1e-2


def test_json_defaults_are_the_showcase(json_record):
    params = json.loads(json_record)["params"]
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
