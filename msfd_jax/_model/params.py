"""Collision inputs: the non-dimensional groups of Eq. (1), their SI form, and validation.

Everything the solver needs is a non-dimensional group scaled by the *ring* (Eq. 1):
moment M_pr = Y b h_r^2 / 4, mass per length mu_r = rho b h_r, length R,
time T = sqrt(mu_r R^3 / M_pr). This module is the one place where SI inputs are converted
and where every input is checked.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

# Allowed ranges: (low, high, low_inclusive, high_inclusive). Chosen to exclude only what is
# non-physical or outside what the discrete model can represent (see docs/model.md).
_RANGES: dict[str, tuple[float, float, bool, bool]] = {
    "thickness_ratio": (0.0, 100.0, False, True),
    "modulus_ratio": (1.0, 1.0e7, False, True),
    "slenderness": (2.0, 1.0e4, True, True),
    "mass_ratio": (0.0, 1.0e7, True, True),
    "velocity": (0.0, 1.0e3, False, True),
    "width_ratio": (0.0, 100.0, False, True),
    "axial_constraint": (0.0, 1.0, True, True),
}

_DESCRIPTIONS = {
    "thickness_ratio": "h_b/h_r, beam to ring thickness",
    "modulus_ratio": "E/Y, Young's modulus over yield stress",
    "slenderness": "R/h_r, ring radius over ring thickness",
    "mass_ratio": "g = G/(mu_r R), half block mass over ring mass per radius",
    "velocity": "v0 = V0 sqrt(mu_r R / M_pr), impact velocity",
    "span_ratio": "L_b/R, beam half span over ring radius",
    "width_ratio": "b_b/b_r, beam to ring width",
    "axial_constraint": "1 for an axially constrained beam, 0 for a free one",
}


def _show(value: Any) -> str:
    """`repr(value)` on one line (an array's repr spans several), at most 80 characters."""
    try:
        text = " ".join(repr(value).split())
    except ValueError:  # an int of more than 4300 digits has no repr (sys.int_info)
        text = f"<{type(value).__name__} too long to show>"
    return text if len(text) <= 80 else text[:77] + "..."


def _label(name: str) -> str:
    return f"{name} ({_DESCRIPTIONS[name]})" if name in _DESCRIPTIONS else name


def _check_value(name: str, value: Any, low: float, high: float, lo_in: bool, hi_in: bool):
    """Raise a ValueError naming `name` unless every element of `value` is in range."""
    if isinstance(value, jax.core.Tracer):
        return  # validated where it was concrete (the public entry points)
    arr = _real(name, value)
    lo_br, hi_br = ("[" if lo_in else "("), ("]" if hi_in else ")")
    allowed = f"allowed {lo_br}{low:g}, {high:g}{hi_br}"
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{_label(name)} must be finite, got {_show(value)}; {allowed}")
    ok = ((arr >= low) if lo_in else (arr > low)) & ((arr <= high) if hi_in else (arr < high))
    if not np.all(ok):
        bad = arr[~ok].ravel()[0]
        raise ValueError(f"{_label(name)} = {bad:g} is out of range; {allowed}")


def _real(name: str, value: Any) -> np.ndarray:
    """`value` as a float array; a TypeError naming `name` unless it is real numbers."""
    try:  # a ragged list has no dtype: numpy raises ValueError (not naming `name`)
        kind = np.asarray(value).dtype.kind if not isinstance(value, str) else "U"
    except (TypeError, ValueError):
        kind = "O"
    if isinstance(value, bool) or kind not in "iuf":  # no strings, booleans, complex, objects
        raise TypeError(
            f"{_label(name)} must be a real number, got {type(value).__name__} {_show(value)}"
        )
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"{_label(name)} must be a real number, got {type(value).__name__} {_show(value)}"
        ) from None
    return arr


def _check_count(
    name: str,
    value: Any,
    minimum: int,
    maximum: int | None = None,
    small="below what the model needs",
):
    """Raise naming `name` unless `value` is an integer in [minimum, maximum] (a TypeError
    for a non-integer, a ValueError out of range; `small` says why fewer is refused)."""
    allowed = f">= {minimum}" if maximum is None else f">= {minimum} and <= {maximum}"
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer {allowed}, got {_show(value)}")
    if value < minimum:
        raise ValueError(f"{name} = {_show(value)} is {small}; allowed {allowed}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} = {_show(value)} is too large; allowed {allowed}")


