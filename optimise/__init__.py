"""optimise: gradient-based tuning of a ring-on-beam design for a target energy split.

Imports `msfd_jax`; `msfd_jax` never imports this package (its CLI loads it lazily for
``msfd tune``).
"""

from ._conditions import Conditions
from ._design import DEFAULT_BOUNDS, Box, Design, default_box, project
from ._front import design_front
from ._graded import (
    DEFAULT_POINTS,
    QUANTITIES,
    GradedDesign,
    GradedProblem,
    graded_problem,
    quantities,
)
from ._gradient import (
    DEFAULT_SMOOTHING,
    MODES,
    SharpGradientWarning,
    finite_difference,
    gradient,
)
from ._objective import (
    STRUCTURES,
    AbstractTerm,
    Objective,
    ShareAtLeast,
    ShareAtMost,
    TargetShare,
    objective,
    share,
)
from ._problem import Evaluation, Problem, evaluate, make_problem
from ._search import design
from ._tune import DEFAULT_STAGES, Stage, TuneResult, achievable_range, tune

__all__ = [
    "DEFAULT_POINTS",
    "QUANTITIES",
    "GradedDesign",
    "GradedProblem",
    "design",
    "design_front",
    "graded_problem",
    "quantities",
    "Conditions",
    "DEFAULT_STAGES",
    "Stage",
    "TuneResult",
    "achievable_range",
    "tune",
    "DEFAULT_BOUNDS",
    "DEFAULT_SMOOTHING",
    "SharpGradientWarning",
    "MODES",
    "STRUCTURES",
    "AbstractTerm",
    "Box",
    "Design",
    "Evaluation",
    "Objective",
    "Problem",
    "ShareAtLeast",
    "ShareAtMost",
    "TargetShare",
    "default_box",
    "evaluate",
    "finite_difference",
    "gradient",
    "make_problem",
    "objective",
    "project",
    "share",
]
