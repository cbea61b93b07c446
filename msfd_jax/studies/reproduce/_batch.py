"""What the figure modules share: meshes, settings, batched runs with histories, plot helpers.

Compiled programs are keyed by the mesh, the static settings, `max_steps` and the batch size.
Every figure of one mode (quick or full) uses the same four of them: `partition` (a
`msfd_jax.sweep`, final values only), `histories` (a vmap of `simulate` keeping histories,
shapes and the final state), and the fine single run of Fig. 15a; `max_steps` is one bound per
mesh (the thickest beam of Fig. 10, h_b/h_r = 5, has the smallest stable step), so that no
figure compiles a program another has compiled.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..._batched.results import FAILED, RESULTS
from ..._batched.simulate import Settings, simulate
from ..._collision.provenance import json_ready
from ..._model.params import CollisionParams, Mesh, validate
from ..._model.scene import ring_on_beam
from ..._sweeps.sweep import SweepTable, collisions, sweep, sweep_step_bound

RING, BEAM = 0, 1  # chain order of ring_on_beam
THICKEST = 5.0  # the largest h_b/h_r of the reproduction (Fig. 10): the smallest stable step
PAPER_SHAPE_TIMES = (0.15, 0.49, 0.75, 1.5)  # Fig. 13a-d


def mesh(quick: bool) -> Mesh:
    """The paper's mesh (15 ring, 20 + 5 beam segments), or the tests' coarse one."""
    return Mesh(6, 8, 2) if quick else Mesh()


_CRITICAL: dict[Mesh, float] = {}


def max_steps(quick: bool, settings: Settings = Settings()) -> int:
    """One step bound per mesh and settings (`sweep_step_bound` of the thickest beam)."""
    key = mesh(quick)
    if key not in _CRITICAL:
        from ..._model.state import critical_step

        scene = ring_on_beam(CollisionParams(thickness_ratio=THICKEST), key)
        _CRITICAL[key] = float(eqx.filter_jit(critical_step)(scene))
    return sweep_step_bound(np.asarray([_CRITICAL[key]]), settings)


def partition_settings(quick: bool) -> Settings:
    """Final values only (two history samples, no shapes), as `msfd_jax.sweep` defaults."""
    return Settings(history_points=2, shape_times=(), max_steps=max_steps(quick))


def history_settings(quick: bool) -> Settings:
    """Histories sampled every 0.001 (0.005 quick) over tau in [0, 10]; the paper's shapes."""
    points = 2001 if quick else 10001
    return Settings(
        history_points=points, shape_times=PAPER_SHAPE_TIMES, max_steps=max_steps(quick)
    )


FINE_T_MAX = 0.5


def fine_settings(quick: bool) -> Settings:
    """The collision stage resolved: one Verlet step per diffrax step, tau <= 0.5 sampled every
    1e-4 (paper mesh; below the step, 1.2-2.6e-4) or 5e-4 (quick)."""
    base = Settings(
        t_max=FINE_T_MAX, history_points=1001 if quick else 5001, shape_times=(), substeps=1
    )
    return dataclasses.replace(base, max_steps=max_steps(quick, base))


def chunk(quick: bool) -> int:
    """Collisions per compiled call (one size for every figure of a mode: one program)."""
    return 8 if quick else 20


_PARTITIONS: dict = {}


def partition(rows: Sequence[Mapping[str, Any]], quick: bool) -> SweepTable:
    """The final partition of each collision (`msfd_jax.sweep`, one compiled program).

    Remembered for the process: figures that share a case list (Fig. 16 and 23-24) run it once.
    """
    key = (quick, tuple(tuple(sorted(r.items())) for r in rows))
    if key not in _PARTITIONS:
        settings = partition_settings(quick)
        _PARTITIONS[key] = sweep(list(rows), mesh(quick), settings, chunk(quick), progress=False)
    return _PARTITIONS[key]


HISTORY_CHUNK = 4


@dataclasses.dataclass
class Run:
    """One collision with its histories (numpy; energies in units of M_pr)."""

    params: dict[str, float]
    status: str
    t_end: float
    k0: float
    ts: np.ndarray  # samples up to t_end only
    history: dict[str, np.ndarray]
    shape_ts: np.ndarray
    shapes: list[np.ndarray]  # per chain: (len(shape_ts), nodes, 2)
    final: list[np.ndarray]  # per chain: (nodes, 2)
    bending: np.ndarray  # per chain, final
    axial: np.ndarray
    contact: float

    def energy(self, key: str) -> np.ndarray:
        """History of one energy as a fraction of K0: ``ring_bending``, ``beam_axial``,
        ``ring``/``beam`` (bending + axial), ``contact``, ``kinetic``, ``elastic``, ``plastic``."""
        h, k0 = self.history, self.k0
        if key in ("ring", "beam"):
            return self.energy(f"{key}_bending") + self.energy(f"{key}_axial")
        if key == "plastic":
            return self.energy("ring") + self.energy("beam") + self.energy("contact")
        if key in ("contact", "kinetic"):
            return h[key].sum(-1) / k0
        if key == "elastic":
            return h["elastic"] / k0
        name, kind = key.split("_")
        return h[kind][:, RING if name == "ring" else BEAM] / k0


