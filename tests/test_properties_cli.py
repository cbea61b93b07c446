"""Property-based tests of the ``msfd run`` and ``msfd sweep`` options (issue 12 item 6).

Random text for every option (numbers, nan/inf/huge/tiny/negative, ints, ranges and lists,
empty and arbitrary strings), flags, case files, ``--from-json`` records and ``--from-csv``
tables with random content, through the in-process entry point `main`. The property: exit 0
(or 3, a solve stopped by a guard) with finite numbers; or exit 2 with one message line
(argparse's usage lines before it are allowed) that names an option given and, for a range,
states the allowed range. Never a traceback, another exit code, or a NaN in a success.

What passes the checks reaches `msfd_jax.run` (patched here): when it is the program every
test of the Python API shares (SMALL_MESH, `RUN`'s static settings), it runs for real with
RUN's small step bound; any other mesh or static setting would compile a program of its own,
so it is only checked (a valid `Mesh`/`Settings`) and not run. A sweep's solve is likewise
replaced after its input checks (the batched core would compile for tens of seconds).
"""

import contextlib
import dataclasses
import io
import json
import math
import re
import tempfile
from pathlib import Path
from unittest import mock

import jax
import numpy as np
from conftest import SMALL_MESH
from hypothesis import HealthCheck, event, example, given
from hypothesis import settings as hsettings
from hypothesis import strategies as st
from test_properties import RUN

import msfd_jax as m
from msfd_jax._sweeps import sweep as _sweep
from msfd_jax.cli import common, main
from msfd_jax.cli import sweep as cli_sweep

jax.devices()  # start the backends: --host-devices must then refuse, not set XLA_FLAGS
CLI = hsettings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))

SPECIAL = [
    "nan", "inf", "-inf", "1e400", "-1e400", "-0", "0", "1e-320", "0x10", "1_000", " 2 ",
    "", " ", "abc", "1,2", "1,,2", ",", "1:2:3", "1:2:0", "2:1:2", "1:2", "1:2:3:4", "a:b:c",
    "1:2:100000000000", "0:1:1e3", "True", "None", "[1]", "1e3", "-1e308", "١٢", "+5", "5.",
    "1e-3", "0.3", "6", "8", "2", "3", "10", "1000000000000", "-5", "0.5,0.7", "nan,1",
]  # fmt: skip
TEXT = st.one_of(
    st.sampled_from(SPECIAL),
    st.floats().map(repr),
    st.floats(1e-3, 10).map(lambda x: f"{x:g}"),
    st.integers(-10, 100).map(str),
    st.integers().map(str),
    st.text(max_size=6),
)
PATHS = st.sampled_from(["x.png", "x.pdf", "x.txt", "x", "no/dir/x.png", "x.csv", "x.parquet"])

# option -> how its value is drawn (None: a flag without a value)
RUN_OPTIONS = {
    **{flag: TEXT for flag, _ in common.PARAMS.values()},
    **{flag: TEXT for flag, _ in common.SI.values()},
    **{
        flag: TEXT
        for flag in (
            "--ring-segments", "--beam-contact-segments", "--beam-outer-segments",
            "--contact-region", "--safety", "--dt", "--t-max", "--history-points",
            "--shape-times", "--contact-smoothing", "--yield-smoothing",
        )
    },
    "--axial-constraint": st.one_of(st.none(), TEXT),
    "--no-axial-constraint": st.none(),
    "--si": st.none(),
    "--json": st.none(),
    "--plot": PATHS,
}  # fmt: skip
SWEEP_OPTIONS = {
    **{k: v for k, v in RUN_OPTIONS.items() if k not in ("--no-axial-constraint", "--json")},
    "--axial-constraint": st.one_of(st.sampled_from(["held", "free", "both"]), TEXT),
    "--chunk-size": TEXT,
    "--shard": st.none(),
    "--host-devices": TEXT,
    "--cluster": st.one_of(st.sampled_from(["local:2", "local:0", "tcp://h:1", "udp://x"]), TEXT),
    "--task-size": TEXT,
    "--workers": TEXT,
    "--resume": st.none(),
    "--json": st.none(),
    "-q": st.none(),
    **{flag: PATHS for flag in ("--csv", "--parquet", "--netcdf")},
}
# keep what passes the checks on the shared program's static settings (see the docstring)
RUN_BASE = ["--ring-segments=6", "--beam-contact-segments=8", "--beam-outer-segments=2"]
RUN_BASE += [f"--t-max={RUN.t_max}", f"--history-points={RUN.history_points}", "--shape-times="]
RUN_BASE += ["--no-cache"]

