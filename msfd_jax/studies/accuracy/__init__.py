"""The work-precision study: other integrators against the default Verlet step.

`methods` (the integrators compared and the fractions they yield), `runners` (collisions,
configuration, runners, timing, the reference), `study` (the study and its extensions),
`report` (markdown and figures). Run it with ``msfd bench accuracy`` or
``python -m msfd_jax.studies.scripts.accuracy`` (writes benchmarks/results/accuracy.* and the
figures). The names are re-exported here, so ``from msfd_jax.studies import accuracy as A``
reads as the former ``msfd_jax._accuracy``.
"""

from .methods import (
    DISSIPATED,
    LUMPED_KEYS,
    Viscoplastic,
    YoshidaVerlet,
    lumped,
    max_error,
    state_fractions,
    viscoplastic_elastic,
    viscoplastic_field,
    viscoplastic_state,
)
from .methods import (
    _kinetic as _kinetic,  # used by tests/test_accuracy.py
)
from .report import fastest_within, markdown, plot
from .runners import (
    CASES,
    METHODS,
    QUICK,
    QUICK_MESH,
    TINY_MESH,
    Config,
    Job,
    reference,
    rk_fixed,
    time_jobs,
    verlet_at_stop,
    verlet_fixed,
    verlet_solver,
)
from .study import candidate_stability, case_jobs, kvaerno_comparison, mesh_refinement, study

__all__ = [
    "CASES",
    "Config",
    "DISSIPATED",
    "Job",
    "LUMPED_KEYS",
    "METHODS",
    "QUICK",
    "QUICK_MESH",
    "TINY_MESH",
    "Viscoplastic",
    "YoshidaVerlet",
    "candidate_stability",
    "case_jobs",
    "fastest_within",
    "kvaerno_comparison",
    "lumped",
    "markdown",
    "max_error",
    "mesh_refinement",
    "plot",
    "reference",
    "rk_fixed",
    "state_fractions",
    "study",
    "time_jobs",
    "verlet_at_stop",
    "verlet_fixed",
    "verlet_solver",
    "viscoplastic_elastic",
    "viscoplastic_field",
    "viscoplastic_state",
]
