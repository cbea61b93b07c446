"""``msfd bench``: recorded studies, one sub-choice each (``stability``, ``accuracy``).

A study registers itself in `BENCHES` as (help, add_arguments, handler), the same shape as
`msfd_jax.cli.COMMANDS`, so that ``msfd bench accuracy`` is one more entry here.

Exit codes: 0 every row as expected, 1 some row not as expected, 2 bad input.
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable

from . import common

EXIT_UNEXPECTED = 1


def _add_stability(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--quick", action="store_true", help="coarse mesh, tau <= 3 (a minute instead of several)"
    )
    parser.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    parser.add_argument(
        "--only", nargs="+", metavar="SCENE", help="run only these scenes (default: all)"
    )


def _stability(args: argparse.Namespace) -> int:
    from ..studies import stability as _stability  # lazy: `msfd run` loads no study

    if args.only:
        unknown = [n for n in args.only if n not in _stability.BY_NAME]
        if unknown:
            raise common.UsageError(
                f"unknown scene(s) {', '.join(unknown)}; known: {', '.join(_stability.BY_NAME)}"
            )
    common.enable_compilation_cache()
    start = time.perf_counter()
    rows = _stability.run_catalogue(args.only, quick=args.quick)
    machine = f"{platform.node()} ({platform.machine()}, {platform.processor() or 'cpu'})"
    stamp = time.strftime("%Y-%m-%d %H:%M %Z")
    total = time.perf_counter() - start
    if args.json:
        print(
            common.dumps(
                {
                    "machine": machine,
                    "date": stamp,
                    "quick": args.quick,
                    "total_wall_time_s": total,
                    "rows": rows,
                }
            )
        )
    else:
        print(_stability.markdown_table(rows))
        print(
            f"\n{len(rows)} scenes, {'quick' if args.quick else 'full'} form, "
            f"{total:.0f} s in all (wall times include compiling), {stamp} on {machine}"
        )
    bad = [r["name"] for r in rows if r["verdict"] != "as expected"]
    return EXIT_UNEXPECTED if bad else 0


def _add_accuracy(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--quick", action="store_true", help="coarse mesh, tau = 1, few steps (a few minutes)"
    )
    parser.add_argument("--json", action="store_true", help="print the result as one JSON object")
    parser.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        help="run only these collisions and/or methods (default: all)",
    )


def _accuracy(args: argparse.Namespace) -> int:
    from ..studies import accuracy as _accuracy

    names = args.only or []
    unknown = [n for n in names if n not in _accuracy.CASES and n not in _accuracy.METHODS]
    if unknown:
        raise common.UsageError(
            f"unknown name(s) {', '.join(unknown)}; collisions: {', '.join(_accuracy.CASES)}; "
            f"methods: {', '.join(_accuracy.METHODS)}"
        )
    common.enable_compilation_cache()
    start = time.perf_counter()
    config = _accuracy.QUICK if args.quick else _accuracy.Config()
    result = _accuracy.study(
        config,
        cases=[n for n in names if n in _accuracy.CASES] or None,
        methods=[n for n in names if n in _accuracy.METHODS] or None,
    )
    result["machine"] = f"{platform.node()} ({platform.machine()}, {platform.processor() or 'cpu'})"
    result["date"] = time.strftime("%Y-%m-%d %H:%M %Z")
    result["total_wall_time_s"] = time.perf_counter() - start
    if args.json:
        print(common.dumps(result))
    else:
        print(_accuracy.markdown(result))
        print(
            f"\n{len(result['rows'])} runs, {'quick' if args.quick else 'full'} form, "
            f"{result['total_wall_time_s']:.0f} s in all, {result['date']} on {result['machine']}"
        )
    # a failed row of another method is a finding; a failed default-integrator row is not expected
    failed = [r for r in result["rows"] if r["method"] == "verlet" and not r["ok"]]
    return EXIT_UNEXPECTED if failed else 0


BENCHES: dict[str, tuple[str, Callable, Callable]] = {
    "stability": ("stiff and extreme scenes (docs/stability.md)", _add_stability, _stability),
    "accuracy": ("error against wall time (docs/accuracy.md)", _add_accuracy, _accuracy),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """One sub-choice per study in `BENCHES`."""
    studies = parser.add_subparsers(dest="study", required=True, metavar="STUDY")
    for name, (text, add_arguments, handler) in BENCHES.items():
        sub = studies.add_parser(name, help=text, description=text)
        add_arguments(sub)
        sub.set_defaults(study_handler=handler)


def handle(args: argparse.Namespace) -> int:
    """Handler of ``msfd bench``: run the chosen study."""
    return args.study_handler(args)
