"""Objectives built from the energy partition (fractions of K0, as `msfd_jax.fractions` gives).

A *share* is the sum of some fractions: ``"beam"`` = beam bending + beam axial plastic work,
``"ring"`` = ring bending + ring axial, ``"dissipated"`` = all plastic work, or any single
fraction key (``"beam_axial"``, ``"contact"``, ...). Terms:

- `TargetShare`: weight * (share - target)^2.
- `ShareAtMost` / `ShareAtLeast`: weight * max(share - limit, 0)^2 (or below the limit): a C1
  penalty that is exactly zero inside the allowed range, so it never moves a design that
  already satisfies it.
- `Objective`: the sum of any terms (a weighted combination through each term's weight).

Every term also has a `violation` in units of K0 (|share - target|, or how far past its limit),
which is what "met within a tolerance" is judged on.
"""

from __future__ import annotations

import abc
from typing import Any

import equinox as eqx
import jax.numpy as jnp

import msfd_jax as m

STRUCTURES: dict[str, tuple[str, ...]] = {
    "beam": ("beam_bending", "beam_axial"),
    "ring": ("ring_bending", "ring_axial"),
    "dissipated": ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact"),
}


def share(fractions: dict[str, Any], structure: str):
    """The share of K0 taken by `structure` (a name in `STRUCTURES` or one fraction key)."""
    keys = STRUCTURES.get(structure, (structure,))
    return sum(fractions[k] for k in keys)


def _check_structure(structure: str) -> None:
    known = (*STRUCTURES, *m.FRACTION_KEYS, "kinetic_ring", "kinetic_block", "kinetic_beam")
    if structure not in known:
        raise ValueError(f"unknown structure {structure!r}; expected one of {known}")


class AbstractTerm(eqx.Module):
    """One term of an objective, a function of the partition."""

    @abc.abstractmethod
    def __call__(self, fractions: dict[str, Any]) -> Any: ...

    @abc.abstractmethod
    def violation(self, fractions: dict[str, Any]) -> Any:
        """How far the partition is from meeting this term, in units of K0 (>= 0)."""

    @abc.abstractmethod
    def describe(self) -> str: ...


class TargetShare(AbstractTerm):
    """weight * (share - target)^2: `structure` should take `target` of K0."""

    structure: str = eqx.field(static=True)
    target: Any
    weight: Any = 1.0

    def __check_init__(self):
        _check_structure(self.structure)

    def __call__(self, fractions):
        return self.weight * (share(fractions, self.structure) - self.target) ** 2

    def violation(self, fractions):
        return jnp.abs(share(fractions, self.structure) - self.target)

    def describe(self) -> str:
        return f"{self.structure} share = {float(self.target):g}"


class ShareAtMost(AbstractTerm):
    """weight * max(share - limit, 0)^2: `structure` should take at most `limit` of K0."""

    structure: str = eqx.field(static=True)
    limit: Any
    weight: Any = 1.0

    def __check_init__(self):
        _check_structure(self.structure)

    def __call__(self, fractions):
        return self.weight * self.violation(fractions) ** 2

    def violation(self, fractions):
        return jnp.maximum(share(fractions, self.structure) - self.limit, 0.0)

    def describe(self) -> str:
        return f"{self.structure} share <= {float(self.limit):g}"


class ShareAtLeast(AbstractTerm):
    """weight * max(limit - share, 0)^2: `structure` should take at least `limit` of K0."""

    structure: str = eqx.field(static=True)
    limit: Any
    weight: Any = 1.0

    def __check_init__(self):
        _check_structure(self.structure)

    def __call__(self, fractions):
        return self.weight * self.violation(fractions) ** 2

    def violation(self, fractions):
        return jnp.maximum(self.limit - share(fractions, self.structure), 0.0)

    def describe(self) -> str:
        return f"{self.structure} share >= {float(self.limit):g}"


class Objective(eqx.Module):
    """A weighted sum of terms (each term carries its weight); minimised by `tune`."""

    terms: tuple[AbstractTerm, ...]

    def __check_init__(self):
        if not self.terms:
            raise ValueError("an Objective needs at least one term")

    def __call__(self, fractions):
        return sum(term(fractions) for term in self.terms)

    def violation(self, fractions):
        """The largest violation over the terms (K0): the objective is met when it is small."""
        return jnp.max(jnp.stack([jnp.asarray(t.violation(fractions)) for t in self.terms]))

    def structures(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(t.structure for t in self.terms))

    def describe(self) -> str:
        return ", ".join(t.describe() for t in self.terms)


def objective(*terms: AbstractTerm) -> Objective:
    """`Objective(terms)`: ``objective(TargetShare("beam", 0.6), ShareAtMost("ring", 0.3))``."""
    return Objective(tuple(terms))
