"""Design variables (a pytree) and their bounds (a box), with the map to unit coordinates.

A `Design` names the `CollisionParams` fields being designed; fields left ``None`` are not
design variables (they keep the problem's base value). Adding a variable is adding a field here
and a default range in `DEFAULT_BOUNDS`: objectives, gradients and tuning are written for any
pytree of scalars.

Bounds are enforced by **projection** (clip after each optimiser step in unit coordinates
u = (x - low)/(high - low) in [0, 1]), not by a sigmoid/softplus reparametrisation: a projected
iterate reaches a bound exactly and stays there, which is what lets `tune` say that a target is
unreachable (the optimum sits on a bound with the gradient pointing out of the box), and unit
coordinates give every variable the same step scale whatever its physical range.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp

import msfd_jax as m

# Default ranges of each design variable (non-dimensional, Eq. 1): inside the parameter ranges
# that `CollisionParams` accepts, and where the paper's model is meant to be used
# (thickness ratios in [0.5, 5]; span beyond the contact region 2R).
DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "thickness_ratio": (0.5, 5.0),
    "width_ratio": (0.25, 4.0),
    "span_ratio": (2.5, 10.0),
}


class Design(eqx.Module):
    """The design variables: each a scalar array, or ``None`` when not designed.

    **Arguments:**
    - `thickness_ratio`: h_b/h_r, beam to ring thickness.
    - `width_ratio`: b_b/b_r, beam to ring width.
    - `span_ratio`: L_b/R, beam half span over ring radius.
    """

    thickness_ratio: Any = None
    width_ratio: Any = None
    span_ratio: Any = None

    def __check_init__(self):
        if not self.variables():
            raise ValueError("a Design needs at least one design variable")

    def variables(self) -> dict[str, Any]:
        """The designed fields and their values (fields left ``None`` are not design variables)."""
        fields = (f.name for f in dataclasses.fields(self))
        return {name: getattr(self, name) for name in fields if getattr(self, name) is not None}

    def apply(self, params: m.CollisionParams) -> m.CollisionParams:
        """`params` with the designed fields replaced (validated unless traced)."""
        return dataclasses.replace(params, **self.variables())

    def as_floats(self) -> dict[str, float]:
        return {name: float(value) for name, value in self.variables().items()}


def as_arrays(design: Design) -> Design:
    """Every designed value as a float64 scalar array (what gradients are taken against)."""
    return jax.tree_util.tree_map(lambda v: jnp.asarray(v, dtype=jnp.float64), design)


class Box(eqx.Module):
    """Lower and upper bounds of a design, as two `Design`s with the same designed fields."""

    lower: Design
    upper: Design

    def __check_init__(self):
        low, high = self.lower.variables(), self.upper.variables()
        if low.keys() != high.keys():
            raise ValueError(f"bounds for {sorted(low)} and {sorted(high)} do not match")
        for name in low:
            if not float(low[name]) < float(high[name]):
                raise ValueError(f"{name}: lower bound {low[name]} must be below {high[name]}")

    def to_unit(self, design: Design) -> Design:
        """u = (x - low)/(high - low): 0 at the lower bound, 1 at the upper."""
        return jax.tree_util.tree_map(
            lambda x, lo, hi: (x - lo) / (hi - lo), design, self.lower, self.upper
        )

    def from_unit(self, unit: Design) -> Design:
        return jax.tree_util.tree_map(
            lambda u, lo, hi: lo + u * (hi - lo), unit, self.lower, self.upper
        )

    def width(self) -> Design:
        return jax.tree_util.tree_map(lambda lo, hi: hi - lo, self.lower, self.upper)

    def corners(self) -> list[Design]:
        """Every corner of the box (2^n designs for n variables)."""
        names = list(self.lower.variables())
        out = []
        for index in range(2 ** len(names)):
            pick = {
                name: (self.upper if index >> i & 1 else self.lower).variables()[name]
                for i, name in enumerate(names)
            }
            out.append(Design(**pick))
        return out


def default_box(design: Design, **bounds: tuple[float, float]) -> Box:
    """The box of `design`'s variables: `DEFAULT_BOUNDS` unless given (thickness_ratio=(1, 4))."""
    names = design.variables()
    unknown = set(bounds) - set(names)
    if unknown:
        raise ValueError(f"bounds given for {sorted(unknown)}, which are not design variables")
    ranges = {name: bounds.get(name, DEFAULT_BOUNDS[name]) for name in names}
    lower = Design(**{k: float(v[0]) for k, v in ranges.items()})
    upper = Design(**{k: float(v[1]) for k, v in ranges.items()})
    return Box(as_arrays(lower), as_arrays(upper))


def project(unit: Design) -> Design:
    """Clip unit coordinates into [0, 1] (the projection of projected gradient descent)."""
    return jax.tree_util.tree_map(lambda u: jnp.clip(u, 0.0, 1.0), unit)
