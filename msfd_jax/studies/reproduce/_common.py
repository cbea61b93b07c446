"""What every figure of ``msfd reproduce`` returns, and how it is written out.

A figure module exposes ``reproduce(quick: bool, figures_dir: Path) -> Reproduction``: it runs
the collisions it needs (small mesh and few points when ``quick``), saves its figure(s) under
``figures_dir`` and returns the numbers, a markdown table and one `Finding` per statement of
the paper it checks. Each is a thin composition of three parts: ``compute_*(quick)`` (the runs
and their numbers, no matplotlib), ``draw_*(numbers, figures_dir)`` (rendering only; the figure
names) and ``table_*`` / ``judge_*(numbers)`` (the markdown table and the findings, pure
functions of the computed numbers). The runner (``msfd_jax.studies.reproduce.run``) collects
them into ``reproduce.md`` / ``reproduce.json``; ``docs/validation.md`` quotes those files.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


@dataclasses.dataclass
class Finding:
    """One statement of the paper against our number.

    - `figure`: where the paper says it, e.g. ``"Fig. 10a"``.
    - `paper`: the paper's statement, one line.
    - `ours`: what we measured, one line with the numbers.
    - `agree`: True / False, or None where the two cannot be compared.
    - `reason`: why they agree or not (the mechanics), one or two lines.
    """

    figure: str
    paper: str
    ours: str
    agree: bool | None
    reason: str = ""


@dataclasses.dataclass
class Reproduction:
    """The result of one figure (or group of figures) of the paper's Sect. 4."""

    key: str  # registry key, e.g. "fig10"
    title: str  # e.g. "Fig. 10-11: energy partition against h_b/h_r"
    figures: list[str]  # file names written in figures_dir
    table: str  # markdown: the numbers behind the figure
    numbers: dict[str, Any]  # the same numbers, JSON-able
    findings: list[Finding]
    wall_time_s: float = float("nan")

    def to_json(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def markdown(self) -> str:
        lines = [f"## {self.title}", ""]
        lines += [f"![{name}](figures/{name})" for name in self.figures]
        lines += ["", self.table, ""]
        if self.findings:
            lines += ["| Figure | Paper | Ours | Agree | Why |", "|---|---|---|---|---|"]
            mark = {True: "yes", False: "**no**", None: "n/a"}
            for f in self.findings:
                lines.append(
                    f"| {f.figure} | {f.paper} | {f.ours} | {mark[f.agree]} | {f.reason} |"
                )
        lines += ["", f"({self.wall_time_s:.0f} s)", ""]
        return "\n".join(lines)


def compose(
    key: str,
    title: str,
    quick: bool,
    figures_dir: Path,
    *,
    compute: Callable[[bool], dict],
    draw: Callable[[dict, Path], list[str]],
    table: Callable[[dict], str],
    judge: Callable[[dict], list[Finding]],
    publish: Callable[[dict], dict[str, Any]],
) -> Reproduction:
    """One figure's `Reproduction` from its parts: compute, then draw, tabulate, publish, judge.

    `publish` picks the JSON-able numbers of ``reproduce.json`` from what `compute` returned
    (which may also hold runs and curves that only drawing and judging need).
    """
    start = time.perf_counter()
    numbers = compute(quick)
    return Reproduction(
        key=key,
        title=title,
        figures=draw(numbers, figures_dir),
        table=table(numbers),
        numbers=publish(numbers),
        findings=judge(numbers),
        wall_time_s=time.perf_counter() - start,
    )
