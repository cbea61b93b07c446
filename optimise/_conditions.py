"""Impact conditions as samples, for robust tuning of the *expected* energy split.

A guardrail is not hit at one speed by one car: `Conditions` holds samples of the impact
velocity v0 and the block mass ratio g (paired: sample i is (velocity[i], mass_ratio[i])), with
probability weights. A `Problem` built with conditions (`make_problem(..., conditions=...)`)
evaluates every sample in **one compiled program** (`jax.vmap` over the sampled
`CollisionParams` fields inside the objective), and everything downstream (the objective,
both gradient modes, `tune`, the sharp-model check) then works on the expected partition

    E[f_k] = sum_i w_i f_k(design, v0_i, g_i),

each f_k a fraction of that sample's own K0 (the expected share of an impact, whatever its
energy; an energy-weighted mean would let the fastest, heaviest samples dominate the split).
`Conditions.grid` builds the product of independent velocity and mass samples.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np

import msfd_jax as m

SAMPLED = ("velocity", "mass_ratio")  # the CollisionParams fields a sample may set


class Conditions(eqx.Module):
    """Paired samples of the impact conditions and their weights.

    **Arguments:**
    - `velocity`: v0 of each sample (None: the problem's base value for every sample).
    - `mass_ratio`: g of each sample (None: the base value).
    - `weights`: probability of each sample (default equal); normalised to sum 1.
    """

    velocity: Any = None
    mass_ratio: Any = None
    weights: Any = None

    def __init__(self, velocity=None, mass_ratio=None, weights=None):
        given = {
            k: v for k, v in (("velocity", velocity), ("mass_ratio", mass_ratio)) if v is not None
        }
        if not given:
            raise ValueError("Conditions need velocity and/or mass_ratio samples")
        sizes = {k: np.size(v) for k, v in given.items()}
        if len(set(sizes.values())) != 1 or min(sizes.values()) < 1:
            raise ValueError(f"paired samples need equal, non-zero lengths, got {sizes}")
        n = next(iter(sizes.values()))
        for name, value in given.items():
            values = np.asarray(value, dtype=float).reshape(-1)
            if not np.all(np.isfinite(values)):
                raise ValueError(f"{name} samples must be finite, got {values}")
            for v in values:  # the same range checks as one collision's parameters
                m.CollisionParams(**{name: float(v)})
            given[name] = jnp.asarray(values)
        if weights is None:
            w = np.full(n, 1.0 / n)
        else:
            w = np.asarray(weights, dtype=float).reshape(-1)
            if w.size != n or not np.all(w >= 0) or not w.sum() > 0:
                raise ValueError(f"need {n} non-negative weights with a positive sum, got {w}")
            w = w / w.sum()
        self.velocity = given.get("velocity")
        self.mass_ratio = given.get("mass_ratio")
        self.weights = jnp.asarray(w)

    @classmethod
    def grid(cls, velocity=None, mass_ratio=None) -> Conditions:
        """Every combination of the velocity and mass samples (independent, equally likely)."""
        axes = {
            k: v for k, v in (("velocity", velocity), ("mass_ratio", mass_ratio)) if v is not None
        }
        if not axes:
            raise ValueError("Conditions.grid needs velocity and/or mass_ratio samples")
        names = list(axes)
        rows = list(itertools.product(*(np.asarray(axes[k], float).reshape(-1) for k in names)))
        return cls(**{k: [r[i] for r in rows] for i, k in enumerate(names)})

    def __len__(self) -> int:
        return int(self.weights.shape[0])

    def fields(self) -> dict[str, Any]:
        """The sampled fields and their sample arrays."""
        return {k: getattr(self, k) for k in SAMPLED if getattr(self, k) is not None}

    def apply(self, params: m.CollisionParams, index: int) -> m.CollisionParams:
        """`params` at sample `index` (concrete: validated)."""
        return dataclasses.replace(params, **{k: float(v[index]) for k, v in self.fields().items()})

    def rows(self) -> list[dict[str, float]]:
        """One dict per sample: the sampled fields and the weight."""
        fields = self.fields()
        return [
            {**{k: float(v[i]) for k, v in fields.items()}, "weight": float(self.weights[i])}
            for i in range(len(self))
        ]


def expectation(samples: dict[str, Any], weights) -> dict[str, Any]:
    """The weighted mean over the leading (sample) axis of every fraction."""
    return {k: jnp.sum(weights * v, axis=0) for k, v in samples.items()}


def spread(samples: dict[str, Any], weights) -> dict[str, dict[str, float]]:
    """Per fraction: weighted mean, standard deviation, min and max over the samples."""
    w = np.asarray(weights, float)
    out = {}
    for k, v in samples.items():
        v = np.asarray(v, float)
        mean = float(np.sum(w * v))
        out[k] = {
            "mean": mean,
            "std": float(np.sqrt(np.sum(w * (v - mean) ** 2))),
            "min": float(v.min()),
            "max": float(v.max()),
        }
    return out
