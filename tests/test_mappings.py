"""The guard against XLA:CPU using up the process's memory mappings
(msfd_jax/_runtime/mappings.py)."""

import jax
import jax.numpy as jnp
import pytest

import msfd_jax as m
from msfd_jax._runtime import mappings as _mappings


def test_usage_counts_this_process_mappings():
    now = _mappings.usage()
    if now is None:
        pytest.skip("no /proc here")
    count, limit = now
    assert 0 < count < limit


def test_near_the_limit_compiled_programs_are_released_with_a_warning(monkeypatch):
    f = jax.jit(lambda x: x * 2.0 + 1.0)
    f(jnp.ones(3))
    assert f._cache_size() == 1
    monkeypatch.setattr(_mappings, "usage", lambda: (60_000, 65_530))
    with pytest.warns(m.CompiledProgramsReleased, match="vm.max_map_count"):
        _mappings.release_if_near_limit()
    assert f._cache_size() == 0  # dropped: the next call compiles again
    monkeypatch.setattr(_mappings, "usage", lambda: (1_000, 65_530))
    assert _mappings.release(_mappings.RELEASE_AT) is None  # far from the limit: kept
    monkeypatch.setattr(_mappings, "usage", lambda: None)  # no /proc: nothing checked
    assert _mappings.release(0.0) is None
