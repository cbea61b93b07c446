"""User-facing results: the energy partition, checks, and readable failure messages."""

from __future__ import annotations

import dataclasses
import functools
import time
from typing import Any

import jax
import numpy as np

from .._batched.engine import FOLD_LIMIT
from .._batched.results import BALANCE_TOLERANCE, FAILED, RESULTS
from .._batched.simulate import (
    Settings,
    Solution,
    _simulate,
    array_module,
    prepare,
)
from .._model.collapse import COLLAPSE_TYPES
from .._model.params import CollisionParams, Mesh, Scales
from .._model.scene import Scene, ring_on_beam
from .._model.si import design_quantities
from .._runtime.export import compile_program
from .._runtime.mappings import release_if_near_limit
from . import collapse as _collapse
from .attempts import (
    RETRY_NOTE,
    STEP_CAUSE,
    keep_earlier,
    needs_retry,
    retry_headroom,
    smaller_step,
)
from .provenance import mesh_json, params_json, settings_json, versions

FRACTION_KEYS = (
    "beam_bending",
    "beam_axial",
    "ring_bending",
    "ring_axial",
    "contact",
    "kinetic",
    "elastic",
)


class SimulationError(RuntimeError):
    """A run that went non-finite, broke its energy balance, or ran out of steps.

    `collision` is the failed `Collision` when `run` raised it (None otherwise), so that a
    caller can still report the inputs and where the run stopped.
    """

    def __init__(self, message: str, collision: Collision | None = None):
        super().__init__(message)
        self.collision = collision


def fractions(solution: Solution, scene: Scene) -> dict[str, Any]:
    """Energy partition as fractions of K0 (arrays; batched if the solution is).

    Keys: ``beam_bending, beam_axial, ring_bending, ring_axial, contact, kinetic, elastic``
    (absent structures give 0; ``contact`` is the plastic work of every contact set, and
    ``contact_collapse`` its part in the collapse contacts of `Mesh.collapse_contacts`) and
    the kinetic split ``kinetic_ring, kinetic_block,
    kinetic_beam`` (the ring's share excludes the block g).
    """
    k0 = solution.k0
    xp = array_module(k0)  # numpy for a host copy (`Collision`): no eager jax dispatch
    out: dict[str, Any] = {}
    zeros = xp.zeros_like(k0)
    for name in ("beam", "ring"):
        i = scene.chain_index(name)
        out[f"{name}_bending"] = zeros if i is None else solution.bending[..., i] / k0
        out[f"{name}_axial"] = zeros if i is None else solution.axial[..., i] / k0
    out["contact"] = xp.sum(solution.contact, -1) / k0
    # the collapse contacts' share of "contact" (0 without them)
    collapse = [isinstance(k, COLLAPSE_TYPES) for k in scene.contacts]
    out["contact_collapse"] = (
        xp.sum(solution.contact[..., np.asarray(collapse)], -1) / k0 if any(collapse) else zeros
    )
    out["kinetic"] = xp.sum(solution.kinetic, -1) / k0
    out["elastic"] = solution.elastic / k0
    ring, beam = scene.chain_index("ring"), scene.chain_index("beam")
    block = solution.kinetic_block / k0
    out["kinetic_ring"] = zeros if ring is None else solution.kinetic[..., ring] / k0 - block
    out["kinetic_block"] = block
    out["kinetic_beam"] = zeros if beam is None else solution.kinetic[..., beam] / k0
    return out


