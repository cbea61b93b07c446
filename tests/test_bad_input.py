"""Every row of docs/bad_input.md is a test (issue 5 item 3).

The cases live in tests/bad_input_cases.py (which also writes the table). A clean refusal
is the expected exception (CLI: exit code) with a message naming the parameter and, where one
applies, the allowed range. The known gaps (inputs not refused cleanly) are strict xfails:
when one gets fixed the test fails, asking for the table to be regenerated.

Runs that get as far as a solve use conftest's SMALL_MESH and SHORT settings (shared compiled
program); three gaps compile their own (safety = 5's step bound, t_max = 1e9, max_steps).
"""

import importlib.util
import sys
from pathlib import Path

import pytest

_PATH = Path(__file__).parent / "bad_input_cases.py"
_SPEC = importlib.util.spec_from_file_location("bad_input_cases", _PATH)
table = importlib.util.module_from_spec(_SPEC)
sys.modules["bad_input_cases"] = table  # dataclasses look their module up
_SPEC.loader.exec_module(table)


def _param(case):
    marks = [pytest.mark.xfail(strict=True, reason=case.gap)] if case.gap else []
    return pytest.param(case, id=case.id, marks=marks)


@pytest.mark.parametrize("case", [_param(c) for c in table.CASES])
def test_bad_input_is_refused(case):
    outcome = table.attempt(case)
    expected = f"exit {case.error}" if case.cli else case.error.__name__
    assert outcome.kind == expected, outcome
    assert case.parameter in outcome.message, outcome.message
    if case.allowed is not None:
        assert case.allowed in outcome.message, outcome.message


def test_the_table_has_every_kind_of_bad_input():
    # issue 5 item 3: negative, zero, NaN, inf, wrong types, impossible meshes, unknown options
    codes = " ".join(c.code for c in table.CASES)
    kinds = (
        "=-1",
        "=0.0",
        "math.nan",
        "math.inf",
        "'ten'",
        "None",
        "1j",
        "[1.0, 2.0]",
        "Mesh(2, 8",
        "Mesh(True",
        "Mesh(6.5",
        "speed=",
        "--colour",
        "safety=0.0",
        "dt=0.0",
        "(-0.1,)",
        "span_ratio=1.5",
    )
    assert [k for k in kinds if k not in codes] == []