TOML_VALUE = st.one_of(
    st.integers(-10, 100),
    st.floats(),
    st.booleans(),
    st.sampled_from(SPECIAL),
    st.lists(st.one_of(st.floats(0.1, 10), st.sampled_from(SPECIAL)), max_size=3),
)
TOML_KEYS = ["velocity", "mass_ratio", "ring_segments", "t_max", "safety", "shape_times",
             "axial_constraint", "impact_speed", "density", "json", "chunk_size", "colour",
             "history_points", "quiet"]  # fmt: skip
CASE = st.dictionaries(
    st.sampled_from(["collision", "mesh", "settings", "output", "axes", "batching", "nope"]),
    st.dictionaries(st.sampled_from(TOML_KEYS), TOML_VALUE, max_size=3),
    max_size=3,
)
JSON_VALUE = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers(-10, 100) | st.text(max_size=3),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner),
    max_leaves=6,
)
RECORD = st.one_of(
    JSON_VALUE,
    st.fixed_dictionaries(
        {"params": st.one_of(JSON_VALUE, st.dictionaries(st.sampled_from(TOML_KEYS), JSON_VALUE))},
        optional={
            k: st.one_of(JSON_VALUE, st.dictionaries(st.sampled_from(TOML_KEYS), JSON_VALUE))
            for k in ("mesh", "settings", "si_inputs")
        },
    ),
)
CSV = st.one_of(
    st.text(max_size=20),
    st.lists(
        st.lists(
            st.one_of(st.sampled_from(["velocity", "mass_ratio", "colour"]), TEXT), max_size=3
        ),
        max_size=3,
    ).map(lambda rows: "\n".join(",".join(r) for r in rows)),
)


def toml(case: dict) -> str:
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return (
                "nan"
                if math.isnan(v)
                else ("inf" if v > 0 else "-inf")
                if math.isinf(v)
                else repr(v)
            )
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return json.dumps(v)

    return "".join(
        f"[{s}]\n" + "".join(f"{k} = {value(v)}\n" for k, v in table.items())
        for s, table in case.items()
    )


def options(table: dict) -> st.SearchStrategy:
    """A list of (option, value or None) drawn from `table`, in random order."""
    return st.lists(
        st.sampled_from(sorted(table)).flatmap(lambda k: st.tuples(st.just(k), table[k])),
        max_size=5,
    )


class Accepted(Exception):
    """Raised by the patched solve: the input passed every check."""


def check_exit(code: int, out: str, err: str, given: list[str]) -> None:
    """The CLI property for one call: see the module docstring."""
    assert code in (0, 2, 3), (code, err)
    assert "Traceback" not in err, err
    if code == 2:
        lines = err.strip().splitlines()
        assert lines, "a refusal must say why"
        if lines[0].startswith("usage:"):  # argparse: usage, then its one error line
            lines = lines[-1:]
        assert len(lines) == 1, err
        line = lines[0]
        assert line.startswith("msfd") and "error" in line, line
        names = {n for flag in given for n in (flag, flag.lstrip("-").replace("-", "_"))}
        if {"case file", "--from-json", "--from-csv"} & set(given):  # a file can set any
            names |= {*common.OPTION_NAMES, *common.OPTION_NAMES.values()}
        assert any(n in line for n in names if n), f"{line!r} names none of {sorted(names)}"
        if "out of range" in line or "must be finite" in line:
            assert "allowed" in line, line
        if "--json" not in given:
            assert out == "", out
    if code == 0:
        assert not re.search(r"\bnan\b", out, re.IGNORECASE), out


