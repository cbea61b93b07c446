"""Progress on stderr with tqdm: sweeps (collisions, rate, ETA) and lines of long studies.

The Python API is quiet unless asked (``progress=True``); the CLI shows progress unless
``-q/--quiet``. tqdm is imported only when a bar is shown.
"""

from __future__ import annotations

import sys


class SweepProgress:
    """Collisions done of `total` (`done` of them already there), their rate and time left.

    The rate and the time left exclude compilation: until the first group of collisions has
    finished (that group pays for compiling, or for loading the compile cache) one line names
    the stage; the bar starts after it, with that group counted as already done.
    """

    def __init__(self, total: int, done: int = 0, enabled: bool = False, name: str = "sweep"):
        self.total, self.done, self.enabled, self.name = total, done, enabled, name
        self.bar = None

    def note(self, stage: str) -> None:
        if self.enabled and self.bar is None:
            before = f", {self.done} already done" if self.done else ""
            print(
                f"msfd {self.name}: {self.total} collisions{before}; {stage} "
                "(compiling on first use; the rate starts after the first group)",
                file=sys.stderr,
                flush=True,
            )

    def update(self, n: int) -> None:
        self.done += n
        if not self.enabled:
            return
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(
                total=self.total,
                initial=self.done,
                desc=f"msfd {self.name}",
                unit=" collisions",
                file=sys.stderr,
                dynamic_ncols=True,
            )
        else:
            self.bar.update(n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class LineProgress:
    """A bar of `total` steps whose each step comes with a line of text (printed above it).

    For studies that report one line per step (tuning iterations, reproduced figures):
    ``progress = LineProgress(n, "tune"); progress(line)`` advances one step and prints the
    line; ``progress.note(line)`` prints a line without advancing.
    """

    def __init__(self, total: int | None, name: str, unit: str = " steps"):
        from tqdm import tqdm

        self.bar = tqdm(
            total=total, desc=f"msfd {name}", unit=unit, file=sys.stderr, dynamic_ncols=True
        )

    def __call__(self, line: str) -> None:
        self.bar.write(line, file=sys.stderr)
        self.bar.update(1)

    def note(self, line: str) -> None:
        self.bar.write(line, file=sys.stderr)

    def close(self) -> None:
        self.bar.close()
