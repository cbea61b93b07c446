"""Case files: ``msfd run CASE.toml``, ``msfd sweep CASE.toml`` (and ``msfd tune``).

A case file is TOML with one table per option group of the subcommand's ``--help``; every
long option has a key, its name with ``_`` for ``-`` (``--beam-contact-segments`` is
``beam_contact_segments`` in ``[mesh]``). Sections (`SECTIONS`): ``[collision]`` (the
non-dimensional groups, ``axial_constraint``, or the SI values ``youngs_modulus`` ...
``impact_speed``, ``block_mass``; any SI value switches to SI input), ``[mesh]``,
``[settings]`` (numerics), ``[output]``, ``[input]``; for a sweep ``[axes]`` (lists, or the
command line's ``"a:b:n"`` strings; ``[collision]`` is accepted there too), ``[batching]``; for
tune ``[targets]``, ``[tuning]``, ``[robust]``. Options given on the command line override the
file; an unknown section or key is refused with the allowed ones (exit code 2).
"""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path
from typing import Any

from .common import UsageError

# First word of an argument group's title -> its section in a case file.
SECTIONS = {
    "collision": "collision",
    "si": "collision",
    "grid": "axes",
    "mesh": "mesh",
    "numerics": "settings",
    "output": "output",
    "input": "input",
    "batching": "batching",
    "targets": "targets",
    "tuning": "tuning",
    "robust": "robust",
    "design": "design",
}
# In a sweep, [collision] may hold axes too (one value or a list).
ALIASES = {"axes": ("collision",)}


def keys(parser: argparse.ArgumentParser) -> dict[str, dict[str, argparse.Action]]:
    """Section -> key -> the option's action, for every long option of `parser`."""
    out: dict[str, dict[str, argparse.Action]] = {}
    for group in parser._action_groups:  # argparse keeps its groups there (stable since 3.2)
        words = (group.title or "").split()
        section = SECTIONS.get(words[0].lower() if words else "")
        if section is None:
            continue
        for action in group._group_actions:
            names = [s for s in action.option_strings if s.startswith("--")]
            if names and action.dest != "help":
                out.setdefault(section, {})[names[0][2:].replace("-", "_")] = action
    for section, others in ALIASES.items():
        if section in out:
            for other in others:
                out.setdefault(other, {}).update(out[section])
    return out


def _convert(where: str, action: argparse.Action, value: Any) -> Any:
    """A TOML value as the option would have parsed it (UsageError naming `where`)."""
    if action.nargs == 0:  # store_true / BooleanOptionalAction
        if not isinstance(value, bool):
            raise UsageError(f"{where} must be true or false, got {value!r}")
        return value if action.const is not False else not value
    if action.choices is not None:
        if isinstance(value, bool) and {"held", "free"} <= set(action.choices):
            value = "held" if value else "free"
        if value not in action.choices:
            allowed = ", ".join(map(str, action.choices))
            raise UsageError(f"{where} = {value!r} is not allowed; allowed: {allowed}")
        return value
    if isinstance(value, bool):
        raise UsageError(f"{where} must be a number or a string, got {value!r}")
    parse = action.type or str
    try:
        if isinstance(value, list):
            texts = [repr(v) if isinstance(v, float) else str(v) for v in value]
            if action.nargs in ("+", "*"):
                return [parse(t) for t in texts]
            return parse(",".join(texts))
        text = repr(value) if isinstance(value, float) else str(value)
        parsed = parse(text)
        return [parsed] if action.nargs in ("+", "*") else parsed
    except (argparse.ArgumentTypeError, ValueError, TypeError) as error:
        raise UsageError(f"{where} = {value!r}: {error}") from None


def load(path: Path, parser: argparse.ArgumentParser) -> dict[str, Any]:
    """Argument defaults (dest -> value) from the case file at `path`, for `parser`."""
    try:
        data = tomllib.loads(Path(path).read_text())
    except OSError as error:
        raise UsageError(f"cannot read the case file {path}: {error.strerror}") from None
    except tomllib.TOMLDecodeError as error:
        raise UsageError(f"case file {path} is not valid TOML: {error}") from None
    allowed = keys(parser)
    out: dict[str, Any] = {}
    seen: dict[str, str] = {}
    for section, table in data.items():
        if section not in allowed:
            names = ", ".join(f"[{s}]" for s in allowed)
            raise UsageError(f"case file {path}: unknown section [{section}]; allowed: {names}")
        if not isinstance(table, dict):
            raise UsageError(f"case file {path}: {section} must be a [section] table")
        for key, value in table.items():
            action = allowed[section].get(key)
            if action is None:
                names = ", ".join(sorted(allowed[section]))
                raise UsageError(
                    f"case file {path}: unknown key {key!r} in [{section}]; allowed: {names}"
                )
            if action.dest in seen:
                raise UsageError(
                    f"case file {path}: {key} is given twice ([{seen[action.dest]}], [{section}])"
                )
            seen[action.dest] = section
            out[action.dest] = _convert(f"case file {path}: [{section}] {key}", action, value)
    return out
