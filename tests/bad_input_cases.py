"""Every invalid input tried through the Python API and the CLI, and what the user is told.

Issue 5 item 3. Each case is one user action (an expression, or an ``msfd`` command line);
running it records the exception (or exit code) and the exact message, and classifies it:

- **refused**: a ValueError/TypeError (CLI: exit code 2, or 3 for a solve stopped by a guard)
  whose message names the parameter and, where it has one, the allowed range;
- **not refused**: accepted (a value that means nothing was taken), a raw error from inside
  numpy/jax/diffrax, or a message that does not say which input is wrong. These are the
  `GAP` cases; tests/test_bad_input.py marks them xfail(strict), so fixing one makes that test
  pass unexpectedly and fail, which asks for this table to be regenerated.

Inputs that are accepted at construction but only fail later are carried to the point where
the user meets them (``m.run`` on the small mesh), so the table shows what is finally said.

Usage: ``python tests/bad_input_cases.py [--out docs/bad_input.md]``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import math
import platform
import sys
import time
import traceback
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import msfd_jax as m  # noqa: E402
from msfd_jax.cli import main as msfd_main  # noqa: E402

SMALL = m.Mesh(6, 8, 2)  # tests/conftest.py SMALL_MESH: shares the compiled program
SHORT = dict(t_max=1.5, history_points=31, shape_times=(0.5,))  # conftest SHORT
CLI_SMALL = [
    "--ring-segments=6",
    "--beam-contact-segments=8",
    "--beam-outer-segments=2",
    "--t-max=1.5",
    "--history-points=31",
    "--shape-times=0.5",
    "--no-cache",
]
NAMESPACE = dict(m=m, math=math, P=m.CollisionParams, SMALL=SMALL, SHORT=SHORT)


@dataclasses.dataclass(frozen=True)
class Case:
    """One invalid input.

    **Arguments:**
    - `code`: a Python expression (namespace `NAMESPACE`) or, for the CLI, the arguments
      after ``msfd`` (the small-mesh options are appended for ``run``).
    - `parameter`: what the message must name (CLI: the option).
    - `allowed`: text of the allowed range the message must contain (None: no range applies).
    - `error`: the expected exception type (Python) or exit code (CLI).
    - `gap`: why this case is not refused cleanly (None when it is).
    """

    code: str
    parameter: str
    allowed: str | None
    error: type[Exception] | int = ValueError
    gap: str | None = None

    @property
    def cli(self) -> bool:
        return isinstance(self.error, int)

    @property
    def id(self) -> str:
        return ("msfd " if self.cli else "") + self.code


RANGE = {
    "thickness_ratio": "(0, 100]",
    "modulus_ratio": "(1, 1e+07]",
    "slenderness": "[2, 10000]",
    "mass_ratio": "[0, 1e+07]",
    "velocity": "(0, 1000]",
    "width_ratio": "(0, 100]",
    "axial_constraint": "[0, 1]",
    "span_ratio": "(2, 10000]",
    "smoothing": "[0, 1000]",
    "si": "(0, inf)",
}
_C = Case
_SETTINGS_RUN = "m.run(P(), SMALL, m.Settings(**{**SHORT, %s})).status"
CASES: tuple[Case, ...] = (
    # --- CollisionParams: each group in its range (Eq. 1) ---
    _C("P(thickness_ratio=-1.0)", "thickness_ratio", RANGE["thickness_ratio"]),
    _C("P(thickness_ratio=0.0)", "thickness_ratio", RANGE["thickness_ratio"]),
    _C("P(modulus_ratio=1.0)", "modulus_ratio", RANGE["modulus_ratio"]),
    _C("P(modulus_ratio=math.nan)", "modulus_ratio", RANGE["modulus_ratio"]),
    _C("P(slenderness=math.inf)", "slenderness", RANGE["slenderness"]),
    _C("P(slenderness=1.0)", "slenderness", RANGE["slenderness"]),
    _C("P(mass_ratio=-1.0)", "mass_ratio", RANGE["mass_ratio"]),
    _C("P(velocity=0.0)", "velocity", RANGE["velocity"]),
    _C("P(velocity=-math.inf)", "velocity", RANGE["velocity"]),
    _C("P(velocity=2000.0)", "velocity", RANGE["velocity"]),
    _C("P(width_ratio=0.0)", "width_ratio", RANGE["width_ratio"]),
    _C("P(axial_constraint=2.0)", "axial_constraint", RANGE["axial_constraint"]),
    _C("P(mass_ratio='ten')", "mass_ratio", "real number", TypeError),
    _C("P(velocity=None)", "velocity", "real number", TypeError),
    _C("P(velocity=1 + 1j)", "velocity", "real number", TypeError),
    _C("P(velocity=[1.0, -2.0])", "velocity", RANGE["velocity"]),
    _C("P(speed=1.0)", "speed", None, TypeError),
    _C("m.ring_on_beam(P(span_ratio=math.nan), SMALL)", "span_ratio", RANGE["span_ratio"]),
    _C("m.ring_on_beam(P(span_ratio=1.5), SMALL)", "span_ratio", RANGE["span_ratio"]),
    _C("m.ring_on_beam(P(), m.Mesh(6, 8, 2, 5.0))", "span_ratio", "(5, 10000]"),
    _C(
        "m.run(P(axial_constraint=0.5), SMALL, m.Settings(**SHORT)).status",
        "axial_constraint",
        "0 or 1",
    ),
    _C(
        "P(velocity=True).velocity",
        "velocity",
        "real number",
        TypeError,
    ),
    _C(
        "P(mass_ratio='10').mass_ratio",
        "mass_ratio",
        "real number",
        TypeError,
    ),
    _C(
        "m.run(P(velocity=[1.0, 2.0]), SMALL, m.Settings(**SHORT))",
        "velocity",
        "single value",
    ),
    # --- Mesh: counts are static integers ---
    _C("m.Mesh(0, 8, 2)", "ring_segments", ">= 3"),
    _C("m.Mesh(2, 8, 2)", "ring_segments", ">= 3"),
    _C("m.Mesh(6, 1, 2)", "beam_contact_segments", ">= 2"),
    _C("m.Mesh(6, 8, 0)", "beam_outer_segments", ">= 1"),
    _C("m.Mesh(6.5, 8, 2)", "ring_segments", ">= 3", TypeError),
    _C("m.Mesh(True, 8, 2)", "ring_segments", ">= 3", TypeError),
    _C("m.Mesh('6', 8, 2)", "ring_segments", ">= 3", TypeError),
    _C("m.Mesh(6, 8, 2, 0.0)", "contact_region", "(0, 1000]"),
    _C("m.Mesh(6, 8, 2, math.nan)", "contact_region", "(0, 1000]"),
    _C("m.Mesh(segments=6)", "segments", None, TypeError),
    _C(
        "m.run(P(), m.Mesh(6, 8, 2, '2'), m.Settings(**SHORT))",
        "contact_region",
        "real number",
        TypeError,
    ),
    # --- from_si: SI inputs ---
    _C("m.from_si(**{**m.PAPER_SI, 'youngs_modulus': -1.0})", "youngs_modulus", RANGE["si"]),
    _C("m.from_si(**{**m.PAPER_SI, 'density': 0.0})", "density", RANGE["si"]),
    _C("m.from_si(**{**m.PAPER_SI, 'radius': math.nan})", "radius", RANGE["si"]),
    _C("m.from_si(**{**m.PAPER_SI, 'ring_thickness': math.inf})", "ring_thickness", RANGE["si"]),
    _C("m.from_si(**{**m.PAPER_SI, 'block_mass': -1.0})", "block_mass", "[0, inf)"),
    _C(
        "m.from_si(**{**m.PAPER_SI, 'impact_speed': 'fast'})",
        "impact_speed",
        "real number",
        TypeError,
    ),
    _C("m.from_si(**{**m.PAPER_SI, 'youngs_modulus': 1e8})", "modulus_ratio", "(1, 1e+07]"),
    _C(
        "m.ring_on_beam(m.from_si(**{**m.PAPER_SI, 'beam_half_span': 0.5})[0], SMALL)",
        "span_ratio",
        RANGE["span_ratio"],
    ),
    _C("m.from_si(**{**m.PAPER_SI, 'colour': 1})", "colour", None, TypeError),
    _C(
        "m.from_si(**{k: v for k, v in m.PAPER_SI.items() if k != 'radius'})",
        "radius",
        None,
        TypeError,
    ),
    # --- Settings ---
    _C("m.Settings(safety=0.0)", "safety", "allowed (0,"),
    _C("m.Settings(safety=-1.0)", "safety", "allowed (0,"),
    _C("m.Settings(safety=math.nan)", "safety", "allowed (0,"),
    _C("m.Settings(dt=0.0)", "dt", "allowed (0,"),
    _C("m.Settings(dt=-1e-3)", "dt", "allowed (0,"),
    _C("m.Settings(dt=math.inf)", "dt", "allowed (0,"),
    _C("m.Settings(t_max=0.0)", "t_max", "allowed (0,"),
    _C("m.Settings(t_max=math.inf)", "t_max", "allowed (0,"),
    _C("m.Settings(settle_window=0.0)", "settle_window", "allowed (0,"),
    _C("m.Settings(energy_guard=0.0)", "energy_guard", "allowed (0,"),
    _C("m.Settings(shape_times=(-0.1,))", "shape_times", "allowed [0,"),
    _C("m.Settings(shape_times=(math.nan,))", "shape_times", "allowed [0,"),
    _C("m.Settings(history_points=1)", "history_points", ">= 2"),
    _C("m.Settings(substeps=0)", "substeps", ">= 1"),
    _C("m.Settings(substeps=2.0)", "substeps", ">= 1", TypeError),
    _C("m.Settings(contact_loop='pruned')", "contact_loop", "'blocks', 'listed', 'dense'"),
    _C("m.Settings(tmax=1.0)", "tmax", None, TypeError),
    _C(
        "m.run(P(), SMALL, m.Settings(safety=10.0, **SHORT))",
        "safety",
        "stability limit",
        m.SimulationError,
    ),
    _C(
        "m.Settings(safety='0.5')",
        "safety",
        "real number",
        TypeError,
    ),
    _C(
        "m.Settings(safety=None)",
        "safety",
        "real number",
        TypeError,
    ),
    _C(
        "m.Settings(dt='1e-3')",
        "dt",
        "real number",
        TypeError,
    ),
    _C(
        "m.Settings(t_min=-1.0).t_min",
        "t_min",
        "allowed [0,",
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(t_min=math.nan, **SHORT)).status",
        "t_min",
        "allowed [0,",
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(settle_tolerance=math.nan, **SHORT)).status",
        "settle_tolerance",
        "allowed [0, 1]",
    ),
    _C(
        "m.Settings(settle_tolerance=-1.0).settle_tolerance",
        "settle_tolerance",
        "allowed [0, 1]",
    ),
    _C(
        "m.Settings(shape_times=0.5)",
        "shape_times",
        "tuple",
        TypeError,
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(t_max=1.5, history_points=10.5, shape_times=(0.5,)))",
        "history_points",
        ">= 2",
        TypeError,
    ),
    _C(
        "m.Settings(history_points='10')",
        "history_points",
        ">= 2",
        TypeError,
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(max_steps=0, **SHORT))",
        "max_steps",
        ">= 1",
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(max_steps=-5, **SHORT))",
        "max_steps",
        ">= 1",
    ),
    _C(
        "m.Settings(stop_when_settled='no').stop_when_settled",
        "stop_when_settled",
        "True or False",
        TypeError,
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(**{**SHORT, 't_max': 1e9}))",
        "t_max",
        "allowed",
    ),
    # --- scene builders ---
    _C("m.ring_on_beam(P(), SMALL, contact_smoothing=-0.1)", "contact_smoothing", "[0, 1000]"),
    _C("m.ring_on_beam(P(), SMALL, contact_smoothing=math.nan)", "contact_smoothing", "[0, 1000]"),
    _C(
        "m.ring_on_beam(P(), SMALL, contact_smoothing=None)",
        "contact_smoothing",
        "real number",
        TypeError,
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(**SHORT), yield_smoothing=-1.0)",
        "yield_smoothing",
        "[0, 1000]",
    ),
    _C("m.ring_on_beam(P(), SMALL, smoothing=0.1)", "smoothing", None, TypeError),
    _C(
        "m.ring_on_beam(P(), SMALL, contact_smoothing='0.1').contact_smoothing",
        "contact_smoothing",
        "real number",
        TypeError,
    ),
    _C(
        "m.run(P(), SMALL, m.Settings(**SHORT), contact_smoothing=[0.1, 0.2])",
        "contact_smoothing",
        "single value",
    ),
    _C(
        "m.ring_on_beam({'velocity': 1.0}, SMALL)",
        "params",
        "CollisionParams",
        TypeError,
    ),
    _C("m.cantilever_tip_mass(mass_ratio=-1.0)", "mass_ratio", "(0, 1e+07]"),
    _C("m.cantilever_tip_mass(velocity=math.nan)", "velocity", "(0, 1e+07]"),
    _C("m.cantilever_tip_mass(modulus_ratio=0.0)", "modulus_ratio", "(0, 1e+07]"),
    _C("m.cantilever_tip_mass(slenderness=1.0)", "slenderness", "[2, 10000]"),
    _C("m.cantilever_tip_mass(segments=1)", "segments", ">= 2"),
    _C("m.cantilever_tip_mass(segments=4.0)", "segments", ">= 2", TypeError),
    _C("m.cantilever_tip_mass(length=2.0)", "length", None, TypeError),
    # --- m.run's own arguments ---
    _C("m.run(P(), SMALL, safety=0.5)", "safety", None, TypeError),
    _C(
        "m.run(P(), SMALL, 'fast')",
        "settings",
        "Settings",
        TypeError,
    ),
    _C(
        "m.run(P(), (6, 8, 2))",
        "mesh",
        "Mesh",
        TypeError,
    ),
    # --- CLI: msfd run (exit 2: bad input; 3: solve stopped) ---
    _C("run --velocity=-1", "--velocity", RANGE["velocity"], 2),
    _C("run --velocity=nan", "--velocity", RANGE["velocity"], 2),
    _C("run --velocity=abc", "--velocity", None, 2),
    _C("run --mass-ratio=inf", "--mass-ratio", RANGE["mass_ratio"], 2),
    _C("run --span-ratio=1.5", "--span-ratio", RANGE["span_ratio"], 2),
    _C("run --ring-segments=2", "--ring-segments", ">= 3", 2),
    _C("run --ring-segments=2.5", "--ring-segments", None, 2),
    _C("run --contact-region=0", "--contact-region", "(0, 1000]", 2),
    _C("run --safety=0", "--safety", "allowed (0,", 2),
    _C("run --safety=10", "--safety", "stability limit", 3),
    _C("run --dt=-1e-3", "--dt", "allowed (0,", 2),
    _C("run --dt=inf", "--dt", "allowed (0,", 2),
    _C(
        "run --t-max=0",
        "--t-max",
        "allowed (0,",
        2,
    ),
    _C("run --history-points=1", "--history-points", ">= 2", 2),
    _C("run --shape-times=-1", "--shape-times", "allowed [0,", 2),
    _C("run --shape-times=5", "--shape-times", "[0, t_max", 2),
    _C("run --shape-times=a,b", "--shape-times", None, 2),
    _C("run --contact-smoothing=nan", "--contact-smoothing", "[0, 1000]", 2),
    _C("run --yield-smoothing=-1", "--yield-smoothing", "[0, 1000]", 2),
    _C("run --si --youngs-modulus=-1", "--youngs-modulus", RANGE["si"], 2),
    _C("run --si --velocity=1", "--velocity", None, 2),
    _C("run --axial-constraint=0.5", "--axial-constraint", None, 2),
    _C("run --colour=red", "--colour", None, 2),
    _C(
        "run --t-max=1e9",
        "--t-max",
        "allowed",
        2,
    ),
    # --- found by the property-based tests (tests/test_properties*.py, issue 12 item 6) ---
    _C("P(span_ratio=None)", "span_ratio", "real number", TypeError),
    _C("P(velocity=[1.0, [2.0]])", "velocity", "real number", TypeError),
    _C("m.Mesh(6, 8, 2, [2.0])", "contact_region", "single value"),
    _C("m.Mesh(10**12, 8, 2)", "ring_segments", "<= 10000"),
    _C("m.Settings(safety=[0.5, 0.7])", "safety", "single value"),
    _C("m.Settings(shape_times=([0.1, 0.2],))", "shape_times", "single value"),
    _C("m.Settings(history_points=10**9)", "history_points", "<= 1000000"),
    _C("m.Settings(substeps=10**6)", "substeps", "<= 10000"),
    _C("run --contact-region=3", "--contact-region", "(3, 10000]", 2),
    _C("run --si --beam-half-span=0.9", "--beam-half-span", RANGE["span_ratio"], 2),
    _C("run --plot=figure.txt", "--plot", "allowed:", 2),
    _C("sweep --velocity=0:1:1000000000", "--velocity", "1 <= n <= 1000000", 2),
    _C("sweep --velocity=0.1:1:1000 --mass-ratio=1:9:1001", "--mass-ratio", "<= 1000000", 2),
    _C("m.from_si(**{**m.PAPER_SI, 'radius': 5.7e102})", "slenderness", RANGE["slenderness"]),
    _C("run --si --radius=5.7e102", "--radius", RANGE["slenderness"], 2),
    _C("sweep --cluster=local:2 --workers=2", "--workers", None, 2),
    _C("bench nonsense", "nonsense", None, 2),
    _C("bench stability --only nonsense", "nonsense", "known:", 2),
)


@dataclasses.dataclass
class Outcome:
    kind: str  # the exception type name, "exit N", or "accepted"
    message: str
    where: str = ""  # file:line that raised (Python)
    value: str = ""  # what an accepted expression returned


def attempt(case: Case) -> Outcome:
    """Run one case and record what the user is told."""
    if case.cli:
        return _attempt_cli(case)
    try:
        value = eval(case.code, dict(NAMESPACE))  # noqa: S307 - the cases are ours
    except Exception as error:  # noqa: BLE001 - recording whatever the user would see
        frame = traceback.extract_tb(error.__traceback__)[-1]
        where = f"{Path(frame.filename).name}:{frame.lineno}"
        first = str(error).strip().splitlines()[0] if str(error).strip() else ""
        return Outcome(type(error).__name__, first, where)
    return Outcome("accepted", "", value=repr(value).splitlines()[0][:80])


def _attempt_cli(case: Case) -> Outcome:
    argv = case.code.split()
    if argv[0] == "run":
        argv = ["run", *CLI_SMALL, *argv[1:]]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = msfd_main(argv)
    lines = [ln for ln in err.getvalue().splitlines() if ln.startswith("msfd")]
    message = lines[-1] if lines else err.getvalue().strip().splitlines()[-1:]
    return Outcome(f"exit {code}", message if isinstance(message, str) else "".join(message))


def refused(case: Case, outcome: Outcome) -> bool:
    """Whether the outcome is a clean refusal: right error, parameter and range named."""
    if case.cli:
        right_kind = outcome.kind == f"exit {case.error}"
    else:
        right_kind = outcome.kind == case.error.__name__
    named = case.parameter in outcome.message
    ranged = case.allowed is None or case.allowed in outcome.message
    return right_kind and named and ranged


def _expected(case: Case) -> str:
    kind = f"exit {case.error}" if case.cli else case.error.__name__
    rng = f", allowed {case.allowed!r}" if case.allowed else ""
    return f"{kind} naming `{case.parameter}`{rng}"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(outcomes: list[tuple[Case, Outcome]]) -> str:
    lines = [
        "| # | input | expected | verdict | what the user gets | exact message |",
        "|---|---|---|---|---|---|",
    ]
    for i, (case, out) in enumerate(outcomes, 1):
        ok = refused(case, out)
        verdict = "refused" if ok else "**not refused**"
        if not ok and case.gap:
            verdict += f": {case.gap}"
        elif not ok:
            verdict += " (new: not in the known gaps)"
        elif case.gap:
            verdict += " (was a known gap: update the case)"
        got = out.kind + (f" ({out.where})" if out.where else "")
        got += f" -> {out.value}" if out.value else ""
        lines.append(
            f"| {i} | `{_cell(case.id)}` | {_cell(_expected(case))} | {_cell(verdict)} "
            f"| {_cell(got)} | {_cell(out.message)} |"
        )
    return "\n".join(lines)


HEADER = """# Bad input: what the user is told

