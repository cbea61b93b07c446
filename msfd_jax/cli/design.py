"""``msfd design``: registered here, implemented in `optimise` (``optimise/_design_cli.py``).

As ``tune``: the implementation is imported only when the subcommand is built or run, so
``import msfd_jax`` (or ``msfd run``) does not load `optimise`.
"""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from optimise._design_cli import add_design_arguments

    add_design_arguments(parser)


def handle(args: argparse.Namespace) -> int:
    from optimise._design_cli import design_command

    return design_command(args)
