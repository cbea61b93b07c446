"""Following a collapse: when a collision is solved again with the collapse contacts.

The paper's model (one contact, ring on beam) leaves some heavy, fast or slender impacts
without an answer: a ring or beam joint folds past pi, a ring bar is crushed, the energy
balance breaks for a reason a smaller step does not fix. With `Mesh.collapse_contacts` None
(the default) such a collision is solved again with the contacts of a collapsing structure
(`msfd_jax._model.collapse`), on the fewest ring segments their validity check allows
(`collapse_mesh`). Collisions the paper's model finishes are never rerun: the paper's scenes
compile and compute exactly what they did.

Why evidence, not a check from the inputs: a lower bound on the energy a fold needs (the
plastic work of turning a joint by pi/2, (pi/2) M_p) is far below the paper's own impact
energies (the showcase's K0 = 3.9 M_pr against pi/2 M_pr for the ring's face contact), so
such a check would build the contacts in the paper's scenes, whose stability limit, steps and
numbers would change; the failed first run is a decisive check and costs only the failing rows.

`run` applies it to one collision, `solve_following_collapse` to a sweep's rows.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._batched.results import RESULTS
from .._model.params import Mesh, collapse_ring_segments
from .attempts import step_is_cause

# failures a collapse model may turn into an answer: a step bound reached is not one
FOLLOWED = (RESULTS.energy_balance_broken, RESULTS.non_finite, RESULTS.folded)


def automatic(mesh: Mesh) -> bool:
    """Whether `mesh` leaves the collapse contacts to the evidence (collapse_contacts None)."""
    return mesh.collapse_contacts is None


def collapsed(result, dt, dt_critical) -> np.ndarray:
    """True (elementwise) where a run ended in a failure the collapse contacts may answer: one
    the step retries (`attempts`) do not name the step's (a step above the stability limit
    stays the step's fault, the contacts would not help)."""
    return np.isin(np.asarray(result), FOLLOWED) & ~step_is_cause(result, dt, dt_critical)


def collapse_mesh(mesh: Mesh, slenderness) -> tuple[Mesh | None, str]:
    """`mesh` with the collapse contacts on, its ring refined where the contacts' validity check
    needs it for this slenderness; or (None, why) where no ring mesh can hold them."""
    n, why = collapse_ring_segments(slenderness, mesh.ring_segments)
    if n is None:
        return None, why
    return dataclasses.replace(mesh, ring_segments=n, collapse_contacts=True), ""


def rerun_note(mesh: Mesh, first: Mesh, message: str) -> str:
    """The message of a collision solved again with the collapse contacts."""
    refined = (
        f", the ring refined to {mesh.ring_segments} segments (from {first.ring_segments})"
        if mesh.ring_segments != first.ring_segments
        else ""
    )
    return f"solved again with the collapse contacts{refined} after: {message}; then "


def refused_note(why: str) -> str:
    """The suffix of a collapse the contacts cannot be built for."""
    return f"; the collapse contacts cannot follow it ({why})"


def follow_collapse(solve, columns: dict, mesh: Mesh, settings, *, on_rows, **kw) -> None:
    """`solve(columns, mesh, settings, on_rows=..., **kw)` (a sweep's unit of work, its step
    retries included) with the rows that end `collapsed` solved again on `collapse_mesh`
    (grouped by the ring mesh their slenderness needs). `on_rows(rows, outputs)` sees each
    row once, with the answer reported: the rerun's (its message says after what), or the
    first run's with the reason the contacts cannot be built."""
    held: list[tuple[np.ndarray, dict]] = []

    def first(rows, out):
        rows = np.asarray(rows)
        bad = collapsed(out["result"], out["dt"], out["dt_critical"])
        if (~bad).any():
            on_rows(rows[~bad], {k: np.asarray(v)[~bad] for k, v in out.items()})
        if bad.any():
            held.append((rows[bad], {k: np.asarray(v)[bad] for k, v in out.items()}))

    solve(columns, mesh, settings, on_rows=first, **kw)
    if not held:
        return
    rows = np.concatenate([r for r, _ in held])
    outs = {k: np.concatenate([o[k] for _, o in held]) for k in held[0][1]}
    slender = np.asarray(columns["slenderness"])[rows]
    meshes = [collapse_mesh(mesh, s) for s in slender]
    refused = np.asarray([m is None for m, _ in meshes])
    if refused.any():
        out = {k: v[refused] for k, v in outs.items()}
        why = [w for (m, w) in meshes if m is None]
        out["message"] = np.asarray(
            [str(t) + refused_note(w) for t, w in zip(out["message"], why, strict=True)]
        )
        on_rows(rows[refused], out)
    for n in sorted({m.ring_segments for m, _ in meshes if m is not None}):
        group = np.flatnonzero(
            np.asarray([m is not None and m.ring_segments == n for m, _ in meshes])
        )
        again = meshes[group[0]][0]
        firsts = outs["message"][group]

        def second(sub, out, group=group, firsts=firsts, again=again):
            sub = np.asarray(sub)
            out = dict(out)
            out["message"] = np.asarray(
                [
                    rerun_note(again, mesh, str(f)) + str(t)
                    for f, t in zip(firsts[sub], out["message"], strict=True)
                ]
            )
            on_rows(rows[group[sub]], out)

        sub_columns = {k: np.asarray(v)[rows[group]] for k, v in columns.items()}
        solve(sub_columns, again, settings, on_rows=second, **kw)