def diagnose(solution: Solution, scene: Scene, index: int | None = None) -> str:
    """A readable account of how one run ended: when, where, likely cause and remedy."""
    sol = solution if index is None else jax.tree_util.tree_map(lambda a: a[index], solution)
    code = int(sol.result)
    t = float(sol.t_end)
    dt, dt_crit = float(sol.dt), float(sol.dt_critical)
    if code == RESULTS.settled:
        return (
            f"settled: plastic dissipation stopped; ended at tau = {t:.4g}"
            + _balance(sol)
            + _through_face(sol, scene)
        )
    if code == RESULTS.time_limit:
        return (
            f"reached the time cap tau = {t:.4g} (dissipation had not stopped)"
            + _balance(sol)
            + _through_face(sol, scene)
        )
    if code == RESULTS.max_steps:
        return (
            f"stopped at tau = {t:.4g} after the maximum number of steps ({int(sol.steps)}); "
            "raise Settings.max_steps or the step size"
        )
    where = []
    for c, x, v in zip(scene.chains, sol.final.x, sol.final.v, strict=True):
        bad = ~(np.isfinite(np.asarray(x)).all(-1) & np.isfinite(np.asarray(v)).all(-1))
        if bad.any():
            where.append(f"{c.name} node {int(np.argmax(bad))}")
    place = ", ".join(where) if where else "energy bookkeeping"
    ratio = dt / dt_crit
    if ratio > STEP_CAUSE:
        cause = (
            f"the step dt = {dt:.3g} is {ratio:.2f} x the computed stability limit {dt_crit:.3g}"
        )
        remedy = "lower Settings.safety (CLI --safety) or give a smaller dt"
    else:
        collapse = _degenerate(sol, scene)
        cause = f"not the step (dt = {ratio:.2f} x the stability limit): " + (
            collapse
            or "a deformation the mesh cannot follow (ring nodes slipping between beam nodes "
            "or leaving the contact region) or an extreme parameter"
        )
        modelled = _has_collapse_contacts(scene)
        remedy = (
            "the impact is beyond what the discrete model represents: "
            + (
                ""
                if modelled
                else "model the collapse (Mesh(collapse_contacts=True), CLI "
                "--collapse-contacts) or "
            )
            + "lower the velocity or the mass; a smaller dt does not help"
            if collapse
            else "refine the mesh (Mesh.refined) or lower the velocity; a smaller dt rarely helps"
        )
    what = "became non-finite" if code == RESULTS.non_finite else "broke its energy balance"
    balance = code in (RESULTS.energy_balance_broken, RESULTS.folded)
    err = float(sol.energy_balance_error) if balance else float("nan")
    detail = f" (error {err:.3g} K0)" if code == RESULTS.energy_balance_broken else ""
    fold = _folded(sol, scene) if balance else ""
    if fold and np.isfinite(err):  # the fold guard (`_batched.engine.FOLD_LIMIT`), not the balance
        if _has_collapse_contacts(scene):
            why = "the collapse contacts did not stop the fold"
            remedy = "refine the ring (Mesh.ring_segments) or lower the velocity or the mass"
        else:
            why = "the paper's model has no contact to stop it (" + (
                "the beam against its mirror half across the symmetry plane)"
                if "beam joint" in fold
                else "the ring against itself, the block's face or the symmetry plane)"
            )
            remedy = (
                "model the collapse (Mesh(collapse_contacts=True), CLI --collapse-contacts) "
                "or lower the velocity or the mass"
            )
        return (
            f"the solve stopped at tau = {t:.4g} (energy balance error {err:.3g} K0): a "
            f"{fold.removeprefix('; warning: ')}; {why}; remedy: {remedy}; a smaller dt "
            "does not help"
        )
    return (
        f"the solve {what}{detail} at tau = {t:.4g} in the {place}; likely cause: {cause}; "
        f"remedy: {remedy}"
    )


def balance_warning(solution: Solution):
    """True where a run reports success (settled, time limit) but its energy balance closes
    only to worse than `BALANCE_TOLERANCE` K0 (arrays; batched if the solution is)."""
    result = np.asarray(solution.result)
    success = (result == RESULTS.settled) | (result == RESULTS.time_limit)
    return success & (np.abs(np.asarray(solution.energy_balance_error)) > BALANCE_TOLERANCE)


