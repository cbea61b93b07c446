"""``msfd reproduce``: the paper's Sect. 4, figure by figure (see `_common.Reproduction`).

`FIGURES` lists every reproduced result in the paper's order: key -> (module, function, title).
Modules are imported only when their figure runs, so a missing or broken module gives an
error row in the report, never a crash of the whole reproduction. `run` runs a selection,
shows progress, and writes ``reproduce.md`` and ``reproduce.json``.
"""

from __future__ import annotations

import importlib
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..._collision.provenance import dumps
from ..._runtime.progress import LineProgress
from ._common import Finding, Reproduction

FIGURES: dict[str, tuple[str, str, str]] = {
    "fig10": ("fig10", "reproduce", "Fig. 10-11: energy partition against h_b/h_r"),
    "fig13_14": ("shapes", "reproduce", "Fig. 13-14: shapes, contact pairs, 'U' vs 'W' rings"),
    "fig15": ("contact", "reproduce_fig15", "Fig. 15: contact force, raw and averaged"),
    "fig16": ("contact", "reproduce_fig16", "Fig. 16: local contact dissipation against K0"),
    "fig17": ("quasistatic", "reproduce_fig17", "Fig. 17c: half ring on a rigid plate"),
    "fig18_22": ("quasistatic", "reproduce_fig18_22", "Fig. 18 and 22: quasi-static curves"),
    "fig19": ("energy", "reproduce_fig19", "Fig. 19: energy histories, restoring instant"),
    "fig20_21": ("mass_velocity", "reproduce_fig20_21", "Fig. 20-21: mass and velocity effects"),
    "fig23_24": (
        "mass_velocity",
        "reproduce_fig23_24",
        "Fig. 23-24: mass and velocity, h_b/h_r = 1",
    ),
    "analytic": ("closed_forms", "reproduce_analytic", "Eq. 25 and Parkes' cantilever"),
}


def load(key: str) -> Callable[[bool, Path], Reproduction]:
    """The figure's ``reproduce(quick, figures_dir)``; ImportError/AttributeError if absent."""
    module, function, _ = FIGURES[key]
    return getattr(importlib.import_module(f"{__name__}.{module}"), function)


def error_row(key: str, error: BaseException, seconds: float) -> Reproduction:
    """A figure that could not be produced, as a record (the report shows the error)."""
    title = FIGURES[key][2]
    kind = "not available" if isinstance(error, ImportError | AttributeError) else "failed"
    text = f"{type(error).__name__}: {error}"
    return Reproduction(
        key=key,
        title=f"{title} ({kind})",
        figures=[],
        table=f"**{kind}**: `{text}`",
        numbers={"error": text},
        findings=[],
        wall_time_s=seconds,
    )


def run(
    keys: Sequence[str],
    quick: bool,
    figures_dir: Path,
    results_dir: Path,
    progress: bool = False,
) -> list[Reproduction]:
    """Run the figures `keys` (in the registry's order), write the report, return the records.

    ``figures_dir`` receives the PNGs; ``results_dir`` ``reproduce.md`` (each figure's
    section and a summary of every finding) and ``reproduce.json``. A figure that raises is
    recorded as an error row and the others still run. `progress`: a bar of the figures
    on stderr (tqdm) with a line per figure (off by default; ``msfd reproduce`` shows it).
    """
    unknown = [k for k in keys if k not in FIGURES]
    if unknown:
        raise ValueError(f"unknown figures {unknown}; known: {', '.join(FIGURES)}")
    keys = [k for k in FIGURES if k in set(keys)]
    figures_dir, results_dir = Path(figures_dir), Path(results_dir)
    figures_dir.mkdir(parents=True, exist_ok=True)
    results_dir.mkdir(parents=True, exist_ok=True)
    records: list[Reproduction] = []
    begin = time.perf_counter()
    bar = LineProgress(len(keys), "reproduce", unit=" figures") if progress else None
    say = bar.note if bar is not None else (lambda text: None)
    for i, key in enumerate(keys, 1):
        say(f"[{i}/{len(keys)}] {key}: {FIGURES[key][2]} ...")
        start = time.perf_counter()
        try:
            record = load(key)(quick, figures_dir)
        except Exception as error:  # one figure failing must not lose the others
            record = error_row(key, error, time.perf_counter() - start)
            missing = isinstance(error, ImportError | AttributeError)
            say(record.table if missing else traceback.format_exc(limit=3))
        record.wall_time_s = time.perf_counter() - start
        records.append(record)
        agree = sum(f.agree is True for f in record.findings)
        (bar or say)(
            f"[{i}/{len(keys)}] {key}: done in {record.wall_time_s:.0f} s "
            f"({agree}/{len(record.findings)} findings agree; "
            f"{time.perf_counter() - begin:.0f} s elapsed)",
        )
    if bar is not None:
        bar.close()
    write(records, quick, figures_dir, results_dir)
    return records


def summary(records: Sequence[Reproduction]) -> str:
    """Every finding of every figure in one table."""
    lines = [
        "| Figure | Paper | Ours | Agree |",
        "|---|---|---|---|",
    ]
    mark = {True: "yes", False: "**no**", None: "n/a"}
    for record in records:
        if not record.findings and "error" in record.numbers:
            lines.append(f"| {record.key} | (not produced) | {record.numbers['error']} | n/a |")
        for f in record.findings:
            lines.append(f"| {f.figure} | {f.paper} | {f.ours} | {mark[f.agree]} |")
    counts = {v: sum(f.agree is v for r in records for f in r.findings) for v in mark}
    lines += [
        "",
        f"{counts[True]} agree, {counts[False]} disagree, {counts[None]} not comparable.",
    ]
    return "\n".join(lines)


def write(
    records: Sequence[Reproduction], quick: bool, figures_dir: Path, results_dir: Path
) -> None:
    """``reproduce.md`` and ``reproduce.json`` in `results_dir`."""
    results_dir = Path(results_dir)
    command = "msfd reproduce" + (" --quick" if quick else "")
    if records:
        command += " --only " + " ".join(r.key for r in records)
    total = sum(r.wall_time_s for r in records)
    try:  # image links relative to the report
        link = Path(_relative(figures_dir, results_dir))
    except ValueError:
        link = figures_dir
    head = [
        "# The paper's Sect. 4 reproduced" + (" (quick: coarse mesh, few points)" if quick else ""),
        "",
        f"Produced by `{command}` ({time.strftime('%Y-%m-%d')}, {total:.0f} s in all, "
        "including compilation). Energies are fractions of K0 unless said otherwise "
        "(M_pr: the ring's plastic moment times its radius).",
        "",
        "## Summary of findings",
        "",
        summary(records),
        "",
    ]
    body = [r.markdown().replace("](figures/", f"]({link.as_posix()}/") for r in records]
    (results_dir / "reproduce.md").write_text("\n".join(head + body) + "\n")
    data: dict[str, Any] = {
        "command": command,
        "quick": quick,
        "figures": [r.to_json() for r in records],
    }
    (results_dir / "reproduce.json").write_text(dumps(data, indent=1, default=_default) + "\n")


def _relative(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(target.resolve(), start.resolve())


def _default(value):
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


__all__ = ["FIGURES", "Finding", "Reproduction", "load", "run", "summary", "write"]
