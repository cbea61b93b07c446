"""A scene as flat arrays with the batch on the last axis (the batched core's model).

`flatten` turns one `Scene` into a `FlatScene`: every node of every chain in one array (the
chains are static slices of it), every bar and every joint of the scene in one array each,
contact pairs per contact set, and every constant the step needs precomputed once (inverse
masses, rest lengths, reference joint angles, the clamped joints' fixed directions, the pair
stiffnesses and yield forces). Every array ends in the batch axis B, the axis XLA:CPU
vectorises and GPUs coalesce (`../shared/perf/contact_layout.py`: dense contact 1.7 ns/pair
with the batch last against 8-9 ns/pair with it first); a single collision is a batch of one.

`batch_scenes` stacks scenes of one layout (one mesh, one kind of scene) into one FlatScene.
What a scene does not have (a drive, a plane, a second chain) has no array and no code.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._model.collapse import COLLAPSE_TYPES, BarStop, BlockFaceContact, SelfContact
from .._model.contact import NodeToNodeContact, NodeToPlaneContact
from .._model.safe import atan2
from .._model.scene import Scene


class ChainLayout(NamedTuple):
    """Static layout of one chain inside the flat arrays."""

    name: str
    start: str  # "free", "clamped", "symmetric"
    end: str
    node: int  # first node in the flat node array
    n_nodes: int
    bar: int  # first bar in the flat bar array
    joint: int  # first joint in the flat joint array
    n_joints: int


class PairLayout(NamedTuple):
    """A node-to-node contact set: nodes [a, a + n_a) against [b, b + n_b) (flat indices)."""

    a: int
    n_a: int
    b: int
    n_b: int


class PlaneLayout(NamedTuple):
    """A node-to-plane contact set: nodes [a, a + n_a) against the plane y = level."""

    a: int
    n_a: int


class SelfPairLayout(NamedTuple):
    """Ring-on-ring contact of a collapsing ring: nodes [a, a + n) against themselves, the pairs
    i < j with j - i >= separation (`_model.collapse.SelfContact`); pair arrays (n, n, B)."""

    a: int
    n: int
    separation: int


class FacePlaneLayout(NamedTuple):
    """Nodes [a, a + n_a) against the plane x_axis = x[anchor, axis], moving with node
    `anchor` (flat index; `_model.collapse.BlockFaceContact`: axis 1 the block's face, axis 0
    the symmetry plane); the "gap" array holds the offset, (B,) or one per node (n_a, B)."""

    a: int
    n_a: int
    anchor: int
    axis: int = 1


class BarStopLayout(NamedTuple):
    """The crush stops of the bars between nodes [a, a + n) (`_model.collapse.BarStop`):
    arrays (n - 1, B), one per bar."""

    a: int
    n: int


COLLAPSE_LAYOUTS = (SelfPairLayout, FacePlaneLayout, BarStopLayout)


class Tracked(NamedTuple):
    """The nodes whose motion a ring-on-beam run follows at every step (flat indices): the
    beam's mid-span node O, the ring's front node S (on the symmetry plane, first to touch
    the beam) and the block node G (the ring's last node, which carries half the block).
    The engine keeps the design quantities' running peaks from them (`peaks.PEAK_KEYS`)."""

    midspan: int
    front: int
    block: int


class FlatScene(eqx.Module):
    """The model of B collisions of one layout; every array's last axis is the batch.

    Shapes: N nodes, M bars, J joints of all chains together; per contact set the pair
    arrays are (n_a, n_b, B) (node to node) or (n_a, B) (node to plane).
    """

    chains: tuple[ChainLayout, ...] = eqx.field(static=True)
    pairs: tuple[
        PairLayout | PlaneLayout | SelfPairLayout | FacePlaneLayout | BarStopLayout, ...
    ] = eqx.field(static=True)
    drive: tuple[int, int] | None = eqx.field(static=True)  # (flat node, axis)
    tracked: Tracked | None = eqx.field(static=True)  # ring on beam only: the peaks' nodes
    smooth_yield: bool = eqx.field(static=True)  # False: the sharp laws alone (Scene's flags)
    smooth_contact: bool = eqx.field(static=True)
    x0: Float[Array, "N 2 B"]
    v0: Float[Array, "N 2 B"]
    mass: Float[Array, "N B"]
    free: Float[Array, "N 2 B"]
    rest_length: Float[Array, "M B"]
    axial_modulus: Float[Array, "M B"]
    plastic_axial: Float[Array, "M B"]
    joint_stiffness: Float[Array, "J B"]
    joint_weight: Float[Array, "J B"]
    plastic_moment: Float[Array, "J B"]
    reference_angle: Float[Array, "J B"]
    start_direction: tuple[Array | None, ...]  # per chain: (2, B) for a clamped start
    end_direction: tuple[Array | None, ...]  # per chain: (2, B) for a clamped end
    attached_mass: Float[Array, "chains B"]
    # per contact set: (B,) gap, (n_a, n_b, B) one per pair (a graded beam), or for a plane
    # its offset - level
    gap: tuple[Array, ...]
    stiffness: tuple[Array, ...]
    yield_force: tuple[Array, ...]
    drive_velocity: Float[Array, " B"]
    yield_smoothing: Float[Array, " B"]
    contact_smoothing: Float[Array, " B"]

    @property
    def batch(self) -> int:
        return self.mass.shape[-1]

    @property
    def n_nodes(self) -> int:
        return self.mass.shape[0]

    def chain_slice(self, c: ChainLayout) -> slice:
        return slice(c.node, c.node + c.n_nodes)

    @property
    def initial_kinetic_energy(self) -> Float[Array, " B"]:
        return 0.5 * jnp.sum(self.mass[:, None] * self.free * self.v0**2, axis=(0, 1))


def layout_of(scene: Scene):
    """The static layout (chains, contact sets, drive) of a scene."""
    chains, node, bar, joint = [], 0, 0, 0
    for c in scene.chains:
        chains.append(ChainLayout(c.name, c.start, c.end, node, c.n_nodes, bar, joint, c.n_joints))
        node, bar, joint = node + c.n_nodes, bar + c.n_nodes - 1, joint + c.n_joints
    pairs = []
    for k in scene.contacts:
        if isinstance(k, COLLAPSE_TYPES):
            pairs.append(_collapse_layout(k, chains[k.chain].node))
        elif isinstance(k, NodeToNodeContact):
            a, b = _range(k.nodes_a, "nodes_a"), _range(k.nodes_b, "nodes_b")
            pairs.append(
                PairLayout(chains[k.chain_a].node + a[0], a[1], chains[k.chain_b].node + b[0], b[1])
            )
        elif isinstance(k, NodeToPlaneContact):
            a = _range(k.nodes, "nodes")
            pairs.append(PlaneLayout(chains[k.chain].node + a[0], a[1]))
        else:
            raise TypeError(f"the batched core has no rule for the contact {type(k).__name__}")
    drive = None
    if scene.drive is not None:
        drive = (chains[scene.drive.chain].node + scene.drive.node, scene.drive.axis)
    return tuple(chains), tuple(pairs), drive


def tracked_nodes(chains: tuple[ChainLayout, ...]) -> Tracked | None:
    """`Tracked` for a scene with a chain "ring" and a chain "beam", else None (a plate, a
    cantilever or a driven beam follows no peaks and compiles no code for them)."""
    named = {c.name: c for c in chains}
    if "ring" not in named or "beam" not in named:
        return None
    ring, beam = named["ring"], named["beam"]
    return Tracked(beam.node, ring.node, ring.node + ring.n_nodes - 1)


def _collapse_layout(k: SelfContact | BlockFaceContact | BarStop, first: int):
    """The layout of a collapse contact whose chain starts at flat node `first`."""
    a, n = _range(k.nodes, "nodes")
    if isinstance(k, SelfContact):
        return SelfPairLayout(first + a, n, k.separation)
    if isinstance(k, BarStop):
        return BarStopLayout(first + a, n)
    return FacePlaneLayout(first + a, n, first + k.anchor, k.axis)


def _range(nodes: tuple[int, ...], name: str) -> tuple[int, int]:
    if nodes != tuple(range(nodes[0], nodes[0] + len(nodes))):
        raise ValueError(f"contact {name} must be a contiguous range of nodes, got {nodes}")
    return nodes[0], len(nodes)


def _flatten_one(scene: Scene) -> FlatScene:
    """One scene as flat arrays with a trailing batch axis of length 1."""
    chains, pairs, drive = layout_of(scene)
    per_bar, per_joint = [], []
    start_dir, end_dir = [], []
    for c in scene.chains:
        s = c.section
        l0 = c.rest_length
        k, w = c.joint_stiffness_and_weight()
        ones_b, ones_j = jnp.ones_like(l0), jnp.ones_like(k)
        per_bar.append((l0, s.axial_modulus * ones_b, s.plastic_axial * ones_b))
        angles = c.joint_angles(c.reference, atan2)
        per_joint.append((k, w, c.joint_plastic_moment() * ones_j, angles))
        ref = c.reference
        start_dir.append(ref[1] - ref[0] if c.start == "clamped" else None)
        end_dir.append(ref[-1] - ref[-2] if c.end == "clamped" else None)
    v0 = jnp.concatenate(
        [v * c.free for c, v in zip(scene.chains, scene.initial_velocity, strict=True)]
    )
    if drive is not None:
        v0 = v0.at[drive].set(scene.drive.velocity)
    gap, stiffness, yield_force = [], [], []
    for k in scene.contacts:
        if isinstance(k, NodeToNodeContact | SelfContact | BarStop):
            gap.append(k.gap)
        elif isinstance(k, BlockFaceContact):
            gap.append(k.offset)
        else:  # approach = y + offset - level: the plane's "gap" is offset - level
            gap.append(k.offset - k.level)
        stiffness.append(k.stiffness)
        yield_force.append(k.yield_force)

    def cat(parts, i):
        return jnp.concatenate([p[i] for p in parts]) if parts else jnp.zeros(0)

    f = jnp.float64
    flat = FlatScene(
        chains=chains,
        pairs=pairs,
        drive=drive,
        tracked=tracked_nodes(chains),
        smooth_yield=scene.smooth_yield,
        smooth_contact=scene.smooth_contact,
        x0=jnp.concatenate([c.reference for c in scene.chains]),
        v0=v0,
        mass=jnp.concatenate([c.mass for c in scene.chains]),
        free=jnp.concatenate([c.free for c in scene.chains]),
        rest_length=cat(per_bar, 0),
        axial_modulus=cat(per_bar, 1),
        plastic_axial=cat(per_bar, 2),
        joint_stiffness=cat(per_joint, 0),
        joint_weight=cat(per_joint, 1),
        plastic_moment=cat(per_joint, 2),
        reference_angle=cat(per_joint, 3),
        start_direction=tuple(start_dir),
        end_direction=tuple(end_dir),
        attached_mass=jnp.stack([jnp.asarray(c.attached_mass, f) for c in scene.chains]),
        gap=tuple(jnp.asarray(g, f) for g in gap),
        stiffness=tuple(stiffness),
        yield_force=tuple(yield_force),
        drive_velocity=jnp.asarray(0.0 if drive is None else scene.drive.velocity, f),
        yield_smoothing=jnp.asarray(scene.yield_smoothing, f),
        contact_smoothing=jnp.asarray(scene.contact_smoothing, f),
    )
    # (nodes, 2) -> (nodes, 2, 1): every array gains the trailing batch axis
    return jax.tree_util.tree_map(lambda a: a[..., None], flat)


def flatten(scene: Scene) -> FlatScene:
    """One (unbatched) scene as a FlatScene with B = 1."""
    return _flatten_one(scene)


def batch_scenes(scenes: Scene) -> FlatScene:
    """A Scene whose arrays carry a leading batch axis (a vmapped builder's output) as one
    FlatScene with the batch last."""
    return jax.vmap(
        lambda s: jax.tree_util.tree_map(lambda a: a[..., 0], _flatten_one(s)), out_axes=-1
    )(scenes)