def _has_collapse_contacts(scene: Scene) -> bool:
    """Whether the scene was built with the collapse contacts (`Mesh.collapse_contacts`)."""
    return any(isinstance(k, COLLAPSE_TYPES) for k in scene.contacts)


def through_face(scene: Scene, ring_x) -> tuple[int, float]:
    """(node, depth): the ring node whose centre line ended deepest past the block's face, the
    plane y = y_G through the ring's end G, and how far (in R; <= 0: none past it). (-1, nan)
    for a scene without a ring clamped to a block."""
    ring = scene.chains[0] if scene.chains else None
    if ring is None or ring.name != "ring" or ring.end != "clamped":
        return -1, float("nan")
    x = np.asarray(ring_x)
    depth = x[-1, 1] - x[:-1, 1]  # the ring lies on the side y > y_G of the face
    k = int(np.argmax(depth))
    return k, float(depth[k])


def _through_face(sol: Solution, scene: Scene) -> str:
    """The message's suffix for a success of the paper's model whose ring ended partly past the
    block's face: the ring went through the block, a contact that model does not have (the
    collapse contacts' `BlockFaceContact` has it). Not silent: the partition is the paper's
    model's, and the remedy is named."""
    if _has_collapse_contacts(scene):
        return ""
    k, depth = through_face(scene, sol.final.x[0])
    if not depth > 0.0:
        return ""
    return (
        f"; warning: ring node {k} ended {depth:.3g} R past the block's face (the paper's "
        "model has no contact of the ring with the block: the ring went through it, and the "
        "partition is that model's); Mesh(collapse_contacts=True) (CLI --collapse-contacts) "
        "models the contact"
    )


def _balance(sol: Solution) -> str:
    """The message's suffix for a successful run whose balance is not closed to tolerance."""
    if not bool(balance_warning(sol)):
        return ""
    err = abs(float(sol.energy_balance_error))
    return (
        f"; balance {err:.1e} K0 (above {BALANCE_TOLERANCE:g}: fractions uncertain by about "
        "that much; a smaller Settings.safety or contact_smoothing may close it)"
    )


def _folded(sol: Solution, scene: Scene) -> str:
    """Which joint has folded past `FOLD_LIMIT` (pi: its bars through each other), if any.

    The joint angle is continuous past pi (`_model.safe.unwrap_near`), so the energy balance holds,
    but the bars then overlap: the paper's model has no contact to stop it (the collapse
    contacts, `_model.collapse`, do where a scene has them), so the engine stops the run there
    (`RESULTS.folded`, this message).
    """
    for c, rotation in zip(scene.chains, sol.final.plastic_rotation, strict=True):
        rotation = np.abs(np.asarray(rotation))
        if rotation.size and rotation.max() > FOLD_LIMIT:
            k = int(np.argmax(rotation))
            return (
                f"; warning: {c.name} joint at node {c.joint_nodes[k]} folded by "
                f"{rotation[k]:.2f} rad, past pi (its bars through each other)"
            )
    return ""


def _degenerate(sol: Solution, scene: Scene) -> str | None:
    """Name a bar crushed towards zero length or a joint folded near 180 degrees, if any."""
    for c, x in zip(scene.chains, sol.final.x, strict=True):
        x = np.asarray(x)
        if not np.isfinite(x).all():
            continue
        strain = np.asarray(c.axial_strain(x))
        fold = np.abs(np.asarray(c.joint_angles(x) - c.joint_angles(c.reference)))
        if strain.min() < -0.5:
            i = int(np.argmin(strain))
            return (
                f"{c.name} bar {i} is crushed to {100 * (1 + strain[i]):.0f} % of its length "
                "(axial strain {:.2f}); the discrete model cannot follow such a collapse".format(
                    strain[i]
                )
            )
        if fold.max() > 0.9 * np.pi:
            k = int(np.argmax(fold))
            return f"{c.name} joint at node {c.joint_nodes[k]} has folded by {fold[k]:.2f} rad"
    return None


