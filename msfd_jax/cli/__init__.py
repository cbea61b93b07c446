"""Command line ``msfd``: one module per subcommand, registered in `COMMANDS`.

``run`` simulates one collision, ``sweep`` a batch, ``bench`` and ``reproduce`` run the
studies (`msfd_jax.studies`), ``tune`` and ``design`` come from `optimise`. Each
subcommand module gives ``add_arguments(parser)`` and ``handle(args) -> exit code``; what
they share (argument groups, exit codes, `UsageError`, the compile cache) is the leaf
`msfd_jax.cli.common`, which imports no subcommand.

Exit codes: 0 success, 2 bad input (argparse or parameter validation), 3 failed solve
(``bench``: 1 some row not as expected; ``tune``: 4 target not met).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

import msfd_jax

from . import bench, case, design, reproduce, run, sweep, tune
from .common import (
    EXIT_OK,
    EXIT_SOLVE,
    EXIT_USAGE,
    UsageError,
    add_collision_arguments,
    add_numerics_arguments,
    checked,
    collision_from_args,
    dumps,
    enable_compilation_cache,
    mesh_from_args,
    settings_from_args,
)
from .run import report

__all__ = [
    "COMMANDS",
    "EXIT_OK",
    "EXIT_SOLVE",
    "EXIT_USAGE",
    "UsageError",
    "add_collision_arguments",
    "add_numerics_arguments",
    "build_parser",
    "checked",
    "collision_from_args",
    "enable_compilation_cache",
    "main",
    "mesh_from_args",
    "report",
    "settings_from_args",
]

COMMANDS: dict[str, tuple[str, Callable, Callable]] = {
    "run": (
        "simulate one collision (default: the paper's Fig. 13 showcase)",
        run.add_arguments,
        run.handle,
    ),
    "bench": (
        f"recorded studies: msfd bench {{{','.join(bench.BENCHES)}}}",
        bench.add_arguments,
        bench.handle,
    ),
    "sweep": (
        "run a grid or list of collisions, batched (vmap)",
        sweep.add_arguments,
        sweep.handle,
    ),
    "reproduce": (
        "regenerate the paper's Sect. 4 figures and numbers",
        reproduce.add_arguments,
        reproduce.handle,
    ),
    "tune": (
        "tune the beam thickness to a target energy split",
        tune.add_arguments,
        tune.handle,
    ),
    "design": (
        "design a graded beam (a thickness per segment) under limits, in SI",
        design.add_arguments,
        design.handle,
    ),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``msfd`` parser; with `command`, only that subcommand gets its options.

    Building only the one subcommand that runs keeps a new process from importing what
    the others need (``tune``'s options come from `optimise`, which loads optax).
    """
    parser = argparse.ArgumentParser(
        prog="msfd", description="Ring-on-beam collisions with the MS-FD model (Ruan & Yu 2003)."
    )
    parser.add_argument("--version", action="version", version=f"msfd-jax {msfd_jax.__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    parser.commands = {}  # name -> subparser (case files set its defaults)
    for name, (text, add_arguments, handler) in COMMANDS.items():
        sub = commands.add_parser(name, help=text, description=text)
        if command is None or name == command:
            add_arguments(sub)
            _state_defaults(sub)
        sub.set_defaults(handler=handler)
        parser.commands[name] = sub
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """The subcommand `argv` names (its first word that is not an option), if a known one."""
    word = next((a for a in argv if not a.startswith("-")), None)
    return word if word in COMMANDS else None


def _state_defaults(parser: argparse.ArgumentParser) -> None:
    """Append its default to every option's help that does not state one."""
    for action in parser._actions:
        if action.help == argparse.SUPPRESS or action.dest in ("help", "version"):
            continue
        if isinstance(action, argparse._SubParsersAction):  # a required choice: no default
            continue
        text = action.help or action.dest.replace("_", " ")
        if "default" in text:
            continue
        value = action.default
        if action.nargs == 0 and value in (False, None):
            shown = "off"
        elif value is None:
            shown = "none"
        elif isinstance(value, list | tuple):
            shown = ",".join(map(str, value)) or "none"
        else:
            shown = str(value)
        action.help = f"{text} (default: {shown.replace('%', '%%')})"


def _with_files(parser: argparse.ArgumentParser, args, argv) -> argparse.Namespace:
    """Parse again with the defaults of --from-json and the case file (the line overrides)."""
    from_json, case_file = getattr(args, "from_json", None), getattr(args, "case", None)
    if from_json is None and case_file is None:
        return args
    sub = parser.commands[args.command]
    defaults = {} if from_json is None else run.json_defaults(from_json)
    if case_file is not None:
        defaults.update(case.load(case_file, sub))
    sub.set_defaults(**defaults)
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``msfd``; returns the exit code (0 ok, 2 bad input, 3 failed solve)."""
    parser = build_parser(_command_of(sys.argv[1:] if argv is None else argv))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse has printed its message
        return EXIT_OK if exit_.code is None else int(exit_.code)
    try:
        args = _with_files(parser, args, argv)
        return args.handler(args)
    except UsageError as error:
        print(f"msfd: error: {error}", file=sys.stderr)
        if getattr(args, "json", False) and args.command == "run":
            inputs = {"argv": list(sys.argv[1:] if argv is None else argv)}
            print(dumps(run.failure_record("bad input", str(error), inputs)))
        return EXIT_USAGE
