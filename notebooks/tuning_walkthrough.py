# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Tuning a guardrail for an energy split (`optimise`)
#
# A designer states how the collision energy K0 should be shared, say "the beam takes 35 % of
# K0", and `optimise` finds the beam thickness ratio h_b/h_r by gradients through the whole
# simulation, plasticity and contact included. This notebook looks at the objective over the
# thickness (sharp and smoothed model), compares the gradients (forward mode, reverse mode,
# finite differences), tunes one collision and then tunes the *expected* split over several
# impact conditions.
#
# Everything runs on a coarse mesh (6 ring segments, 8 + 2 beam segments) and a short run
# (t_max = 1.5, not until settled, so part of K0 is still kinetic at the end) so that the
# notebook executes in the test suite (on the problems tests/test_optimise.py compiles); the
# same calls work on `m.Mesh()` and `m.Settings()` (see `msfd tune --help`).

# %%
import time
import warnings

import jax
import matplotlib.pyplot as plt
import numpy as np

jax.config.update("jax_enable_x64", True)

import msfd_jax as m  # noqa: E402
import optimise as o  # noqa: E402

# %% [markdown]
# ## Two problems: the showcase alone, and two impact conditions
#
# A `Problem` fixes what does not change while the design does: the collision, the mesh, the
# integration settings (with a step bound `max_steps` covering the whole design box). With
# `Conditions` it evaluates several impact conditions (ring velocity v0, block mass ratio g)
# in one program, `jax.vmap`ped over the samples, and every objective sees the expected
# partition, the weighted mean of the samples' fractions of K0 (equal weights here; the
# weights are arrays, so other weights compile nothing new).
#
# `single` is the paper's showcase alone (v0 = 0.82, g = 10); `robust` pairs a slow light
# block with a fast heavy one. The time step is held fixed (`dt`) so that finite differences
# see the same discrete map as the derivatives (msfd_jax keeps the stable step out of the
# derivative).

# %%
mesh = m.Mesh(ring_segments=6, beam_contact_segments=8, beam_outer_segments=2)
settings = m.Settings(t_max=1.5, dt=2.0e-4, history_points=31, shape_times=(0.5,))
box = o.default_box(o.Design(thickness_ratio=2.5))  # h_b/h_r in [0.5, 5]
expected = o.Conditions(velocity=[0.7, 1.0], mass_ratio=[5.0, 20.0])  # equal weights
single = o.make_problem(m.CollisionParams(), mesh, settings, box)
robust = o.make_problem(m.CollisionParams(), mesh, settings, box, conditions=expected)
print("max_steps", single.settings.max_steps, "diffrax steps of", settings.substeps)

# %% [markdown]
# ## The objective over thickness, sharp and smoothed
#
# The goal: the beam (bending + axial plastic work) takes 35 % of K0. The sharp model (the
# paper's clipped return mapping, hard contact) is what we design for; the smoothed one
# (softplus yield at s = 0.05 of the yield value, contact smoothed over w = 0.01 R) is what
# gives clean slopes, at the price of a bias in the partition
# (`benchmarks/results/smoothing_bias.md`).

# %%
goal = o.objective(o.TargetShare("beam", 0.35))
smooth = dict(yield_smoothing=0.05, contact_smoothing=0.01)
thickness = np.linspace(0.5, 5.0, 16)
start = time.perf_counter()
sharp_share, smooth_share = [], []
for h in thickness:
    design = o.Design(thickness_ratio=h)
    sharp_share.append(float(o.share(o.evaluate(design, single, goal).fractions, "beam")))
    fractions = o.evaluate(design, single, goal, **smooth).fractions
    smooth_share.append(float(o.share(fractions, "beam")))
print(f"{2 * len(thickness)} evaluations in {time.perf_counter() - start:.1f} s (with compiling)")

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.5))
left.plot(thickness, sharp_share, "o-", label="sharp")
left.plot(thickness, smooth_share, "s--", label="smoothed (s = 0.05, w = 0.01)")
left.axhline(0.35, color="k", lw=0.8, label="target")
left.set(xlabel="$h_b/h_r$", ylabel="beam share of $K_0$", title="showcase collision")
left.legend()
right.plot(thickness, (np.array(sharp_share) - 0.35) ** 2, "o-", label="sharp")
right.plot(thickness, (np.array(smooth_share) - 0.35) ** 2, "s--", label="smoothed")
right.set(xlabel="$h_b/h_r$", ylabel="$J = (\\mathrm{share} - 0.35)^2$", title="objective")
right.legend()
fig.tight_layout()

