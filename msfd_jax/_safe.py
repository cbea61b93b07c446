"""Reverse-mode-safe maths (the double-where pattern, as jax-md's ``safe_mask``)."""

from __future__ import annotations

import jax.numpy as jnp


def safe_norm(v, axis=-1):
    """Euclidean norm along `axis` with a finite (zero) gradient where the vector vanishes."""
    sq = jnp.sum(v * v, axis=axis)
    positive = sq > 0
    safe_sq = jnp.where(positive, sq, 1.0)
    return jnp.where(positive, jnp.sqrt(safe_sq), 0.0)
