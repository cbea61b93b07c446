"""Every code block of README.md and docs/*.md runs as a user runs it, and what it prints is
checked (issue 28: the docs showed inf, nan and null that no test saw).

The blocks are found when the tests are collected, so a new doc is covered without a change
here. Per fenced block, by its language:

- ```python: run by a fresh interpreter (``sys.executable``), the block on its stdin.
- ```bash / ```sh: run by ``bash -e -o pipefail``; ```console: its ``$ `` lines likewise.
- ```text, ```toml and plain ``` fences are shown, not run; a plain or text fence whose
  first line is a command (``msfd ...``, ``python ...``) fails `test_commands_are_labelled`:
  a command is labelled ```bash so that it is run (or skipped, saying why).
- any other language fails `test_languages_are_known`.

A block preceded (on the previous non-blank line) by ``<!-- doc-test: skip REASON -->`` is
not run (a pip install, a SLURM job, an hour-long study); the reason is shown in the doc and
in the test report, and a marker without one fails the collection.

The blocks of one doc run in order in one temporary directory (the working directory), in one
pytest-xdist worker, so a block sees the files of the blocks above it (run the whole doc, not
one block by ``-k``);
``MPLBACKEND=Agg``; ``MSFD_CACHE_DIR`` is one directory for the session, the suite's compile
cache (the CLI's compiled programs are shared by all blocks and with the python blocks; set it
in the environment to reuse a warm one). A block
passes when it exits 0 within `TIMEOUT_S` and its output (stdout and stderr) holds:

- no non-finite number (``nan``, ``inf``, ``-inf``, ``Infinity``, as a word: "information"
  and "infeasible" are words, and an interval's open bound ``(0, inf)`` is not a value);
- JSON (the whole stdout, every object or array starting a line, and every ``*.json`` file
  the block wrote) that a strict parser reads (no bare NaN/Infinity), with no non-finite
  number; no null where a number is promised (the energy fractions, the balance error,
  the SI design quantities); the seven fractions (`msfd_jax.FRACTION_KEYS`) summing to 1
  within |energy_balance_error| + 1e-9; a mean contact force at most the peak;
- in text, the partition's ``sum`` within its printed balance error (and the rounding) of
  1, and a printed mean contact force at most the printed peak.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

import msfd_jax as m

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT_S = 300

RUN = {"python": "python", "py": "python", "bash": "bash", "sh": "bash", "console": "console"}
SHOWN = {"", "text", "toml"}  # fences shown and not run
# A plain or text fence starting with one of these shows a command, which must be run.
COMMAND = re.compile(r"^(\$ )?(msfd|python3?|pytest|pip|taskset|PYTHONPATH=\S*|ruff|bash)\b")

# Never run: an install would replace the package under test (a block with one must be skipped).
INSTALL = re.compile(r"^\s*(\$ )?(.*&&\s*)?(python3? -m )?pip3? install\b")

FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})[ \t]*(?P<lang>[^\s`]*)[^`]*$")
MARKER = re.compile(r"^\s*<!--\s*doc-test:(?P<body>.*?)-->\s*$")
SKIP = re.compile(r"^\s*skip\b(?P<reason>.*)$", re.DOTALL)


def documents() -> list[Path]:
    """README.md and docs/*.md, as they are when the tests are collected."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


@dataclasses.dataclass(frozen=True)
class Block:
    doc: Path
    line: int  # of the opening fence, 1-based
    lang: str
    code: str
    skip: str | None  # the reason given by a skip marker, None when run

    @property
    def id(self) -> str:
        return f"{self.doc.relative_to(ROOT)}:{self.line}"


class DocError(Exception):
    """A doc the harness cannot read as it is (an empty skip reason, a stray marker)."""


def parse(doc: Path) -> list[Block]:
    """The fenced blocks of a markdown file, with the skip markers above them."""
    lines = doc.read_text(encoding="utf-8").splitlines()
    blocks: list[Block] = []
    pending: tuple[int, str] | None = None  # a skip marker waiting for its block
    last = ""  # the previous non-blank line
    i = 0
    while i < len(lines):
        text = lines[i]
        marker = MARKER.match(text)
        fence = FENCE.match(text)
        if marker:
            skip = SKIP.match(marker["body"].strip())
            if skip is None:
                raise DocError(f"{doc.name}:{i + 1}: unknown doc-test marker {text.strip()!r}")
            reason = skip["reason"].strip()
            if not reason:
                raise DocError(f"{doc.name}:{i + 1}: doc-test skip without a reason")
            pending = (i + 1, reason)
        elif fence:
            start, body = i, []
            indent, mark = fence["indent"], fence["fence"]
            close = re.compile(rf"^[ \t]*{re.escape(mark[0])}{{{len(mark)},}}[ \t]*$")
            i += 1
            while i < len(lines) and not close.match(lines[i]):
                body.append(lines[i][len(indent) :] if lines[i].startswith(indent) else lines[i])
                i += 1
            reason = None
            if pending is not None:
                if not MARKER.match(last):
                    raise DocError(
                        f"{doc.name}:{pending[0]}: a skip marker must be the line above a block"
                    )
                reason = pending[1]
                pending = None
            code = "\n".join(body) + "\n"
            blocks.append(Block(doc, start + 1, fence["lang"].lower(), code, reason))
            last = text
            i += 1
            continue
        elif text.strip() and pending is not None:
            raise DocError(f"{doc.name}:{pending[0]}: a skip marker must be the line above a block")
        if text.strip():
            last = text
        i += 1
    if pending is not None:
        raise DocError(f"{doc.name}:{pending[0]}: a skip marker with no block after it")
    return blocks


BLOCKS = [block for doc in documents() for block in parse(doc)]  # DocError fails collection
RUNNABLE = [block for block in BLOCKS if block.lang in RUN]


# ----------------------------------------------------------------------------------------------
# Running a block


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory) -> Path:
    """The CLI's compile cache for every block of the session: the suite's own (conftest's
    JAX_COMPILATION_CACHE_DIR, which the python blocks and notebooks use), so a python block
    loads the programs a command above it compiled for the same problem (docs/design.md's
    coarse design: 39.5 s -> 21.2 s)."""
    given = os.environ.get("MSFD_CACHE_DIR") or os.environ.get("JAX_COMPILATION_CACHE_DIR")
    return Path(given) if given else tmp_path_factory.mktemp("msfd-cache")


@pytest.fixture(scope="session")
def doc_dirs(tmp_path_factory) -> dict[Path, Path]:
    """One working directory per doc, shared by its blocks in order."""
    return {doc: tmp_path_factory.mktemp(doc.stem) for doc in documents()}


def command(block: Block) -> list[str]:
    """The interpreter and arguments that run a block, its code on stdin for python."""
    if block.lang == "python":
        return [sys.executable, "-"]
    code = block.code
    if block.lang == "console":
        code = "\n".join(line[2:] for line in code.splitlines() if line.startswith("$ "))
    return ["bash", "-e", "-o", "pipefail", "-c", code]


def execute(block: Block, cwd: Path, cache: Path) -> subprocess.CompletedProcess:
    """Run a block in its own process group, killed whole past `TIMEOUT_S`."""
    env = dict(os.environ, MPLBACKEND="Agg", MSFD_CACHE_DIR=str(cache))
    # the interpreter's own bin first: `msfd` and `python` are the ones installed with it
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    process = subprocess.Popen(
        command(block),
        cwd=cwd,
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    stdin = block.code if block.lang == "python" else ""
    try:
        out, err = process.communicate(stdin, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        out, err = process.communicate()
        pytest.fail(f"{block.id} ran past {TIMEOUT_S} s\n--- stdout\n{out}\n--- stderr\n{err}")
    return subprocess.CompletedProcess(process.args, process.returncode, out, err)


# ----------------------------------------------------------------------------------------------
# Checks on what a block prints and writes

# A non-finite number as a word: not "information", "infeasible", "nanoseconds", "file_nan".
NON_FINITE = re.compile(r"(?<![\w.])[-+]?(?:nan|inf(?:inity)?)(?![\w])", re.IGNORECASE)
# An interval's open bound, as in "allowed (0, inf)" or "[-inf, 0]": a range, not a value.
OPEN_BOUND = re.compile(r"[\[(]\s*-inf\s*,|,\s*\+?inf\s*[\])]", re.IGNORECASE)


def non_finite_words(text: str) -> list[str]:
    """Lines of `text` that print a non-finite number."""
    return [line for line in text.splitlines() if NON_FINITE.search(OPEN_BOUND.sub("", line))]


class NonFinite(Exception):  # not a ValueError: the JSON scanner must not swallow it
    pass


def _refuse_constant(name: str):
    raise NonFinite(name)


STRICT = json.JSONDecoder(parse_constant=_refuse_constant)


def json_values(text: str) -> Iterator[tuple[str, object]]:
    """(where, value) for every JSON object or array that starts a line of `text`."""
    position = 0
    for line in text.splitlines(keepends=True):
        start, position = position, position + len(line)
        if not line.lstrip().startswith(("{", "[")):
            continue
        begin = start + len(line) - len(line.lstrip())
        try:
            value, _ = STRICT.raw_decode(text, begin)
        except json.JSONDecodeError:
            continue  # not JSON (a log line in brackets)
        except NonFinite as error:
            raise AssertionError(f"JSON with a bare {error} (not JSON): {line[:200]!r}") from None
        yield f"JSON at {line[:60]!r}", value


# A null is a failure under these keys (a number is promised) and anywhere inside an `si` dict.
NUMBER_KEYS = set(m.FRACTION_KEYS) | {"energy_balance_error", "k0"}
SI_KEY = re.compile(r"_(N|kN|J|kJ|m|mm|s|ms|m_s2|g)$")


def check_json(value: object, where: str) -> None:
    """Finite numbers, promised numbers present, fractions summing to 1, mean <= peak."""
    problems: list[str] = []

    def walk(node: object, path: str, parent: dict | None, in_si: bool) -> None:
        if isinstance(node, float) and not math.isfinite(node):
            problems.append(f"{path} = {node}")
        elif isinstance(node, list):
            for index, item in enumerate(node):
                walk(item, f"{path}[{index}]", parent, in_si)
        elif isinstance(node, dict):
            for key, item in node.items():
                if item is None and (in_si or key in NUMBER_KEYS or SI_KEY.search(key)):
                    problems.append(f"{path}.{key} is null where a number is promised")
                walk(item, f"{path}.{key}", node, in_si or key == "si")
            problems.extend(_partition(node, path, parent))
            problems.extend(_mean_at_most_peak(node, path))

    walk(value, "$", None, False)
    assert not problems, f"{where}:\n" + "\n".join(problems[:20])


def _partition(node: dict, path: str, parent: dict | None) -> list[str]:
    """The seven fractions sum to 1 within the balance error (of the record they are in)."""
    values = [node.get(key) for key in m.FRACTION_KEYS]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return []
    balance = node.get("energy_balance_error")
    if balance is None and parent is not None:
        balance = parent.get("energy_balance_error")
    if not isinstance(balance, (int, float)):
        return [f"{path}: fractions without an energy_balance_error to check their sum against"]
    total = math.fsum(values)
    if abs(total - 1.0) > abs(balance) + 1e-9:
        return [f"{path}: fractions sum to {total!r}, balance error {balance!r}"]
    return []


def _mean_at_most_peak(node: dict, path: str) -> list[str]:
    problems = []
    for key, mean in node.items():
        if "mean_contact_force" not in key:
            continue
        peak = node.get(key.replace("mean_contact_force", "peak_contact_force"))
        if isinstance(mean, (int, float)) and isinstance(peak, (int, float)) and mean > peak:
            problems.append(f"{path}: {key} = {mean} above the peak {peak}")
    return problems


UNITS = {"N": 1.0, "kN": 1e3, "MN": 1e6}
FORCE = r"[^\d\n]*?([-+]?\d[\d.]*(?:e[-+]?\d+)?)\s*(N|kN|MN)\b"  # the first number, its unit
MEAN_FORCE = re.compile(r"^\s*mean contact force" + FORCE, re.MULTILINE)
PEAK_FORCE = re.compile(r"^\s*peak contact force" + FORCE, re.MULTILINE)
SUM = re.compile(r"^\s*sum\s+([-+]?\d\.\d+)\s*$", re.MULTILINE)
BALANCE = re.compile(r"^\s*energy balance error\s+([-+]?\d[\d.]*e[-+]?\d+)", re.MULTILINE)


def check_text(text: str) -> list[str]:
    """The printed partition's sum and contact forces, where `msfd run` prints them."""
    problems = []
    for total, balance in zip(SUM.findall(text), BALANCE.findall(text), strict=False):
        decimals = len(total.split(".")[1])
        if abs(float(total) - 1.0) > abs(float(balance)) + 10.0**-decimals:
            problems.append(f"printed sum {total} against the balance error {balance}")
    for (mean, mean_unit), (peak, peak_unit) in zip(
        MEAN_FORCE.findall(text), PEAK_FORCE.findall(text), strict=False
    ):
        if float(mean) * UNITS[mean_unit] > float(peak) * UNITS[peak_unit]:
            problems.append(
                f"mean contact force {mean} {mean_unit} above the peak {peak} {peak_unit}"
            )
    return problems


def written_json(cwd: Path, before: dict[Path, float]) -> list[Path]:
    """The ``*.json`` files under `cwd` that are new or changed since `before`."""
    return [p for p in sorted(cwd.rglob("*.json")) if before.get(p) != p.stat().st_mtime_ns]


# ----------------------------------------------------------------------------------------------
# The tests


# The blocks of one doc run in order in one process (pytest-xdist's `loadgroup`: a doc is one
# group), since a block may read what the blocks above it wrote; the docs spread over workers.
@pytest.mark.parametrize(
    "block",
    [pytest.param(b, marks=pytest.mark.xdist_group(b.doc.name), id=b.id) for b in RUNNABLE],
)
def test_block(block: Block, doc_dirs, cache_dir):
    if block.skip is not None:
        pytest.skip(f"the doc says: {block.skip}")
    installs = [line for line in block.code.splitlines() if INSTALL.match(line)]
    assert not installs, (
        f"{block.id} installs packages ({installs[0].strip()!r}), which would change this "
        "environment: mark the block <!-- doc-test: skip REASON --> (CI runs the install)"
    )
    cwd = doc_dirs[block.doc]
    before = {p: p.stat().st_mtime_ns for p in cwd.rglob("*.json")}
    result = execute(block, cwd, cache_dir)
    shown = f"{block.id} ({block.lang})\n--- stdout\n{result.stdout}\n--- stderr\n{result.stderr}"
    assert result.returncode == 0, f"exit code {result.returncode}: {shown}"
    output = result.stdout + "\n" + result.stderr
    bad = non_finite_words(output)
    assert not bad, "non-finite numbers printed:\n" + "\n".join(bad[:20]) + f"\n{shown}"
    for where, value in json_values(result.stdout):
        check_json(value, f"{block.id}: {where}")
    for path in written_json(cwd, before):
        try:
            value = STRICT.decode(path.read_text())
        except NonFinite as error:
            raise AssertionError(f"{block.id}: {path.name} holds a bare {error}") from None
        check_json(value, f"{block.id}: {path.relative_to(cwd)}")
    problems = check_text(output)
    assert not problems, "\n".join(problems) + f"\n{shown}"


@pytest.mark.parametrize("doc", documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_languages_are_known(doc: Path):
    unknown = [f"{b.id}: ```{b.lang}" for b in parse(doc) if b.lang not in {*RUN, *SHOWN}]
    assert not unknown, "blocks in a language the doc tests neither run nor show:\n" + "\n".join(
        unknown
    )


@pytest.mark.parametrize("doc", documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_commands_are_labelled(doc: Path):
    hidden = [
        f"{b.id}: {first!r}"
        for b in parse(doc)
        if b.lang in ("", "text")
        for first in [next((x for x in b.code.splitlines() if x.strip()), "")]
        if COMMAND.match(first.strip())
    ]
    assert not hidden, (
        "commands in a plain fence are never run: label them ```bash (and mark the block "
        "<!-- doc-test: skip REASON --> if it cannot run in a test):\n" + "\n".join(hidden)
    )


LINK = re.compile(r"\]\(([^()\s]+)\)")  # [text](target) and ![alt](target)


@pytest.mark.parametrize("doc", documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_links_resolve(doc: Path):
    """Every relative link names a file or folder that exists (files move: stale names)."""
    targets = {t.split("#")[0] for t in LINK.findall(doc.read_text(encoding="utf-8"))}
    local = [t for t in targets if t and not re.match(r"^[a-z]+:", t)]
    missing = sorted(t for t in local if not (doc.parent / t).exists())
    assert not missing, f"{doc.name}: links to missing files:\n" + "\n".join(missing)


def test_every_skip_says_why():
    """Collection already refused empty reasons; the skipped blocks are listed here."""
    skipped = [b for b in BLOCKS if b.skip is not None]
    assert all(b.skip.strip() for b in skipped)
    assert all(b.lang in RUN for b in skipped), [b.id for b in skipped if b.lang not in RUN]


# ----------------------------------------------------------------------------------------------
# The harness's own checks (fast: no block is run)


def test_harness_reads_markers_and_fences(tmp_path):
    doc = tmp_path / "x.md"
    doc.write_text(
        "# t\n\n<!-- doc-test: skip needs SLURM -->\n\n```bash\nsbatch x\n```\n\n"
        "- item\n\n  ```python\n  print(1)\n  ```\n\n````text\n```\n````\n"
    )
    blocks = parse(doc)
    assert [(b.line, b.lang, b.skip) for b in blocks] == [
        (5, "bash", "needs SLURM"),
        (11, "python", None),
        (15, "text", None),
    ]
    assert blocks[1].code == "print(1)\n"
    doc.write_text("<!-- doc-test: skip   -->\n```bash\nmsfd run\n```\n")
    with pytest.raises(DocError, match="without a reason"):
        parse(doc)
    doc.write_text("<!-- doc-test: skip why -->\ntext between\n```bash\nmsfd run\n```\n")
    with pytest.raises(DocError, match="line above a block"):
        parse(doc)
    doc.write_text("<!-- doc-test: skp why -->\n```bash\nmsfd run\n```\n")
    with pytest.raises(DocError, match="unknown doc-test marker"):
        parse(doc)


def test_harness_output_checks():
    assert non_finite_words("peak deflection inf mm\nx = NaN\n-inf\nInfinity") == [
        "peak deflection inf mm",
        "x = NaN",
        "-inf",
        "Infinity",
    ]
    fine = "information, infeasible, nanoseconds, file_nan.csv, allowed (0, inf), [-inf, 0]"
    assert non_finite_words(fine) == []
    with pytest.raises(AssertionError, match="bare NaN"):
        list(json_values('{"settings_dt": NaN}\n'))
    assert [v for _, v in json_values('log [x]\n{"a": 1,\n "b": [2]}\n[3]\n')] == [
        {"a": 1, "b": [2]},
        [3],
    ]
    fractions = dict.fromkeys(m.FRACTION_KEYS, 0.0) | {"beam_bending": 1.0 + 1e-6}
    check_json({"fractions": fractions, "energy_balance_error": -2e-6}, "ok")
    with pytest.raises(AssertionError, match="sum to"):
        check_json({"fractions": fractions, "energy_balance_error": 1e-7}, "bad")
    with pytest.raises(AssertionError, match="null"):
        check_json({"si": {"peak_beam_deflection_m": None}}, "null")
    with pytest.raises(AssertionError, match="above the peak"):
        check_json([{"mean_contact_force_N": 2.0, "peak_contact_force_N": 1.0}], "mean")
    with pytest.raises(AssertionError, match="inf"):
        check_json({"x": float("inf")}, "1e400")
    text = (
        "  sum             1.0000\nenergy balance error  +2.70e-05 K0\n"
        "  peak contact force (whole beam)       858 kN\n"
        "  mean contact force while open       1245 kN\n"
    )
    assert check_text(text) == ["mean contact force 1245 kN above the peak 858 kN"]
