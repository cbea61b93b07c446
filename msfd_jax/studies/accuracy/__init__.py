"""The work-precision study (issue 5): other integrators against the default Verlet step."""

from . import methods as _methods

globals().update({k: v for k, v in vars(_methods).items() if not k.startswith("__")})