def _check_scalar(name: str, value: Any):
    """Raise a ValueError naming `name` unless `value` is one number (a 0-d array at most)."""
    if isinstance(value, jax.core.Tracer):
        return
    try:
        ndim = np.ndim(value)
    except (TypeError, ValueError):  # ragged: not one number either
        ndim = -1
    if ndim != 0:
        raise ValueError(f"{_label(name)} must be a single value, got {_show(value)}")


def _check_static_number(name: str, value: Any):
    """A number that keys the compiled program (a static field): one hashable number."""
    _check_scalar(name, value)
    if isinstance(value, np.ndarray | jax.Array):  # arrays are unhashable, even 0-d ones
        raise TypeError(f"{name} must be a plain number, not an array, got {_show(value)}")


# Largest segment count of a mesh: the paper's mesh is 15 / 20 / 5 and the refinement studies
# go to 8x; beyond, the step (~ 1/n^2) makes a run last for ever and the dense contact arrays
# (ring x beam nodes) outgrow memory.
MAX_SEGMENTS = 10_000


class Mesh(eqx.Module):
    """Node counts (static: they fix array shapes, so they are part of the compiled program).

    **Arguments:**
    - `ring_segments`: segments of the quarter ring S->G (paper: 15).
    - `beam_contact_segments`: equal segments over the possible contact region OC (paper: 20).
    - `beam_outer_segments`: equal segments over CE (paper: 25 - 20 = 5).
    - `contact_region`: length of OC in units of R (paper: 2).
    - `collapse_contacts`: the contacts of a collapsing structure (`msfd_jax._model.collapse`:
      ring on the block's face, on itself and on the symmetry plane, the ring bars' crush
      stops, the beam on its mirror image). None (the default): the paper's model, and a
      run or sweep row that it leaves without an answer (a fold, a crushed bar, a broken
      balance a smaller step does not close) is solved again with them, the ring refined
      where their validity check needs it (`msfd_jax._collision.collapse`); True: always
      built (the validity check refuses a ring mesh they cannot use); False: never (the
      paper's model alone, its failures reported). A scene without them compiles none of
      their code. Part of the mesh because it is part of the discrete model (and static,
      like the node counts).
    """

    ring_segments: int = eqx.field(static=True, default=15)
    beam_contact_segments: int = eqx.field(static=True, default=20)
    beam_outer_segments: int = eqx.field(static=True, default=5)
    contact_region: float = eqx.field(static=True, default=2.0)
    collapse_contacts: bool | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        _check_count("ring_segments", self.ring_segments, 3, MAX_SEGMENTS)
        _check_count("beam_contact_segments", self.beam_contact_segments, 2, MAX_SEGMENTS)
        _check_count("beam_outer_segments", self.beam_outer_segments, 1, MAX_SEGMENTS)
        _check_value("contact_region", self.contact_region, 0.0, 1.0e3, False, True)
        _check_static_number("contact_region", self.contact_region)
        if self.collapse_contacts is not None and not isinstance(self.collapse_contacts, bool):
            raise TypeError(
                "collapse_contacts must be None (automatic: built where a collapse needs "
                f"them), True or False, got {self.collapse_contacts!r}"
            )

    def refined(self, factor: int) -> Mesh:
        """The same mesh with every segment count multiplied by `factor`."""
        return Mesh(
            self.ring_segments * factor,
            self.beam_contact_segments * factor,
            self.beam_outer_segments * factor,
            self.contact_region,
            self.collapse_contacts,
        )


