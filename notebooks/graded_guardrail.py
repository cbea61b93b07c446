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
# # A graded guardrail: thickness along the span by gradients, in SI
#
# The paper's SI case (`msfd_jax.PAPER_SI`): an aluminium half ring (R = 0.5 m) carrying a
# 67 kg block strikes a 3 m aluminium beam at 30 m/s, the beam held axially at its supports.
# The uniform beam is h_b/h_r = 2.5 (125 mm). The designer's question: **with at most 90 % of
# the uniform beam's material, and a peak deflection of at most 0.16 m, how should the
# thickness vary along the span so that the car (the block) decelerates least over 10 ms?**
#
# `optimise.design` varies the thickness through K control points (a piecewise-linear
# profile over the half span, one value per beam segment), steps along the gradient of a
# smoothed surrogate, and judges every design on the sharp model (`optimise/_graded.py`).
# The model's answers, not test results (README, "What the model is not").
#
# Set `MSFD_GRADED_FULL=1` for the design worth keeping: K = 6 and 30 design steps on the
# paper's mesh with every segment split in two (`m.Mesh().refined(2)`, 50 beam segments; the
# design about ten minutes on one core, each of the front's three more about as long). On
# the paper's own mesh the 10 ms deceleration of the uniform beams near the limit is 25 %
# above its converged value, and a design made there keeps about half of its gain on a finer
# mesh (docs/design.md, "Which mesh"). The default is a coarse mesh, K = 3 and a few steps,
# so that the notebook runs in the tests in well under a minute: its numbers show the
# workflow, not a design.

# %%
import dataclasses
import os

import equinox as eqx
import jax
import matplotlib.pyplot as plt
import numpy as np

import msfd_jax as m
import optimise as o

FULL = os.environ.get("MSFD_GRADED_FULL") == "1"
mesh = m.Mesh().refined(2) if FULL else m.Mesh(6, 8, 2)
STEPS = 30 if FULL else 6
LIMIT, BUDGET, G = 0.16, 0.9, 9.81

si = dict(m.PAPER_SI)
si["block_mass"] = 67.0
params, scales = m.from_si(**si)
h0 = float(params.thickness_ratio)
print(f"uniform h_b/h_r = {h0:g}, {m.beam_segments(mesh)} beam segments on {mesh}")

# %% [markdown]
# ## The design
#
# Minimise the 10 ms deceleration subject to deflection <= 0.16 m and beam mass <= 0.9 of
# the uniform beam (thickness bounds h/h_r in [1, 5]). The start is the uniform beam, projected
# into the mass budget (h/h_r = 2.25 everywhere). The method is the default, SLSQP on the
# smoothed surrogate with every point it tries checked on the sharp model (docs/design.md says
# when `method="adam"` is worth a try too).

# %%
problem = o.graded_problem(params, scales, mesh, profile_points=6 if FULL else 3)
result = o.design(
    problem,
    minimise="deceleration_10ms",
    limits={"deflection": LIMIT},
    max_beam_mass_ratio=BUDGET,
    steps=STEPS,
)
print(result.status, f"after {result.iterations} points, {result.wall_time_s:.0f} s")
for name in ("deceleration_10ms", "deflection", "beam_mass"):
    print(f"{name:<18} start {result.start[name]:10.4g}   design {result.values[name]:10.4g}")
print("profile h/h_r, O to E:", np.round(result.thickness_profile, 3))

# %% [markdown]
# ## Uniform beams within the same budget, one batch
#
# The sharp quantities of uniform beams from h/h_r = 1 to 2.25 (mass <= 0.9), vmapped over
# the designs in one compiled program; the best uniform beam is the one with the lowest
# deceleration among those within the deflection limit.

# %%
uniform_h = np.linspace(1.0, BUDGET * h0, 8 if not FULL else 20)
controls = np.repeat(uniform_h[:, None], problem.points, axis=1)
batch = eqx.filter_jit(lambda cs, p: jax.vmap(lambda c: o.quantities(c, p)[0])(cs))
uniform = {k: np.asarray(v) for k, v in batch(controls, problem).items()}
ok = np.flatnonzero(uniform["deflection"] <= LIMIT)
best = ok[np.argmin(uniform["deceleration_10ms"][ok])] if len(ok) else None
for h, d, a in zip(uniform_h, uniform["deflection"], uniform["deceleration_10ms"], strict=True):
    print(f"uniform h/h_r = {h:.3f}: deflection {d:.4f} m, {a / G:6.1f} g")
if best is None:
    print("no uniform beam within the budget meets the deflection limit")
else:
    gain = 1 - result.values["deceleration_10ms"] / uniform["deceleration_10ms"][best]
    print(f"best uniform: h/h_r = {uniform_h[best]:.3f}; the graded beam decelerates "
          f"{100 * gain:.1f} % less")  # fmt: skip

# %% [markdown]
# ## The profile on the beam
#
# Thickness h_b (mm) along the half span, from mid-span O (struck) to the support E: the
# segments' boundaries as the model places them (the contact region OC, then the outer part).