Issue 5 item 3. Every row is one invalid input tried through the Python API or the ``msfd``
command line, with the exact message the user gets. Generated by
``python tests/bad_input_cases.py --out docs/bad_input.md`` ({date}, {machine},
{seconds:.0f} s); every row is a test in ``tests/test_bad_input.py`` (the **not refused** rows
are strict xfails: they pass once the input is refused cleanly, and then fail until this table
is regenerated).

**Refused** means: the expected exception (Python) or exit code (CLI: 2 bad input, 3 solve
stopped by a guard) with a message that names the parameter (the CLI: the option) and, where a
range applies, the allowed range. Python's own messages for unknown keywords and missing
arguments name the keyword but do not list the valid ones. Inputs accepted at construction and
only failing later are carried to where the user meets them (``m.run`` on the 6/8/2 mesh,
t_max = 1.5).

{counts}

"""


# A section written by hand after the table (the property-based tests): kept on --out.
KEPT = "\n## Property-based tests"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="write the markdown here (default: stdout)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    outcomes = []
    for i, case in enumerate(CASES, 1):
        print(f"[{i}/{len(CASES)}] {case.id}", file=sys.stderr, flush=True)
        outcomes.append((case, attempt(case)))
    n_ok = sum(refused(c, o) for c, o in outcomes)
    counts = (
        f"{len(outcomes)} inputs: {n_ok} refused cleanly, {len(outcomes) - n_ok} not refused "
        f"({sum(c.cli for c, _ in outcomes)} of the {len(outcomes)} through the CLI)."
    )
    text = (
        HEADER.format(
            date=time.strftime("%Y-%m-%d"),
            machine=f"{platform.machine()}, Python {platform.python_version()}, "
            f"jax {jax.__version__}",
            seconds=time.perf_counter() - start,
            counts=counts,
        )
        + table(outcomes)
        + "\n"
    )
    if args.out:
        old = args.out.read_text() if args.out.exists() else ""
        args.out.write_text(text + (old[old.index(KEPT) :] if KEPT in old else ""))
    else:
        print(text)
    print(counts, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