@dataclasses.dataclass
class Collision:
    """One finished ring-on-beam collision, with its partition and provenance.

    `settings` are the settings asked for (a rerun from `to_json` is the same run).
    `scales` are the SI unit scales when the collision was given in SI (then `si` holds the
    design quantities in SI, whole structure).
    """

    params: CollisionParams
    mesh: Mesh
    scene: Scene
    solution: Solution
    wall_time_s: float
    compile_time_s: float = float("nan")
    settings: Settings | None = None
    contact_smoothing: float = 0.0
    yield_smoothing: float = 0.0
    scales: Scales | None = None
    si_inputs: dict[str, float] | None = None
    retries: int = 0
    retried_after: str | None = None
    retry_note: str = ""
    collapse_note: str = ""  # solved again with the collapse contacts: after what

    @functools.cached_property
    def _host(self) -> Solution:
        """The solution copied to host numpy arrays once (read-outs without jax dispatch)."""
        return jax.device_get(self.solution)

    @property
    def fractions(self) -> dict[str, float]:
        return {k: float(v) for k, v in fractions(self._host, self.scene).items()}

    @property
    def energy_balance_error(self) -> float:
        return float(self._host.energy_balance_error)

    @property
    def status(self) -> str:
        return RESULTS(int(self.solution.result)).status

    @property
    def safety(self) -> float:
        """The step used over the stability limit, dt / dt_crit (after any retries)."""
        return float(self.solution.dt) / float(self.solution.dt_critical)

    @property
    def balance_warning(self) -> bool:
        """True if the run reports success but closes its energy balance only to worse than
        `BALANCE_TOLERANCE` (1e-4) K0 (its message then says how far)."""
        return bool(balance_warning(self._host))

    @property
    def message(self) -> str:
        text = diagnose(self._host, self.scene) + self.retry_note
        if self.retries:
            text = (
                f"retried with dt = {float(self.solution.dt):.3g} ({self.safety:.3g} x the "
                f"stability limit, {self.retries} retries) after: {self.retried_after}; then "
                f"{text}"
            )
        return self.collapse_note + text

    @property
    def si(self) -> dict[str, Any] | None:
        """SI design quantities of the whole structure (`_model.si`), or None without SI."""
        return None if self.scales is None else design_quantities(self, self.scales)

    def to_json(self) -> dict[str, Any]:
        """The record of ``msfd run --json``: results, inputs, mesh, settings, versions."""
        f = self.fractions
        record = {
            "fractions": {k: f[k] for k in FRACTION_KEYS},
            "kinetic_split": {k: f[k] for k in ("kinetic_ring", "kinetic_block", "kinetic_beam")},
            "energy_balance_error": self.energy_balance_error,
            "t_end": float(self.solution.t_end),
            "steps": int(self.solution.steps),
            "dt": float(self.solution.dt),
            "dt_critical": float(self.solution.dt_critical),
            "k0": float(self.solution.k0),
            "status": self.status,
            "message": self.message,
            "retries": self.retries,
            "safety": self.safety,
            "balance_warning": self.balance_warning,
            "t_max": float(self._host.ts[-1]),  # the cap used (derived when t_max is None)
            "wall_time_s": self.wall_time_s,
            "compile_time_s": self.compile_time_s,
            "params": params_json(self.params),
        }
        record["mesh"] = mesh_json(self.mesh)
        if self.mesh.collapse_contacts:
            record["contact_collapse"] = f["contact_collapse"]  # part of fractions.contact
        if self.settings is not None:
            record["settings"] = {
                **settings_json(self.settings),
                "contact_smoothing": float(self.contact_smoothing),
                "yield_smoothing": float(self.yield_smoothing),
            }
        record["versions"] = versions()
        if self.scales is not None:
            record["si"] = self.si
            record["si_scales"] = vars(self.scales)  # the former key, kept for old readers
            if self.si_inputs is not None:
                record["si_inputs"] = dict(self.si_inputs)
        return record


