"""``msfd reproduce``: regenerate the paper's Sect. 4 results (figures and numbers).

A full run writes the figures to ``docs/figures`` and ``reproduce.md`` / ``reproduce.json``
to ``docs/results/reproduce`` (both relative to the current directory); ``--quick`` (a
coarse mesh and few points, a few minutes) writes both to ``reproduce-quick/`` instead, so a
quick run never overwrites the committed figures. ``--only KEY ...`` picks figures.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from . import common


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..studies.reproduce import FIGURES

    known = ", ".join(FIGURES)
    parser.add_argument(
        "--quick", action="store_true", help="coarse mesh, few points (a few minutes)"
    )
    parser.add_argument(
        "--only", nargs="+", metavar="KEY", help=f"figures to run (default all): {known}"
    )
    parser.add_argument(
        "--figures",
        type=Path,
        metavar="DIR",
        help="where the PNGs go (default docs/figures; quick: reproduce-quick/figures)",
    )
    parser.add_argument(
        "--results",
        type=Path,
        metavar="DIR",
        help="where reproduce.md/.json go (default docs/results/reproduce; quick: reproduce-quick)",
    )
    common.add_quiet_argument(parser, "--no-progress")
    parser.add_argument("--no-cache", action="store_true", help="no persistent compile cache")


def handle(args: argparse.Namespace) -> int:
    from ..studies.reproduce import FIGURES, run

    keys = list(FIGURES) if args.only is None else args.only
    unknown = [k for k in keys if k not in FIGURES]
    if unknown:
        raise common.UsageError(f"unknown figure {', '.join(unknown)}; known: {', '.join(FIGURES)}")
    if args.quick:
        base = Path("reproduce-quick")
        figures = args.figures or base / "figures"
        results = args.results or base
    else:
        figures = args.figures or Path("docs") / "figures"
        results = args.results or Path("docs") / "results" / "reproduce"
    if not args.no_cache:
        common.enable_compilation_cache()
    records = run(keys, args.quick, figures, results, progress=not args.quiet)
    failed = [r.key for r in records if "error" in r.numbers]
    findings = [f for r in records for f in r.findings]
    agree = sum(f.agree is True for f in findings)
    disagree = sum(f.agree is False for f in findings)
    missing = f": {', '.join(failed)}" if failed else ""
    print(
        f"{len(records)} figures ({len(failed)} not produced{missing}); "
        f"{agree} findings agree, {disagree} disagree; report: {results / 'reproduce.md'}, "
        f"figures: {figures}"
    )
    return common.EXIT_SOLVE if failed else common.EXIT_OK
