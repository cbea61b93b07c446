"""What a run needs to be made again: its mesh, settings and smoothing as JSON, and versions.

``msfd run --json`` records `mesh_json`, `settings_json` and `versions`; ``msfd run
--from-json`` reads them back with `mesh_from_json` and `settings_from_json`. Every field of
`Mesh` and `Settings` is written (generically, so a field added later is recorded too).

`dumps` is the one way msfd writes JSON (every ``--json`` output, the sweep's and the
reproduction's records): strict JSON, so a value that is not a number (a failed run's NaN, a
setting not given) is ``null``, never the bare ``NaN`` or ``Infinity`` that strict parsers
refuse.
"""

from __future__ import annotations

import dataclasses
import datetime
import importlib.metadata
import json
import math
import platform
import sys
from typing import Any

import numpy as np

from .._model.params import Mesh

_PACKAGES = ("msfd-jax", "jax", "jaxlib", "diffrax", "equinox", "optax", "numpy")


def _version(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def versions() -> dict[str, str]:
    """Versions of msfd-jax and what it runs on (packages, Python, platform, JAX backend)."""
    out = {name: _version(name) for name in _PACKAGES}
    out["python"] = sys.version.split()[0]
    out["platform"] = platform.platform()
    try:
        import jax

        out["jax_backend"] = jax.default_backend()
    except Exception:  # noqa: BLE001 (a missing backend must not stop a record)
        out["jax_backend"] = "unknown"
    return out


def now() -> str:
    """The current time, UTC, ISO 8601."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def json_ready(value: Any) -> Any:
    """`value` as plain JSON data: numpy scalars and arrays as Python numbers and lists, tuples
    as lists, and every non-finite float (NaN, inf: a number that is not there) as None."""
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, np.generic):
        return json_ready(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dumps(value: Any, **kwargs: Any) -> str:
    """Strict JSON text of `value` (`json_ready`): ``allow_nan=False``, so a non-finite float
    that got past `json_ready` (through a ``default``) raises instead of writing ``NaN``."""
    return json.dumps(json_ready(value), allow_nan=False, **kwargs)


def _plain(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int | np.integer):
        return int(value)
    return float(np.asarray(value))


def _fields(module) -> dict[str, Any]:
    return {f.name: _plain(getattr(module, f.name)) for f in dataclasses.fields(module)}


def params_json(params) -> dict[str, Any]:
    """A collision's groups as JSON numbers; a graded beam's `thickness_profile` as a list
    (recorded only when given: the uniform beam's records stay as they were)."""
    out = {k: float(np.asarray(v)) for k, v in params.scalars().items()}
    if params.graded:
        out["thickness_profile"] = [float(v) for v in np.asarray(params.thickness_profile)]
    return out


def mesh_json(mesh: Mesh) -> dict[str, Any]:
    # collapse_contacts is recorded only when on: records of the paper's model,
    # and the sweeps' stores holding them, stay as they were
    out = _fields(mesh)
    if not out.get("collapse_contacts"):
        out.pop("collapse_contacts", None)
    return out


def settings_json(settings) -> dict[str, Any]:
    # contact_loop is recorded only when given: the default's records, and the
    # sweeps' stores holding them, stay as they were
    out = _fields(settings)
    if out.get("contact_loop") is None:
        out.pop("contact_loop", None)
    return out


def mesh_from_json(record: dict[str, Any]) -> Mesh:
    return Mesh(**record)


def settings_from_json(record: dict[str, Any]):
    from .._batched.simulate import Settings

    values = dict(record)
    if "shape_times" in values:
        values["shape_times"] = tuple(float(t) for t in values["shape_times"])
    return Settings(**values)