@eqx.filter_jit
def _solve_batch(params: CollisionParams, mesh: Mesh, settings: Settings):
    return jax.vmap(lambda p: simulate(ring_on_beam(p, mesh), settings))(params)


def histories(rows: Sequence[Mapping[str, Any]], quick: bool, settings=None) -> list[Run]:
    """Run collisions `HISTORY_CHUNK` at a time under one vmap, keeping their histories."""
    settings = history_settings(quick) if settings is None else settings
    columns, _ = collisions(list(rows))
    the_mesh = mesh(quick)
    validate(CollisionParams(**columns), the_mesh)
    settings = jax.tree_util.tree_map(
        lambda v: jnp.asarray(v, float) if isinstance(v, float | int) else v, settings
    )
    n = len(columns["thickness_ratio"])
    runs: list[Run] = []
    for start in range(0, n, HISTORY_CHUNK):
        index = np.arange(start, min(start + HISTORY_CHUNK, n))
        padded = np.concatenate([index, np.full(HISTORY_CHUNK - len(index), index[0])])
        params = CollisionParams(**{k: jnp.asarray(v[padded]) for k, v in columns.items()})
        sol = jax.device_get(_solve_batch(params, the_mesh, settings))
        for j, i in enumerate(index):
            runs.append(_one(sol, j, {k: float(v[i]) for k, v in columns.items()}))
    return runs


def _one(sol, j: int, params: dict[str, float]) -> Run:
    pick = lambda a: np.asarray(a)[j]  # noqa: E731
    t_end = float(pick(sol.t_end))
    ts = np.asarray(sol.ts)[j]
    keep = ts <= t_end + 1e-12
    history = {k: pick(v)[keep] for k, v in sol.history.items() if k not in ("contact_pairs",)}
    history["contact_pairs"] = pick(sol.history["contact_pairs"][0])[keep]
    return Run(
        params=params,
        status=RESULTS(int(pick(sol.result))).status,
        t_end=t_end,
        k0=float(pick(sol.k0)),
        ts=ts[keep],
        history=history,
        shape_ts=pick(sol.shape_ts),
        shapes=[pick(s) for s in sol.shapes],
        final=[pick(x) for x in sol.final.x],
        bending=pick(sol.bending),
        axial=pick(sol.axial),
        contact=float(np.sum(pick(sol.contact))),
    )


# ---- reporting helpers ------------------------------------------------------------------


def succeeded(status: Sequence[str]) -> np.ndarray:
    """True for the runs whose numbers are data: not failed (non-finite, energy balance
    broken, max steps; `RESULTS.failed`). A failed run's fractions are where it stopped."""
    return ~np.isin(np.asarray(status, dtype=str), [r.status for r in FAILED])


def plot_runs(ax, x, y, ok: np.ndarray, style: str, **kwargs) -> None:
    """Plot the runs that succeeded only: a failed run is a gap in the curve, not a point."""
    ax.plot(x, np.where(ok, y, np.nan), style, **kwargs)


def mark_failed(ax, x, ok: np.ndarray, status: Sequence[str]) -> None:
    """A red cross on the x axis at each failed run, named in the legend as failed."""
    if np.all(ok):
        return
    names = sorted(set(np.asarray(status, dtype=str)[~ok]))
    x = np.asarray(x)[~ok]
    label = f"failed run, not plotted ({', '.join(names)})"
    ax.plot(x, np.zeros_like(x), "x", color="red", ms=8, mew=2, clip_on=False, label=label)


def save(fig, figures_dir: Path, name: str) -> str:
    """Save a matplotlib `Figure` as ``figures_dir / name``; return the name."""
    figures_dir = Path(figures_dir)
    figures_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(figures_dir / name, dpi=110)
    return name


def table(header: Sequence[str], rows: Sequence[Sequence[Any]], fmt: str = ".3f") -> str:
    """A markdown table; floats formatted with `fmt` (NaN, no number: a dash)."""

    def cell(v):
        if isinstance(v, float | np.floating):
            return "-" if np.isnan(v) else format(float(v), fmt)
        return str(v)

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


jsonable = json_ready  # what a figure publishes: plain JSON data (non-finite as null)


def constraint_name(value: float) -> str:
    return "constrained" if value else "free"