class CollisionParams(eqx.Module):
    """The non-dimensional groups of one ring-on-beam collision (Sect. 2, Eq. 1).

    All fields are arrays (differentiable, vmappable); the defaults are the paper's showcase
    (Fig. 13): h_b/h_r = 2.5, E/Y = 500, R/h_r = 10, g = 10, v0 = 0.82, L_b = 3R, constrained.

    **Arguments:**
    - `thickness_ratio`: h_b/h_r.
    - `modulus_ratio`: E/Y.
    - `slenderness`: R/h_r.
    - `mass_ratio`: g = G/(mu_r R), G half the block's mass.
    - `velocity`: v0 = V0 sqrt(mu_r R / M_pr).
    - `span_ratio`: L_b/R, half span of the beam.
    - `width_ratio`: b_b/b_r.
    - `axial_constraint`: 1.0 (x_E = 0, Eq. 20) or 0.0 (free to slide).
    - `thickness_profile`: None (a uniform beam of `thickness_ratio`), or a graded beam
      (MODEL.md section 10): h_k/h_r of every beam segment k, O -> E (one value per segment of
      the mesh's beam: 25 on the paper's mesh), which then replaces `thickness_ratio` for the
      beam; `thickness_ratio` stays the uniform beam a graded one is compared with
      (`beam_mass_ratio`). An array like every other field: profiles vmap and differentiate,
      and a new profile of the same length compiles nothing new.
    """

    thickness_ratio: Any = 2.5
    modulus_ratio: Any = 500.0
    slenderness: Any = 10.0
    mass_ratio: Any = 10.0
    velocity: Any = 0.82
    span_ratio: Any = 3.0
    width_ratio: Any = 1.0
    axial_constraint: Any = 1.0
    thickness_profile: Any = eqx.field(default=None, converter=lambda v: _profile_array(v))

    def __check_init__(self):
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "thickness_profile":
                _check_profile(value)
                continue
            if f.name == "axial_constraint":
                if isinstance(value, bool):
                    continue
                _check_value(f.name, value, *_RANGES[f.name])
                if not isinstance(value, jax.core.Tracer) and not np.all(
                    np.isin(np.asarray(value, float), (0.0, 1.0))
                ):
                    raise ValueError(
                        f"axial_constraint ({_DESCRIPTIONS[f.name]}) must be 0 or 1 "
                        f"(or a bool), got {_show(value)}"
                    )
                continue
            if f.name == "span_ratio":  # its range depends on the mesh: see `validate`
                if not isinstance(value, jax.core.Tracer):
                    _real(f.name, value)  # but a string or None is refused here
                continue
            _check_value(f.name, value, *_RANGES[f.name])

    @property
    def graded(self) -> bool:
        """True for a graded beam (a `thickness_profile` is given)."""
        return self.thickness_profile is not None

    def scalars(self) -> dict[str, Any]:
        """The one-number groups (every field but `thickness_profile`), by name."""
        return {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.name != "thickness_profile"
        }

    def as_arrays(self) -> CollisionParams:
        """Every field as a float64 array (what the compiled solver sees)."""
        return jax.tree_util.tree_map(lambda v: jnp.asarray(v, dtype=jnp.float64), self)

    @property
    def initial_kinetic_energy(self):
        """K0 of the half model from the continuous masses, (g + pi/2) v0^2 / 2 (Fig. 24)."""
        return 0.5 * (self.mass_ratio + math.pi / 2) * self.velocity**2


PROFILE_FIELD = "thickness_profile"
_PROFILE_RANGE = _RANGES["thickness_ratio"]


def _profile_array(value):
    """A list or tuple profile as one numpy array (a pytree leaf, not one leaf per value);
    anything else as given (checked in `_check_profile`)."""
    if isinstance(value, list | tuple):
        try:
            return np.asarray(value)
        except (TypeError, ValueError):  # ragged: refused by the check, naming the field
            return value
    return value


def _check_profile(value) -> None:
    """A thickness profile: None, or a 1-D list/array (a batch of them: 2-D) of h_k/h_r, each
    in `thickness_ratio`'s range. Its length is checked against the mesh in `validate`."""
    if value is None or isinstance(value, jax.core.Tracer):
        return
    arr = _real(PROFILE_FIELD, value)
    if arr.ndim < 1 or arr.shape[-1] < 1:
        raise ValueError(
            f"{PROFILE_FIELD} (h_k/h_r of every beam segment, O to E) must be a list with one "
            f"value per beam segment, got {_show(value)}"
        )
    low, high = _PROFILE_RANGE[:2]
    bad = arr[~(np.isfinite(arr) & (arr > low) & (arr <= high))]
    if bad.size:
        raise ValueError(
            f"{PROFILE_FIELD} (h_k/h_r of every beam segment, O to E) has {bad.ravel()[0]:g}, "
            f"out of range; allowed (0, {high:g}] for every segment"
        )


def beam_segments(mesh: Mesh) -> int:
    """The number of beam segments O -> E (the length of a thickness profile)."""
    return mesh.beam_contact_segments + mesh.beam_outer_segments


