"""Scenes: which structures, contacts and drives a simulation has (the model, not the state).

A scene is a tuple of chains plus a tuple of contacts. Which parts exist is static, so a scene
without a beam, a ring or contact carries none of their state and compiles none of their code.

Builders:
- `ring_on_beam`: the paper's problem (Sect. 2, Fig. 2, 3, 7), with or without axial constraint.
- `ring_on_plate`: the half ring pressed quasi-statically onto a rigid plate (Fig. 17).
- `cantilever_tip_mass`: a cantilever struck at its tip by a mass (Parkes' problem).
- `beam_midspan_load`: a simply supported beam driven at mid-span (Eq. 25).
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._runtime import export as _export
from .chain import Chain, lumped_masses, rectangular_section, side_values
from .collapse import collapse_contacts
from .contact import (
    AbstractContact,
    NodeToNodeContact,
    NodeToPlaneContact,
    block_stiffness,
    block_yield,
)
from .params import CollisionParams, Mesh, _check_value, validate


class Drive(eqx.Module):
    """A degree of freedom moved at a prescribed constant velocity (displacement control).

    The force the driver applies is recorded as the reaction (Fig. 12, 17 quasi-static curves).
    """

    chain: int = eqx.field(static=True)
    node: int = eqx.field(static=True)
    axis: int = eqx.field(static=True)
    velocity: Float[Array, ""]


class Scene(eqx.Module):
    """Everything about a simulation that does not change while it runs.

    **Arguments:**
    - `chains`: the structures (ring and/or beam).
    - `contacts`: contact spring sets between them (or against a rigid plate).
    - `initial_velocity`: per chain, the nodal velocities at tau = 0, shape (n, 2).
    - `drive`: an optional displacement-controlled degree of freedom.
    - `yield_smoothing`: softplus width of the return mapping, fraction of the yield value.
    - `contact_smoothing`: width of the contact activation ramp, in units of R (0 = sharp).
    - `smooth_yield`, `smooth_contact` (static): False when the width is known to be zero, so
      the batched core compiles only the sharp law (no softplus, no ramp: less work per
      step); True (the default) compiles the general law, exact for any width.
    """

    chains: tuple[Chain, ...]
    contacts: tuple[AbstractContact, ...]
    initial_velocity: tuple[Float[Array, "nodes 2"], ...]
    drive: Drive | None = None
    yield_smoothing: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.zeros(()))
    contact_smoothing: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.zeros(()))
    smooth_yield: bool = eqx.field(static=True, default=True)
    smooth_contact: bool = eqx.field(static=True, default=True)

    def chain_index(self, name: str) -> int | None:
        for i, c in enumerate(self.chains):
            if c.name == name:
                return i
        return None

    @property
    def initial_kinetic_energy(self):
        """K0 = sum of m v^2 / 2 over the nodal masses (not hard-coded, MODEL.md Sect. 2)."""
        return sum(
            0.5 * jnp.sum(c.mass[:, None] * c.free * v**2)
            for c, v in zip(self.chains, self.initial_velocity, strict=True)
        )


def _check_types(params, mesh):
    if not isinstance(params, CollisionParams):
        raise TypeError(f"params must be a msfd_jax.CollisionParams, got {params!r}")
    if not isinstance(mesh, Mesh):
        raise TypeError(f"mesh must be a msfd_jax.Mesh, got {mesh!r}")


def smoothing_width(value, name: str):
    """A smoothing width (`contact_smoothing`, `yield_smoothing`) checked, as a float64
    array: in [0, 1000], 0 the sharp law. The one check of scenes and sweeps."""
    _check_value(name, value, 0.0, 1.0e3, True, True)
    return jnp.asarray(value, dtype=jnp.float64)


def smoothed(value) -> bool:
    """False only for a width known (concrete) to be zero: the sharp law can be compiled alone."""
    if isinstance(value, jax.core.Tracer):
        return True
    return bool(np.any(np.asarray(value) != 0))


def ring_chain(params: CollisionParams, mesh: Mesh, apex_y) -> Chain:
    """Quarter ring S -> G (Fig. 7): apex S at (0, apex_y), G at the level of the centre.

    S is a symmetry node (x fixed, Eq. 21); G carries the half block g (Eq. 17), has x fixed
    (Eq. 22) and is clamped in rotation to the rigid block (docs/model.md).
    """
    n = mesh.ring_segments
    theta = np.linspace(0.0, math.pi / 2, n + 1)
    xy = jnp.stack([jnp.sin(theta), apex_y - 1.0 + jnp.cos(theta)], axis=-1)
    section = rectangular_section(1.0, 1.0, params.modulus_ratio, params.slenderness)
    mass = lumped_masses(xy, section.mass_per_length).at[-1].add(params.mass_ratio)
    free = jnp.ones((n + 1, 2)).at[0, 0].set(0.0).at[-1, 0].set(0.0)
    return Chain("ring", "symmetric", "clamped", xy, mass, free, section, params.mass_ratio)


def beam_chain(params: CollisionParams, mesh: Mesh) -> Chain:
    """Half beam O -> E along y = 0: equal segments over OC, equal ones over CE (Fig. 7).

    O is a symmetry node (x fixed); E is simply supported (y fixed, no spring, Eq. 19, 23) and
    held in x when `axial_constraint` is 1 (Eq. 20); the constraint is a 0/1 array, so it can
    be vmapped.
    """
    inner = np.linspace(0.0, mesh.contact_region, mesh.beam_contact_segments + 1)
    outer = jnp.linspace(mesh.contact_region, params.span_ratio, mesh.beam_outer_segments + 1)
    xs = jnp.concatenate([jnp.asarray(inner), outer[1:]])
    xy = jnp.stack([xs, jnp.zeros_like(xs)], axis=-1)
    section = rectangular_section(
        beam_thickness(params), params.width_ratio, params.modulus_ratio, params.slenderness
    )
    mass = lumped_masses(xy, section.mass_per_length)
    free = jnp.ones_like(xy).at[0, 0].set(0.0).at[-1, 1].set(0.0)
    free = free.at[-1, 0].set(1.0 - params.axial_constraint)
    return Chain("beam", "symmetric", "free", xy, mass, free, section)


def beam_thickness(params: CollisionParams):
    """h/h_r of the beam: `thickness_ratio`, or one value per segment (`thickness_profile`)."""
    if params.thickness_profile is None:
        return params.thickness_ratio
    return params.thickness_profile


def contact_gap(params: CollisionParams, beam: Chain, n_b: int):
    """Critical distance (h_r + h_b)/(2R) of the ring-beam pairs: a scalar for a uniform beam;
    graded, one per beam node of OC, from the tributary-length mean thickness of the node's
    adjacent segments (MODEL.md section 10). Returns (gap, gap at O)."""
    if params.thickness_profile is None:
        gap = (1.0 + params.thickness_ratio) / (2.0 * params.slenderness)
        return gap, gap
    (t_l, t_r), (l_l, l_r) = side_values(params.thickness_profile), _side_lengths(beam)
    # (l_L t_L + l_R t_R)/(l_L + l_R) as t_L + l_R (t_R - t_L)/(l_L + l_R): exactly t where
    # the two sides are equal (an equal profile is the uniform beam to rounding)
    mean = t_l + l_r * (t_r - t_l) / (l_l + l_r)
    # O's gap as the uniform beam's scalar expression, plus each node's difference from it:
    # an equal profile gives the uniform gap bit for bit (a vector division may round apart)
    gap_o = (1.0 + t_l[0]) / (2.0 * params.slenderness)
    return gap_o + (mean[:n_b] - t_l[0]) / (2.0 * params.slenderness), gap_o


def _beam_blocks(params, slender, beam: Chain, n_b: int, width):
    """Stiffness of the beam's contact block at each node of OC: uniform, one block over the
    tributary length; graded, the node's two half-segments side by side (in parallel), each
    of its own thickness (MODEL.md section 10)."""
    beta = params.modulus_ratio
    if params.thickness_profile is None:
        lt_b = beam.tributary_length()[:n_b]
        return block_stiffness(beta, slender, lt_b, params.thickness_ratio, width)
    (t_l, t_r), (l_l, l_r) = side_values(params.thickness_profile), _side_lengths(beam)
    # sum of 8 beta (b/b_r) (R/h_r)^3 (l/2)/t over the two half-bars, written as one block of
    # thickness t_L over (l_L + l_R t_L/t_R)/2: the uniform block bit for bit where t_L == t_R
    tributary = 0.5 * (l_l + l_r * (t_l / t_r))
    return block_stiffness(beta, slender, tributary, t_l, width)[:n_b]


def _side_lengths(beam: Chain):
    """Per node, the rest length of the bar on its left and on its right (0 past an end)."""
    l0, pad = beam.rest_length, jnp.zeros(1)
    return jnp.concatenate([pad, l0]), jnp.concatenate([l0, pad])


def beam_mass(params: CollisionParams, mesh: Mesh):
    """Mass of the half beam in units of mu_r R (ring units, Eq. 1): (b_b/b_r) sum_k t_k l_k,
    t_k = h_k/h_r of each segment (`thickness_ratio` for a uniform beam). jit/vmap/grad-able."""
    validate(params, mesh)
    p = params.as_arrays()
    beam = beam_chain(p, mesh)
    return p.width_ratio * jnp.sum(beam_thickness(p) * beam.rest_length)


def beam_mass_ratio(params: CollisionParams, mesh: Mesh):
    """A beam's mass over that of the uniform beam of `params.thickness_ratio` (same span,
    width and mesh): sum t_k l_k / (t_ref sum l_k); 1 for a uniform beam (MODEL.md section 10).
    """
    uniform = dataclasses.replace(params, thickness_profile=None)
    return beam_mass(params, mesh) / beam_mass(uniform, mesh)


def _beam_mirror(params, beam: Chain):
    """The beam's mirror contact data (`collapse.collapse_contacts`): the half thickness
    h/(2R) at every node (uniform: one value; graded: the tributary-length mean of the
    node's two segments, as `contact_gap`), its block's stiffness and yield force."""
    slender, width, n = params.slenderness, params.width_ratio, beam.n_nodes
    if params.thickness_profile is None:
        half = params.thickness_ratio / (2.0 * slender)
    else:
        (t_l, t_r), (l_l, l_r) = side_values(params.thickness_profile), _side_lengths(beam)
        half = (t_l + l_r * (t_r - t_l) / (l_l + l_r)) / (2.0 * slender)
    k_b = _beam_blocks(params, slender, beam, n, width)
    fy_b = block_yield(slender, beam.tributary_length(), width)
    return 1, beam, half, k_b, fy_b


def _ring_beam_contact(params, mesh, ring: Chain, beam: Chain, gap) -> NodeToNodeContact:
    """All quarter-ring nodes against the beam nodes of OC (Sect. 3.2)."""
    n_b = mesh.beam_contact_segments + 1
    width = jnp.minimum(1.0, params.width_ratio)  # contact width: the narrower section
    beta, slender = params.modulus_ratio, params.slenderness
    lt_r = ring.tributary_length()
    lt_b = beam.tributary_length()[:n_b]
    k_r = block_stiffness(beta, slender, lt_r, 1.0, width)
    k_b = _beam_blocks(params, slender, beam, n_b, width)
    k = 1.0 / (1.0 / k_r[:, None] + 1.0 / k_b[None, :])
    f_y = jnp.minimum(
        block_yield(slender, lt_r, width)[:, None], block_yield(slender, lt_b, width)[None, :]
    )
    ring_spacing = 2.0 * math.sin(math.pi / 4 / mesh.ring_segments)
    beam_spacing = mesh.contact_region / mesh.beam_contact_segments
    if jnp.ndim(gap) > 0:  # graded: one critical distance per pair (by beam node)
        gap = jnp.broadcast_to(gap[None, :], k.shape)
    return NodeToNodeContact(
        chain_a=0,
        chain_b=1,
        nodes_a=tuple(range(ring.n_nodes)),
        nodes_b=tuple(range(n_b)),
        gap=gap,
        stiffness=k,
        yield_force=f_y,
        spacing_b=beam_spacing,
        spacing_a=ring_spacing,
    )


def ring_on_beam(
    params: CollisionParams = CollisionParams(),
    mesh: Mesh = Mesh(),
    *,
    contact_smoothing=0.0,
    yield_smoothing=0.0,
) -> Scene:
    """The paper's collision: the quarter ring flies at v0 onto the half beam (Sect. 2, 3).

    At tau = 0 the surfaces just touch at S-O (gap (h_r + h_b)/(2R), h_b the thickness at O
    for a graded beam, `params.thickness_profile`); every ring node moves at
    v0 towards the beam (+y) and the beam is at rest (Eq. 24). With `mesh.collapse_contacts`
    the scene also has the ring-block and ring-ring contacts of a collapse (`collapse`),
    after the ring-beam contact (which stays contact set 0).
    """
    _check_types(params, mesh)
    validate(params, mesh)
    return _export.call(  # a stored program when the CLI has switched the store on
        _ring_on_beam,
        params.as_arrays(),
        mesh,
        smoothing_width(contact_smoothing, "contact_smoothing"),
        smoothing_width(yield_smoothing, "yield_smoothing"),
        (smoothed(contact_smoothing), smoothed(yield_smoothing)),
        name="ring_on_beam",
    )


@eqx.filter_jit
def _ring_on_beam(
    p: CollisionParams, mesh: Mesh, contact_smoothing, yield_smoothing, smooth=(True, True)
) -> Scene:
    # compiled once per mesh: building the scene op by op costs seconds, compiled microseconds
    beam = beam_chain(p, mesh)
    gap, gap_o = contact_gap(p, beam, mesh.beam_contact_segments + 1)
    ring = ring_chain(p, mesh, -gap_o)  # S just touches O
    contacts = (_ring_beam_contact(p, mesh, ring, beam, gap),)
    if mesh.collapse_contacts:
        contacts = contacts + collapse_contacts(p, mesh, ring, _beam_mirror(p, beam))
    v_ring = jnp.zeros_like(ring.reference).at[:, 1].set(p.velocity) * ring.free
    return Scene(
        (ring, beam),
        contacts,
        (v_ring, jnp.zeros_like(beam.reference)),
        yield_smoothing=yield_smoothing,
        contact_smoothing=contact_smoothing,
        smooth_contact=smooth[0],
        smooth_yield=smooth[1],
    )


def ring_on_plate(
    params: CollisionParams = CollisionParams(),
    mesh: Mesh = Mesh(),
    *,
    drive_velocity=0.01,
    contact_smoothing=0.0,
    yield_smoothing=0.0,
) -> Scene:
    """The half ring pressed onto a rigid plate y = 0 by its block moving at `drive_velocity`.

    The end-constrained half ring of Fig. 17(a): G is driven towards the plate (x_G fixed,
    clamped), the apex S touches the plate at tau = 0. The reaction at G is the plate load p/2
    of the half model. Only the ring's half thickness is compressed (the plate is rigid).
    """
    _check_types(params, mesh)
    _check_value("drive_velocity", drive_velocity, 0.0, 1.0e3, False, True)
    p = params.as_arrays()
    offset = 0.5 / p.slenderness
    ring = ring_chain(p, mesh, -offset)
    lt = ring.tributary_length()
    contact = NodeToPlaneContact(
        chain=0,
        nodes=tuple(range(ring.n_nodes)),
        level=jnp.zeros(()),
        offset=offset,
        stiffness=block_stiffness(p.modulus_ratio, p.slenderness, lt, 1.0, 1.0),
        yield_force=block_yield(p.slenderness, lt, 1.0),
    )
    v = jnp.zeros_like(ring.reference)
    drive = Drive(0, ring.n_nodes - 1, 1, jnp.asarray(drive_velocity, dtype=jnp.float64))
    v = v.at[-1, 1].set(drive.velocity)
    ring = eqx.tree_at(lambda c: c.free, ring, ring.free.at[-1, 1].set(0.0))
    return Scene(
        (ring,),
        (contact,),
        (v,),
        drive,
        smoothing_width(yield_smoothing, "yield_smoothing"),
        smoothing_width(contact_smoothing, "contact_smoothing"),
    )


def beam_midspan_load(
    params: CollisionParams = CollisionParams(thickness_ratio=1.0),
    mesh: Mesh = Mesh(),
    *,
    drive_velocity=0.01,
    yield_smoothing=0.0,
) -> Scene:
    """The simply supported half beam driven at mid-span O at `drive_velocity` (Eq. 25, Fig. 12).

    The reaction at O is half the central load p of the whole beam.
    """
    _check_types(params, mesh)
    validate(params, mesh)
    _check_value("drive_velocity", drive_velocity, 0.0, 1.0e3, False, True)
    p = params.as_arrays()
    beam = beam_chain(p, mesh)
    drive = Drive(0, 0, 1, jnp.asarray(drive_velocity, dtype=jnp.float64))
    beam = eqx.tree_at(lambda c: c.free, beam, beam.free.at[0, 1].set(0.0))
    v = jnp.zeros_like(beam.reference).at[0, 1].set(drive.velocity)
    return Scene(
        (beam,), (), (v,), drive, smoothing_width(yield_smoothing, "yield_smoothing"), jnp.zeros(())
    )


def cantilever_tip_mass(
    *,
    mass_ratio=1.0,
    velocity=1.0,
    modulus_ratio=1.0e4,
    slenderness=100.0,
    segments: int = 40,
    yield_smoothing=0.0,
) -> Scene:
    """Parkes' problem: a cantilever of unit length struck at its free tip by a mass.

    Units are the beam's own (length L, mass per length mu, moment M_p): ``mass_ratio`` is
    G/(mu L), ``velocity`` V0 sqrt(mu L / M_p), ``slenderness`` L/h. The mass sticks to the
    tip, which starts at ``velocity``; the rest of the beam is at rest. Root clamped.
    """
    for name, value in dict(
        mass_ratio=mass_ratio, velocity=velocity, modulus_ratio=modulus_ratio
    ).items():
        _check_value(name, value, 0.0, 1.0e7, False, True)
    _check_value("slenderness", slenderness, 2.0, 1.0e4, True, True)
    from .params import _check_count

    _check_count("segments", segments, 2)
    mass_ratio, velocity, modulus_ratio, slenderness = (
        jnp.asarray(v, dtype=jnp.float64)
        for v in (mass_ratio, velocity, modulus_ratio, slenderness)
    )
    xs = jnp.linspace(0.0, 1.0, segments + 1)
    xy = jnp.stack([xs, jnp.zeros_like(xs)], axis=-1)
    section = rectangular_section(1.0, 1.0, modulus_ratio, slenderness)
    mass = lumped_masses(xy, section.mass_per_length).at[-1].add(mass_ratio)
    free = jnp.ones_like(xy).at[0].set(0.0)
    beam = Chain("beam", "clamped", "free", xy, mass, free, section, mass_ratio)
    v = jnp.zeros_like(xy).at[-1, 1].set(velocity)
    return Scene((beam,), (), (v,), None, smoothing_width(yield_smoothing, "yield_smoothing"))
