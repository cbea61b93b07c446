"""``msfd tune``: registered here, implemented in `optimise` (``optimise/_cli.py``).

`optimise` imports `msfd_jax`, never the reverse at module level: the implementation is
imported when the subcommand is built or run, so ``import msfd_jax`` (or ``msfd run``) does
not load `optimise`. ``optimise._cli`` imports only the leaf `msfd_jax.cli.common`, so this
import closes no cycle.
"""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from optimise._cli import add_tune_arguments

    add_tune_arguments(parser)


def handle(args: argparse.Namespace) -> int:
    from optimise._cli import tune_command

    return tune_command(args)
