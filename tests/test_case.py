"""Case files, ``--from-json`` reruns, failures as JSON, provenance and ``--version``."""

import contextlib
import io
import json

import pytest

import msfd_jax as m
from msfd_jax.cli import _with_files as with_files
from msfd_jax.cli import build_parser, main
from msfd_jax.cli.sweep import grid_from_args

SMALL = [
    "--ring-segments=6",
    "--beam-contact-segments=8",
    "--beam-outer-segments=2",
    "--t-max=1.5",
    "--history-points=31",
    "--shape-times=0.5",
    "--no-cache",
]
ISSUE_CASE = """
[collision]
thickness_ratio = 2.5
axial_constraint = true
mass_ratio = 10
velocity = 0.82
"""


def _json(*argv: str) -> tuple[int, dict]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    lines = out.getvalue().splitlines()
    assert len(lines) == 1, (out.getvalue(), err.getvalue())  # one JSON object, nothing else
    return code, json.loads(lines[0])


def _parse(*argv: str):
    parser = build_parser()
    return with_files(parser, parser.parse_args(list(argv)), list(argv))


@pytest.fixture(scope="module")
def command_line():
    code, record = _json("run", *SMALL, "--json")
    assert code == 0
    return record


def test_the_issue_case_equals_the_command_line(tmp_path, command_line):
    case = tmp_path / "case.toml"
    case.write_text(ISSUE_CASE)
    code, record = _json("run", str(case), *SMALL, "--json")
    assert code == 0
    assert record["fractions"] == command_line["fractions"]
    assert record["params"] == command_line["params"]


def test_a_case_file_sets_every_section_and_the_line_overrides(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(
        "[collision]\nvelocity = 0.5\naxial_constraint = false\n"
        "[mesh]\nring_segments = 7\n[settings]\nt_max = 3\nshape_times = [0.1, 0.2]\n"
        "[output]\njson = true\n"
    )
    args = _parse("run", str(case), "--velocity", "0.7")
    assert args.velocity == 0.7 and args.axial_constraint is False and args.json
    assert args.ring_segments == 7 and args.t_max == 3.0 and args.shape_times == (0.1, 0.2)
    si = tmp_path / "si.toml"
    si.write_text("[collision]\nimpact_speed = 27.8\nblock_mass = 1500\n")
    args = _parse("run", str(si))
    assert args.si_impact_speed == 27.8 and args.si_block_mass == 1500.0


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("[collision]\nspeed = 1\n", "allowed: axial_constraint, beam_half_span"),
        ("[colision]\nvelocity = 1\n", "allowed: [collision]"),
        ("[mesh]\nring_segments = 'many'\n", "[mesh] ring_segments"),
        ("[collision]\naxial_constraint = 2\n", "true or false"),
        ("[collision]\nvelocity = [", "not valid TOML"),
    ],
)
def test_bad_case_files_are_refused_with_the_allowed_keys(tmp_path, capsys, text, named):
    case = tmp_path / "case.toml"
    case.write_text(text)
    assert main(["run", str(case), "--no-cache"]) == 2
    out, err = capsys.readouterr()
    assert named in err and "Traceback" not in err and out == ""


def test_a_sweep_case_gives_axes(tmp_path):
    case = tmp_path / "sweep.toml"
    case.write_text(
        '[axes]\nthickness_ratio = [1.5, 2.5]\nvelocity = "0.5:1:3"\n'
        "[collision]\nmass_ratio = 10\naxial_constraint = false\n[batching]\nchunk_size = 4\n"
    )
    args = _parse("sweep", str(case))
    spec = grid_from_args(args)
    assert spec["thickness_ratio"] == [1.5, 2.5] and spec["velocity"] == [0.5, 0.75, 1.0]
    assert spec["mass_ratio"] == [10.0] and spec["axial_constraint"] == [0.0]
    assert args.chunk_size == 4


def test_run_json_records_its_provenance(command_line):
    assert command_line["mesh"] == {
        "ring_segments": 6,
        "beam_contact_segments": 8,
        "beam_outer_segments": 2,
        "contact_region": 2.0,
    }
    assert command_line["settings"]["t_max"] == 1.5
    assert command_line["settings"]["shape_times"] == [0.5]
    for key in ("msfd-jax", "jax", "jaxlib", "diffrax", "python", "platform"):
        assert command_line["versions"][key]
    assert command_line["versions"]["msfd-jax"] == m.__version__


def test_from_json_reruns_the_same_collision(tmp_path, command_line):
    path = tmp_path / "out.json"
    changed = {**command_line, "params": {**command_line["params"]}}
    path.write_text(json.dumps(changed))
    code, again = _json("run", "--from-json", str(path), "--json", "--no-cache")
    assert code == 0
    for key, value in command_line["fractions"].items():
        assert again["fractions"][key] == pytest.approx(value, abs=1e-12)
    assert again["mesh"] == command_line["mesh"]
    assert again["settings"] == command_line["settings"]


def test_a_failed_run_prints_one_json_object(tmp_path, command_line):
    # a real failure on the same compiled program: an energy guard no run can meet
    record = {**command_line, "settings": {**command_line["settings"], "energy_guard": 1e-12}}
    path = tmp_path / "out.json"
    path.write_text(json.dumps(record))
    code, failed = _json("run", "--from-json", str(path), "--json", "--no-cache")
    assert code == 3
    assert failed["ok"] is False and failed["status"] == "energy balance broken"
    assert "energy balance" in failed["message"] and failed["when"]
    assert failed["failed_at"]["tau"] < 1.5 and failed["params"] == command_line["params"]
    assert failed["settings"]["energy_guard"] == 1e-12 and failed["versions"]


def test_bad_input_with_json_prints_one_json_object():
    code, failed = _json("run", *SMALL, "--velocity", "-1", "--json")
    assert code == 2 and failed["ok"] is False and "velocity" in failed["message"]


def test_version(capsys):
    assert main(["--version"]) == 0
    assert m.__version__ in capsys.readouterr().out