def run(
    params: CollisionParams = CollisionParams(),
    mesh: Mesh = Mesh(),
    settings: Settings = Settings(),
    *,
    contact_smoothing: float = 0.0,
    yield_smoothing: float = 0.0,
    check: bool = True,
    scales: Scales | None = None,
    si_inputs: dict[str, float] | None = None,
) -> Collision:
    """Run one ring-on-beam collision with every input checked; raise if it failed.

    Raises `SimulationError` (with `diagnose`'s message and the failed `Collision`) when the
    run went non-finite, broke its energy balance or hit the step bound, unless
    ``check=False``. A run stopped for a reason a smaller step can fix (`step_is_cause`) is
    first rerun with the step halved, at most `MAX_RETRIES` times (`attempts`); so is a run
    that reports success with its balance open by more than `BALANCE_RETRY_ABOVE` (1e-4,
    = `BALANCE_TOLERANCE`) K0, at most `BALANCE_RETRIES` halvings (`needs_retry`; a run
    still open then is flagged, `balance_warning`). The attempt reported is the last one, or the
    successful one with the smallest |error| (`keep_earlier`; its message then ends with
    `RETRY_NOTE`); `retries` and `safety` are those of the reported run, its message names
    the first run's failure or open balance.
    With `scales` (from `from_si`, or use `run_si`) the result also has the
    SI design quantities (`Collision.si`); `si_inputs` are recorded in its JSON.
    """
    for name, value, kind in (
        ("params", params, CollisionParams),
        ("mesh", mesh, Mesh),
        ("settings", settings, Settings),
    ):
        if not isinstance(value, kind):
            raise TypeError(f"{name} must be a msfd_jax.{kind.__name__}, got {value!r}")
    for name, value in [*params.scalars().items()] + [
        ("contact_smoothing", contact_smoothing),
        ("yield_smoothing", yield_smoothing),
    ]:
        if np.ndim(value) != 0:
            raise ValueError(
                f"{name} must be a single value: run() simulates one collision "
                "(use msfd_jax.sweep or jax.vmap over simulate for many)"
            )
    if params.graded and np.ndim(params.thickness_profile) != 1:
        raise ValueError(
            "thickness_profile must be one list of h_k/h_r (one value per beam segment): "
            "run() simulates one collision (use msfd_jax.sweep for many profiles)"
        )
    release_if_near_limit()  # before compiling: XLA would crash past vm.max_map_count
    scene = ring_on_beam(
        params, mesh, contact_smoothing=contact_smoothing, yield_smoothing=yield_smoothing
    )
    if scales is not None and not isinstance(scales, Scales):
        raise TypeError(f"scales must be a msfd_jax.Scales (from from_si), got {scales!r}")
    solved = settings
    solution, wall, compile_s, loop = _solve_timed(scene, solved, headroom=retry_headroom())
    attempt, first, first_text, note = 0, None, None, ""
    best = (solution, wall, 0)
    # the decisions read the balance on the host, as the record reports it (`Collision`):
    # eager jax ops would each load a small program in a new process
    while bool(
        needs_retry(
            solution.result,
            solution.dt,
            solution.dt_critical,
            _host_balance(solution),
            attempt,
        )
    ):
        first_text = first_text or diagnose(solution, scene)
        solved, attempt = smaller_step(solved), attempt + 1
        # the same scene: its stability limit is the first attempt's, not computed again
        # the first attempt's program: its loop bound has room for the halved steps
        solution, run_s, more, _ = _solve_timed(scene, solved, solution.dt_critical, loop)
        compile_s += more
        kept = best[0]
        if bool(
            keep_earlier(
                kept.result,
                _host_balance(kept),
                solution.result,
                _host_balance(solution),
            )
        ):
            note = RETRY_NOTE
        else:
            best, note = (solution, run_s, attempt), ""
    solution, wall, retries = best
    first = first_text if retries else None
    collision = Collision(
        params,
        mesh,
        scene,
        solution,
        wall,
        compile_time_s=compile_s,
        settings=settings,
        contact_smoothing=float(contact_smoothing),
        yield_smoothing=float(yield_smoothing),
        scales=scales,
        si_inputs=si_inputs,
        retries=retries,
        retried_after=first,
        retry_note=note,
    )
    if _collapse.automatic(mesh) and bool(
        _collapse.collapsed(solution.result, solution.dt, solution.dt_critical)
    ):
        collision = _follow_collapse(collision, check)
    if check and int(collision.solution.result) in FAILED:
        raise SimulationError(collision.message, collision)
    return collision