# %%
xs = np.concatenate(
    [
        np.linspace(0.0, mesh.contact_region, mesh.beam_contact_segments + 1),
        np.linspace(mesh.contact_region, float(params.span_ratio), mesh.beam_outer_segments + 1)[
            1:
        ],
    ]
)
x_m = xs * scales.length
h_r_mm = 1e3 * si["ring_thickness"]
fig, ax = plt.subplots(figsize=(7, 3.2))
ax.stairs(result.thickness_profile * h_r_mm, x_m, color="tab:red", lw=2, label="graded")
ax.hlines(h0 * h_r_mm, 0, x_m[-1], color="k", ls="--", label=f"uniform {h0:g} (mass 1)")
if best is not None:
    ax.hlines(
        uniform_h[best] * h_r_mm, 0, x_m[-1], color="tab:gray", label="best uniform, mass <= 0.9"
    )
ax.set_xlabel("distance from mid-span O [m]")
ax.set_ylabel("beam thickness h_b [mm]")
ax.set_ylim(0, None)
ax.legend(fontsize=8)
ax.set_title("Thickness along the half span")
plt.show()

# %% [markdown]
# ## Histories: uniform against graded
#
# `msfd_jax.run` of each beam (a uniform beam given as an equal profile, which reproduces the
# uniform beam exactly and shares the compiled program), its mid-span deflection and the
# block's deceleration averaged over 10 ms, read from `solution.history`.
#
# `run` checks the energy balance and, where it is open, runs again at a smaller step (its
# message says so); the design's evaluations above run at the default step in the design's
# own compiled program. They differ by the step's error where `run` retried (on this coarse
# mesh the uniform beam's balance is open at the default step), and otherwise by rounding,
# which the sharp contact amplifies (~1e-3 relative): printed below beside each other.

# %%
settings = m.Settings(t_max=float(problem.settings.t_max), history_points=401, shape_times=())
reference = uniform_h[best] if best is not None else BUDGET * h0
beams = {
    f"uniform h/h_r = {reference:.3f}": np.full(m.beam_segments(mesh), reference),
    "graded": result.thickness_profile,
}
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
for (label, profile), color in zip(beams.items(), ("tab:gray", "tab:red"), strict=True):
    p = dataclasses.replace(params, thickness_profile=np.asarray(profile))
    collision = m.run(p, mesh, settings, scales=scales)
    sol = collision.solution
    keep = np.asarray(sol.ts) <= float(sol.t_end) + 1e-12
    t = np.asarray(sol.ts)[keep] * scales.time
    deflection = np.abs(np.asarray(sol.history["midspan_deflection"])[keep]) * scales.length
    v = np.asarray(sol.history["block_velocity"])[keep] * scales.length / scales.time
    window = 0.010
    decel = np.abs(np.interp(t + window, t, v) - v) / window
    ax1.plot(1e3 * t, 1e3 * deflection, color=color, label=label)
    ax2.plot(1e3 * (t + window / 2), decel / G, color=color, label=label)
    print(
        f"{label}: peak deflection {collision.si['peak_beam_deflection_m']:.4f} m, "
        f"10 ms deceleration {collision.si['peak_block_deceleration_10ms_m_s2'] / G:.1f} g"
    )
    if collision.message.startswith("retried"):
        print("   ", collision.message.split(" after:")[0])
    row = best if best is not None else len(uniform_h) - 1  # the reference's batch row
    batch_row = {k: v[row] for k, v in uniform.items()}
    design_step = result.values if label == "graded" else batch_row
    print(
        f"    the design's evaluation: deflection {float(design_step['deflection']):.4f} m, "
        f"{float(design_step['deceleration_10ms']) / G:.1f} g"
    )
ax1.axhline(1e3 * LIMIT, color="k", ls=":", lw=1, label="limit")
ax1.set_xlabel("t [ms]")
ax1.set_ylabel("mid-span deflection [mm]")
ax2.set_xlabel("t [ms] (window centre)")
ax2.set_ylabel("block deceleration over 10 ms [g]")
ax1.legend(fontsize=8)
ax2.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %% [markdown]
# ## Pareto front: deflection limit against the lowest deceleration
#
# For uniform beams, the lowest deceleration among the batch within each limit; for graded
# beams, the design solved again at a looser limit (a loop of `o.design`, reusing the programs
# compiled above). `o.design_front(problem, "deflection", limits, ...)` solves every limit in
# one batched run instead (two programs of its own; docs/design.md). benchmarks/design.py
# draws the full front (`docs/figures/design_pareto.png`).

# %%
front = {LIMIT: result}
for limit in [0.20] if not FULL else [0.14, 0.18, 0.20]:
    front[limit] = o.design(
        problem,
        limits={"deflection": limit},
        max_beam_mass_ratio=BUDGET,
        steps=STEPS,
    )
limits = sorted(front)
fig, ax = plt.subplots(figsize=(6, 4))
d, a = uniform["deflection"], uniform["deceleration_10ms"] / G
ax.plot(d, a, "o", color="tab:gray", label="uniform beams (mass <= 0.9)")
grid = np.linspace(min(d.min(), limits[0]), max(d.max(), limits[-1]), 200)
ax.step(grid, [a[d <= x].min() if np.any(d <= x) else np.nan for x in grid], where="post",
        color="tab:gray", label="best uniform within the limit")  # fmt: skip
ax.plot(limits, [front[x].values["deceleration_10ms"] / G for x in limits], "s-",
        color="tab:red", label="graded")  # fmt: skip
ax.set_xlabel("deflection limit [m]")
ax.set_ylabel("lowest 10 ms deceleration [g]")
ax.legend(fontsize=8)
plt.show()
for x in limits:
    print(f"limit {x:.2f} m: graded {front[x].values['deceleration_10ms'] / G:.1f} g "
          f"({front[x].status})")  # fmt: skip
