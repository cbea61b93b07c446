"""Test set-up: float64, no silent rank promotion, and compiled scenes shared across tests."""

import jax

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import pytest  # noqa: E402

import msfd_jax as m  # noqa: E402

# One small mesh for every test that does not need the paper's: compiled once, reused.
SMALL_MESH = m.Mesh(ring_segments=6, beam_contact_segments=8, beam_outer_segments=2)
SHORT = m.Settings(t_max=1.5, history_points=31, shape_times=(0.5,))
# Tests comparing batched with single runs on SMALL_MESH smooth the contact (width in R): the
# sharp contact, stiff since issue 9, chatters there and amplifies the rounding differences
# of a vmapped program exponentially (7e-4 K0 by tau = 0.6); smoothed, they agree to ~1e-13
# (`python -m msfd_jax.studies.scripts.numerics_checks`, "Rounding amplification").
COMPARE_SMOOTHING = 1e-3


@pytest.fixture(autouse=True)
def _no_export_store_leaks():
    """A test that runs the CLI in-process switches the export store on (as the CLI does);
    later tests must see the library's default (off) again."""
    from msfd_jax import _export

    before = _export.store()
    yield
    _export.enable(before)


@pytest.fixture(scope="session")
def small_mesh():
    return SMALL_MESH


@pytest.fixture(scope="session")
def showcase():
    """The paper's showcase (Fig. 13) on the paper's mesh, run once for the whole session."""
    return m.run()
