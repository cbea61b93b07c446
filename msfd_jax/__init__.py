"""msfd-jax: a differentiable JAX solver for ring-on-beam collisions (Ruan & Yu 2003, MS-FD)."""

import importlib.metadata as _metadata

import jax

jax.config.update("jax_enable_x64", True)

try:
    __version__ = _metadata.version("msfd-jax")
except _metadata.PackageNotFoundError:  # a source tree on sys.path, not installed
    __version__ = "0+unknown"

from ._batched.results import RESULT_NAMES, RESULTS  # noqa: E402
from ._batched.simulate import Settings, Solution, simulate  # noqa: E402
from ._collision.run import (  # noqa: E402
    FRACTION_KEYS,
    Collision,
    SimulationError,
    diagnose,
    fractions,
    run,
    run_si,
)
from ._model.chain import Chain, Section, rectangular_section  # noqa: E402
from ._model.contact import AbstractContact, NodeToNodeContact, NodeToPlaneContact  # noqa: E402
from ._model.laws import contact_energy, contact_spring, elastic_plastic, ramp  # noqa: E402
from ._model.params import (  # noqa: E402
    PAPER_SI,
    CollisionParams,
    Mesh,
    Scales,
    beam_segments,
    from_si,
    validate,
)
from ._model.scene import (  # noqa: E402
    Drive,
    Scene,
    beam_mass,
    beam_mass_ratio,
    beam_midspan_load,
    cantilever_tip_mass,
    ring_on_beam,
    ring_on_plate,
)
from ._model.state import State, critical_step, max_frequency  # noqa: E402
from ._reference.dynamics import initial_state, respond  # noqa: E402
from ._runtime.mappings import CompiledProgramsReleased  # noqa: E402
from ._sweeps.sweep import SweepTable, solve_collisions, sweep  # noqa: E402

__all__ = [
    "beam_mass",
    "beam_mass_ratio",
    "beam_segments",
    "CompiledProgramsReleased",
    "SweepTable",
    "sweep",
    "solve_collisions",
    "FRACTION_KEYS",
    "Collision",
    "SimulationError",
    "diagnose",
    "fractions",
    "run",
    "run_si",
    "AbstractContact",
    "Chain",
    "CollisionParams",
    "Drive",
    "Mesh",
    "NodeToNodeContact",
    "NodeToPlaneContact",
    "PAPER_SI",
    "RESULT_NAMES",
    "RESULTS",
    "Scales",
    "Scene",
    "Section",
    "Settings",
    "Solution",
    "State",
    "beam_midspan_load",
    "cantilever_tip_mass",
    "contact_energy",
    "contact_spring",
    "critical_step",
    "elastic_plastic",
    "from_si",
    "initial_state",
    "max_frequency",
    "ramp",
    "rectangular_section",
    "respond",
    "ring_on_beam",
    "ring_on_plate",
    "simulate",
    "validate",
]


def __getattr__(name):
    # plotting is imported lazily: `import msfd_jax` does not load matplotlib
    if name in (
        "plot_collision",
        "plot_partition",
        "plot_energies",
        "plot_shapes",
        "plot_contact_force",
    ):
        from . import _plot

        return getattr(_plot, name)
    raise AttributeError(f"module 'msfd_jax' has no attribute {name!r}")