def call(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


PATH_OPTIONS = ("--plot", "--csv", "--parquet", "--netcdf")


def argv_of(drawn, tmp: str) -> tuple[list[str], list[str]]:
    """The command line of `drawn`; path options point into the temporary directory `tmp`."""
    argv, given = [], []
    for flag, value in drawn:
        if flag in PATH_OPTIONS:
            value = f"{tmp}/{value}"
        argv.append(flag if value is None else f"{flag}={value}")
        given.append(flag)
    return argv, given


def real_or_checked_run(params, mesh, settings, **kwargs):
    """`m.run` on the shared program when the input is on it; else only type-checked."""
    assert isinstance(params, m.CollisionParams) and isinstance(mesh, m.Mesh)
    assert isinstance(settings, m.Settings)
    m.validate(params, mesh)
    static = (settings.history_points, settings.shape_times, settings.dt)
    shared = (RUN.history_points, RUN.shape_times, None)
    if mesh != SMALL_MESH or kwargs.get("scales") is not None or static != shared:
        raise Accepted
    return REAL_RUN(params, mesh, dataclasses.replace(settings, max_steps=RUN.max_steps), **kwargs)


REAL_RUN = m.run


@CLI
@given(drawn=options(RUN_OPTIONS), files=st.tuples(CASE, RECORD), use=st.sampled_from("-cj"))
# what the properties found (each was a traceback or a message naming no option given)
@example(drawn=[], files=({}, {"params": [], "mesh": None}), use="j")
@example(drawn=[], files=({}, {"params": {}, "si_inputs": 1.0}), use="j")
@example(drawn=[], files=({}, {"params": {"velocity": [1.0, 2.0]}}), use="j")
@example(drawn=[], files=({}, {"params": {}, "settings": {"colour": 1}}), use="j")
@example(drawn=[], files=({"output": {"json": 0}}, None), use="c")
@example(drawn=[("--plot", "x.txt")], files=({}, None), use="-")
@example(drawn=[("--contact-region", "3.0")], files=({}, None), use="-")
@example(drawn=[("--beam-half-span", "0.9"), ("--si", None)], files=({}, None), use="-")
def test_msfd_run_options_run_or_exit_2_naming_the_option(drawn, files, use):
    with tempfile.TemporaryDirectory() as tmp:
        argv, given = argv_of(drawn, tmp)
        extra = []
        if use == "c":  # a case file
            path = Path(tmp) / "case.toml"
            path.write_text(toml(files[0]))
            extra, given = [str(path)], [*given, "case file"]
        elif use == "j":  # a --from-json record
            path = Path(tmp) / "out.json"
            path.write_text(json.dumps(files[1]))
            extra, given = [f"--from-json={path}"], [*given, "--from-json"]
        with mock.patch.object(m, "run", real_or_checked_run):
            try:
                code, out, err = call(["run", *extra, *RUN_BASE, *argv])
            except Accepted:
                event("accepted, not run (its own program)")
                return
    event(f"exit {code}")
    check_exit(code, out, err, given)
    if code == 0 and "--json" in given:
        record = json.loads(out)
        assert record["ok"] and record["status"] in ("settled", "time limit"), record
        numbers = [*record["fractions"].values(), record["energy_balance_error"]]
        assert all(isinstance(x, float) and math.isfinite(x) for x in numbers), record


def checked_solve(columns, mesh, settings, **kwargs):
    """The sweep's solve after its own input checks: the columns must be valid by now."""
    m.validate(m.CollisionParams(**{k: columns[k] for k in _sweep.INPUTS}), mesh)
    assert all(np.all(np.isfinite(np.asarray(v, float))) for v in columns.values())
    raise Accepted


def connect(spec, *args, **kwargs):
    raise Accepted  # a well-formed --cluster: no Dask cluster is started here


@CLI
@given(drawn=options(SWEEP_OPTIONS), files=st.tuples(CASE, CSV), use=st.sampled_from("-cv"))
@example(drawn=[], files=({}, ""), use="v")
@example(drawn=[], files=({}, "velocity\n"), use="v")
@example(drawn=[], files=({}, "velocity,mass_ratio\n1.0\n"), use="v")
@example(drawn=[], files=({}, "velocity\nfast\n"), use="v")
@example(drawn=[], files=({}, "colour\nred\n"), use="v")
@example(drawn=[("--beam-half-span", "nan"), ("--mass-ratio", "nan")], files=({}, ""), use="-")
@example(drawn=[("--velocity", "0:1:100000000000")], files=({}, ""), use="-")
@example(drawn=[("--velocity", "0:1:2000"), ("--mass-ratio", "1:2:2000")], files=({}, ""), use="-")
def test_msfd_sweep_options_run_or_exit_2_naming_the_option(drawn, files, use):
    with tempfile.TemporaryDirectory() as tmp:
        argv, given = argv_of(drawn, tmp)
        extra = []
        if use == "c":
            path = Path(tmp) / "case.toml"
            path.write_text(toml(files[0]))
            extra, given = [str(path)], [*given, "case file"]
        elif use == "v":
            path = Path(tmp) / "in.csv"
            path.write_text(files[1])
            extra, given = [f"--from-csv={path}"], [*given, "--from-csv"]
        with (
            mock.patch.object(_sweep, "solve_collisions", checked_solve),
            mock.patch.object(cli_sweep._cluster, "connect", connect),
        ):
            try:
                code, out, err = call(["sweep", *extra, "--no-cache", "-q", *argv])
            except Accepted:
                event("accepted (solve replaced)")
                return
    event(f"exit {code}")
    check_exit(code, out, err, given)