def validate(params: CollisionParams, mesh: Mesh) -> None:
    """Check the combination of parameters and mesh (what a single field cannot check)."""
    profile = params.thickness_profile
    if profile is not None and not isinstance(profile, jax.core.Tracer):
        n = beam_segments(mesh)
        if np.shape(profile)[-1] != n:
            raise ValueError(
                f"{PROFILE_FIELD} has {np.shape(profile)[-1]} values; the mesh's beam has "
                f"{n} segments (beam_contact_segments {mesh.beam_contact_segments} + "
                f"beam_outer_segments {mesh.beam_outer_segments}, O to E): give one h_k/h_r "
                f"per segment, each in (0, {_PROFILE_RANGE[1]:g}]"
            )
    try:
        _check_value("span_ratio", params.span_ratio, mesh.contact_region, 1.0e4, False, True)
    except ValueError as error:  # the lower bound is the mesh's: say so
        raise ValueError(
            f"{error} (the beam must extend past the mesh's contact region, "
            f"contact_region = {mesh.contact_region:g})"
        ) from None
    if mesh.collapse_contacts:
        _check_collapse(params.slenderness, mesh.ring_segments)


REFINE_STEP = 5  # a ring refined for the collapse contacts has a multiple of this many segments


def collapse_ring_segments(slenderness, ring_segments: int) -> tuple[int | None, str]:
    """The fewest ring segments, at least `ring_segments`, on which the collapse contacts can
    hold a ring of this slenderness (R/h_r, one value), and "" ; or (None, why) where no
    count can (`_check_collapse`'s two conditions: node spacing below twice the thickness,
    nodes two apart farther apart than it). A refined count is rounded up to a multiple of
    `REFINE_STEP` (5), so that a sweep's collapsed rows share a few ring meshes, and so a few
    compiled programs, instead of one per count (the second condition allows about four
    times the fewest count, n < pi R/h_r against n > pi R/(4 h_r), so the rounding keeps it)."""
    n = ring_segments
    thin = float(slenderness)
    if 2.0 * math.sin(math.pi / (4 * n)) >= 2.0 / thin:
        n = math.floor(math.pi / (4.0 * math.asin(1.0 / thin))) + 1
        n = REFINE_STEP * math.ceil(n / REFINE_STEP)
    if 2.0 * math.sin(math.pi / (2 * n)) <= 1.0 / thin:
        return None, (
            f"slenderness (R/h_r) = {thin:g}: on {n} ring segments (needed by the collapse "
            "contacts' node spacing) nodes two apart start closer than the ring's thickness"
        )
    return n, ""


def _check_collapse(slenderness, ring_segments: int) -> None:
    """Where ring-on-ring node-to-node contact can represent a fold (docs/model.md).

    The self-contact gap is the ring thickness h_r/R = 1/slenderness and the pairs are nodes
    two or more apart. Two conditions on the chord s = 2 sin(pi/(4n)) between ring nodes:
    s < 2 h_r/R (else a node of one wall slips between two nodes of the other, unresisted)
    and 2 s cos(pi/(4n)) > h_r/R (nodes two apart start apart, so no pair is closed at rest).
    """
    if isinstance(slenderness, jax.core.Tracer):
        return
    n = ring_segments
    chord = 2.0 * math.sin(math.pi / (4 * n))
    gap = 1.0 / np.asarray(slenderness, dtype=float)
    thin = np.max(1.0 / gap)
    if chord >= 2.0 / thin:
        need = math.floor(math.pi / (4.0 * math.asin(1.0 / thin))) + 1
        raise ValueError(
            f"slenderness (R/h_r) = {thin:g} with ring_segments = {n}: with collapse_contacts "
            f"the ring node spacing {chord:.3g} R must stay below twice the ring thickness "
            f"(2 h_r/R = {2.0 / thin:.3g}), or a node slips between two nodes of the other "
            f"wall; use ring_segments >= {need} or collapse_contacts=False"
        )
    thick = np.min(1.0 / gap)
    if 2.0 * math.sin(math.pi / (2 * n)) <= 1.0 / thick:
        raise ValueError(
            f"slenderness (R/h_r) = {thick:g} with ring_segments = {n}: with collapse_contacts "
            f"ring nodes two apart ({2.0 * math.sin(math.pi / (2 * n)):.3g} R) must start "
            f"farther apart than the ring thickness h_r/R = {1.0 / thick:.3g}; use fewer ring "
            "segments or collapse_contacts=False"
        )


@dataclasses.dataclass(frozen=True)
class Scales:
    """SI values of the non-dimensional units (Eq. 1), to convert results back."""

    moment: float  # M_pr [N m]  (also the energy unit [J])
    length: float  # R [m]
    time: float  # T = sqrt(mu_r R^3 / M_pr) [s]
    velocity: float  # R / T [m/s]
    force: float  # M_pr / R [N]


