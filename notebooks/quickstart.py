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
# # msfd-jax quick start
#
# A ring (radius R, thickness h_r) carrying a rigid block flies at V0 onto a simply supported
# beam (thickness h_b), modelled with the mass-spring finite-difference (MS-FD) model of Ruan &
# Yu, "Collision between a ring and a beam", *Int. J. Mech. Sci.* 45 (2003) 1751-1780. This
# notebook runs the paper's showcase (Fig. 13: h_b/h_r = 2.5, axially constrained beam,
# g = 10, v0 = 0.82) on a coarse mesh, looks at its energy histories and shapes, and then
# sweeps the thickness ratio with `jax.vmap`. Everything is non-dimensional (Eq. 1): energies
# in units of the ring's fully plastic moment M_pr, lengths in R, time tau in
# T = sqrt(mu_r R^3 / M_pr).
#
# Open it as a notebook with `jupytext --to notebook quickstart.py` (or the jupytext plugin).

# %%
import time

import jax
import jax.numpy as jnp

import msfd_jax as m
from msfd_jax._plot import plot_collision, plot_partition

# %% [markdown]
# ## Three collisions in one batch
#
# `m.run(params, mesh, settings)` runs one collision with every input checked and returns a
# `Collision` (the CLI's `msfd run` uses it). Here we use the transformable pieces instead,
# `ring_on_beam` (the scene: what is simulated) and `simulate` (how), under `jax.vmap` over
# the thickness ratio h_b/h_r: the three designs share one compiled program and run as a
# batch. Under `vmap` the step bound cannot be read from the (traced) time step, so
# `Settings.max_steps` is given. A coarse mesh (8 ring segments, 10 + 3 beam segments instead
# of the paper's 15, 20 + 5) keeps the compile and the run short.

# %%
mesh = m.Mesh(ring_segments=8, beam_contact_segments=10, beam_outer_segments=3)
settings = m.Settings(t_max=4.0, history_points=401, max_steps=2**16)
thickness = jnp.array([1.0, 2.5, 4.0])


@jax.jit
@jax.vmap
def simulate_design(thickness_ratio):
    scene = m.ring_on_beam(m.CollisionParams(thickness_ratio=thickness_ratio), mesh)
    return m.simulate(scene, settings)


start = time.perf_counter()
solutions = jax.block_until_ready(simulate_design(thickness))
wall = time.perf_counter() - start
print(f"wall time (including compilation): {wall:.1f} s")

# %% [markdown]
# ## The showcase
#
# The middle design, h_b/h_r = 2.5, is the paper's showcase (Fig. 13). `Collision` bundles
# one solution with its inputs; `message` says how the run ended.

# %%
params = m.CollisionParams(thickness_ratio=2.5)
showcase = m.Collision(
    params,
    mesh,
    m.ring_on_beam(params, mesh),
    jax.tree_util.tree_map(lambda a: a[1], solutions),
    wall,
)
print(showcase.message)

# %% [markdown]
# Energy partition over time, the contact force, the initial (dashed), intermediate (light)
# and final shapes (the half model mirrored about the axis of symmetry), and which ring node
# touched which beam node when (compare the paper's Fig. 13).

# %%
plot_collision(showcase)

# %% [markdown]
# The final partition, as fractions of the initial kinetic energy K0. The sum differs from 1
# by the energy balance error of the explicit integration.

# %%
fractions = showcase.fractions
for key in m.FRACTION_KEYS:
    print(f"{key:<13} {fractions[key]:7.3f}")
print(f"{'sum':<13} {sum(fractions[k] for k in m.FRACTION_KEYS):7.3f}")
print(f"energy balance error {showcase.energy_balance_error:+.1e} K0")

# %% [markdown]
# ## Partition vs thickness
#
# `fractions` works on the batched solution too (one entry per design). A thicker beam
# stretches less: its membrane (axial) share falls from about half of K0 to nothing, and the
# ring takes the energy in bending instead (compare the paper's Fig. 22).
#
# `diagnose` says how each run ended. `simulate` runs once, at the step it is given: where
# the energy balance is open above 1e-4 K0 the message says so (the fractions are uncertain
# by about that much), and `m.run` and `m.sweep` would run that collision again at a smaller
# step. On this coarse mesh the thickest beam also stops the ring so hard that the ring's
# crown passes the block's face, which the paper's model does not contact; the message names
# the model that does (`Mesh(collapse_contacts=True)`).

# %%
scene = showcase.scene  # every design has the same structure (chain order, node counts)
sweep = m.fractions(solutions, scene)
for i, h in enumerate(thickness.tolist()):
    print(f"h_b/h_r = {h:g}: {m.diagnose(solutions, scene, index=i)}")
for key in ("beam_bending", "beam_axial", "ring_bending"):
    print(f"{key:<13}", jnp.round(sweep[key], 3))

# %%
plot_partition(
    sweep,
    labels=[f"$h_b/h_r$ = {h:g}" for h in thickness.tolist()],
    title="final partition vs thickness ratio",
)