# %% [markdown]
# ## Gradients: forward mode, reverse mode and finite differences
#
# `o.gradient` differentiates the whole simulation: forward mode pushes one tangent through
# the solve with `jax.jvp` (cheap for one or a few design variables), reverse mode sweeps
# back through diffrax's checkpointed adjoint (one sweep for any number of variables). On the
# smoothed model both agree with central differences of the same model; on the sharp model
# the derivative is exact for the discrete map, but jagged in the design.

# %%
at = o.Design(thickness_ratio=2.0)
start = time.perf_counter()
_, forward = o.gradient(at, single, goal, mode="forward", **smooth)
print(f"forward (jvp):       {float(forward.thickness_ratio):+.6e}")
_, reverse = o.gradient(at, single, goal, mode="reverse", **smooth)
print(f"reverse (adjoint):   {float(reverse.thickness_ratio):+.6e}")
fd = o.finite_difference(at, single, goal, step=1e-3, **smooth)
print(f"central differences: {float(fd.thickness_ratio):+.6e}")
# the sharp model: both widths zero (the default is the smoothed model); optimise warns
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", o.SharpGradientWarning)
    sharp = dict(yield_smoothing=0.0, contact_smoothing=0.0)
    _, sharp_slope = o.gradient(at, single, goal, mode="forward", **sharp)
warned = caught[0].category.__name__
print(f"sharp model (jvp):   {float(sharp_slope.thickness_ratio):+.6e}  ({warned})")
print(f"({time.perf_counter() - start:.1f} s with compiling)")
# what the text claims: the two modes agree to rounding, central differences to O(step^2)
fwd, rev, cd = (float(g.thickness_ratio) for g in (forward, reverse, fd))
assert abs(rev - fwd) <= 1e-8 * abs(fwd) and abs(cd - fwd) <= 1e-2 * abs(fwd)

# %% [markdown]
# ## Tuning the showcase collision
#
# `o.tune` takes projected Adam steps in the unit box with annealed smoothing (three stages,
# smoothing towards zero). At each step the objective and its derivative with respect to the
# partition come from the sharp model, only the slope of the partition in the design from
# the smoothed one, so the smoothing's bias does not move the answer; the design is accepted
# when the *sharp* model meets the target within 0.01 K0. If the steps stall where the sharp
# share jumps, a regula falsi on the sharp model between two designs that bracket the target
# finishes the job; a target no design reaches is reported as unreachable.

# %%
result = o.tune(o.Design(thickness_ratio=3.0), single, goal, progress=print)
print(result.message)
check = o.evaluate(result.design, single, goal)  # an independent sharp-model check
print(f"sharp beam share at the design: {float(o.share(check.fractions, 'beam')):.4f}")

# %%
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.5))
steps = np.arange(1, result.iterations + 1)
left.plot(steps, [d["thickness_ratio"] for d in result.design_history], "o-")
left.set(xlabel="evaluation", ylabel="$h_b/h_r$", title="tuning path")
right.semilogy(steps, result.objective_history, "o-")
right.set(xlabel="evaluation", ylabel="J (sharp model)", title="objective")
fig.tight_layout()

# %% [markdown]
# An unreachable target says so, with the range of shares the sharp model gives over the box:

# %%
far = o.tune(
    o.Design(thickness_ratio=2.5), single, o.objective(o.TargetShare("beam", 0.99)), progress=None
)
print(far.status, "-", far.message)

# %% [markdown]
# ## Robust tuning: the expected split over impact conditions
#
# A guardrail is hit at many speeds by many vehicles. With equal weights over the two
# samples (v0, g) = (0.7, 5), (1.0, 20), the same call tunes the *expected*
# beam share; the sharp model's check at the found design also gives each sample's share and
# their spread.

# %%
robust_result = o.tune(o.Design(thickness_ratio=3.0), robust, goal, progress=None)
print(robust_result.message)
for c, f in zip(robust_result.conditions, robust_result.samples, strict=True):
    beam = f["beam_bending"] + f["beam_axial"]
    print(f"v0 = {c['velocity']:.2f}, g = {c['mass_ratio']:4.1f}: beam share {beam:.4f}")
print("expected:", {k: round(v, 4) for k, v in robust_result.spread["beam"].items()})
print(
    f"showcase-only design h_b/h_r = {result.design.as_floats()['thickness_ratio']:.3f}, "
    f"robust design h_b/h_r = {robust_result.design.as_floats()['thickness_ratio']:.3f}"
)