def si_impact_speed(impact_speed=None, velocity=None):
    """The SI impact speed from `impact_speed`, or from its former name `velocity` (with a
    DeprecationWarning); refuses both at once or neither."""
    if velocity is not None:
        if impact_speed is not None:
            raise TypeError("give impact_speed [m/s] only (velocity is its former SI name)")
        warnings.warn(
            "the SI input 'velocity' is now 'impact_speed' (m/s), as --impact-speed on the "
            "command line and in case files; 'velocity' will be removed",
            DeprecationWarning,
            stacklevel=3,
        )
        return velocity
    if impact_speed is None:
        raise TypeError("from_si() needs impact_speed (V0 [m/s])")
    return impact_speed


def from_si(
    *,
    youngs_modulus: float,
    yield_stress: float,
    density: float,
    radius: float,
    width: float,
    ring_thickness: float,
    beam_thickness: float,
    beam_half_span: float,
    impact_speed: float | None = None,
    block_mass: float,
    beam_width: float | None = None,
    axial_constraint: bool = True,
    velocity: float | None = None,
) -> tuple[CollisionParams, Scales]:
    """Convert SI inputs (Pa, kg/m^3, m, m/s, kg) into `CollisionParams` and unit scales.

    `block_mass` is the whole rigid block 2G; `beam_half_span` is L_b (the span is 2 L_b);
    `impact_speed` is V0 [m/s] (`velocity` is its former SI name, accepted with a
    DeprecationWarning: `CollisionParams.velocity` is the non-dimensional v0).
    """
    impact_speed = si_impact_speed(impact_speed, velocity)
    si = dict(
        youngs_modulus=youngs_modulus,
        yield_stress=yield_stress,
        density=density,
        radius=radius,
        width=width,
        ring_thickness=ring_thickness,
        beam_thickness=beam_thickness,
        beam_half_span=beam_half_span,
        impact_speed=impact_speed,
    )
    for name, value in si.items():
        _check_value(name, value, 0.0, math.inf, False, False)
    _check_value("block_mass", block_mass, 0.0, math.inf, True, False)
    if beam_width is not None:
        _check_value("beam_width", beam_width, 0.0, math.inf, False, False)
    b_b = width if beam_width is None else beam_width
    # in float64 numpy, where an extreme but finite input overflows to inf (Python's float
    # ** raises OverflowError instead: radius = 5.7e102 overflowed R^3): a group or scale that
    # is not finite is then refused below, naming the SI inputs, never a traceback
    f = np.float64
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        mu_r = f(density) * f(width) * f(ring_thickness)
        m_pr = f(yield_stress) * f(width) * f(ring_thickness) ** 2 / 4.0
        t_scale = np.sqrt(mu_r * f(radius) ** 3 / m_pr)  # the formula as before, bit for bit
        groups = dict(
            thickness_ratio=f(beam_thickness) / f(ring_thickness),
            modulus_ratio=f(youngs_modulus) / f(yield_stress),
            slenderness=f(radius) / f(ring_thickness),
            mass_ratio=0.5 * f(block_mass) / (mu_r * f(radius)),
            velocity=f(impact_speed) * t_scale / f(radius),
            span_ratio=f(beam_half_span) / f(radius),
            width_ratio=f(b_b) / f(width),
        )
        scales = (m_pr, f(radius), t_scale, f(radius) / t_scale, m_pr / f(radius))
    params = CollisionParams(
        **{k: float(v) for k, v in groups.items()},
        axial_constraint=1.0 if axial_constraint else 0.0,
    )
    if not all(np.isfinite(scales)) or not all(v > 0.0 for v in scales):
        raise ValueError(
            "the SI inputs give unit scales that are not finite positive float64 numbers "
            f"(M_pr = {float(m_pr):g} N m, T = {float(t_scale):g} s from yield_stress, density, "
            "width, ring_thickness, radius): give values within float64's range"
        )
    return params, Scales(*(float(v) for v in scales))


PAPER_SI = dict(
    youngs_modulus=70e9,
    yield_stress=140e6,
    density=2680.0,
    radius=0.5,
    width=0.05,
    ring_thickness=0.05,
    beam_thickness=0.125,
    beam_half_span=1.5,
    impact_speed=30.0,
    block_mass=2 * 10 * 2680.0 * 0.05 * 0.05 * 0.5,
)
"""The paper's base case in SI (R/b = R/h_r = 10, L_b = 3R, g = 10, h_b/h_r = 2.5; R = 0.5 m)."""