def _follow_collapse(first: Collision, check: bool) -> Collision:
    """`first` (the paper's model, failed) solved again with the collapse contacts
    (`_collision.collapse`); `first` with the reason where they cannot be built."""
    mesh, why = _collapse.collapse_mesh(first.mesh, first.params.slenderness)
    if mesh is None:
        first.retry_note += _collapse.refused_note(why)
        return first
    again = run(
        first.params,
        mesh,
        first.settings,
        contact_smoothing=first.contact_smoothing,
        yield_smoothing=first.yield_smoothing,
        check=False,
        scales=first.scales,
        si_inputs=first.si_inputs,
    )
    again.collapse_note = _collapse.rerun_note(mesh, first.mesh, first.message)
    again.wall_time_s += first.wall_time_s
    again.compile_time_s += first.compile_time_s
    return again


def _host_balance(solution: Solution) -> np.ndarray:
    """`Solution.energy_balance_error` computed with numpy on a host copy (`array_module`)."""
    return jax.device_get(solution).energy_balance_error


def _solve_timed(scene: Scene, settings: Settings, dt_critical=None, loop_steps=0, headroom=1):
    """(solution, run seconds, compile seconds, diffrax's loop bound): compiled (or loaded from
    the cache) first, then run, so the two are timed apart; with the CLI's store on, the
    program is a stored serialized one (no tracing). The loop bound is at least `loop_steps`
    and `headroom` times the run's step bound (`prepare`): a rerun given the first attempt's
    bound reuses its program."""
    start = time.perf_counter()
    args = prepare(
        scene, settings, dt_critical=dt_critical, loop_steps=loop_steps, headroom=headroom
    )
    compiled = compile_program(_simulate, *args, name="simulate")
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    solution = jax.block_until_ready(compiled(*args))
    return solution, time.perf_counter() - start, compile_s, args[2]


def run_si(
    mesh: Mesh = Mesh(),
    settings: Settings = Settings(),
    *,
    contact_smoothing: float = 0.0,
    yield_smoothing: float = 0.0,
    check: bool = True,
    **si: Any,
) -> Collision:
    """`run` from SI inputs (`from_si`'s keywords; missing ones are `PAPER_SI`'s).

    The result has `Collision.si`, the design quantities of the whole structure in SI.
    """
    from .._model.params import PAPER_SI, from_si, si_impact_speed

    if "velocity" in si:  # the former SI name of the impact speed
        si["impact_speed"] = si_impact_speed(si.get("impact_speed"), si.pop("velocity"))
    unknown = sorted(set(si) - set(PAPER_SI) - {"beam_width", "axial_constraint"})
    if unknown:
        allowed = ", ".join(sorted({*PAPER_SI, "beam_width", "axial_constraint"}))
        raise TypeError(f"unknown SI inputs {unknown}; allowed: {allowed}")
    inputs = {**PAPER_SI, **si}
    params, scales = from_si(**inputs)
    return run(
        params,
        mesh,
        settings,
        contact_smoothing=contact_smoothing,
        yield_smoothing=yield_smoothing,
        check=check,
        scales=scales,
        si_inputs={
            k: (bool(v) if k == "axial_constraint" else float(v))
            for k, v in inputs.items()
            if v is not None
        },
    )
