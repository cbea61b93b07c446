"""Serialized programs (`jax.export`) stored next to the persistent compile cache.

A new process that runs a collision, or a sweep (its queue's programs for each slot count,
`_sweeps.queue`), would trace diffrax's loop again (seconds) before the persistent compilation
cache can even be consulted: JAX's cache is keyed by the lowered program, which only
tracing produces. Here a jitted function's program is traced once,
serialized with `jax.export` and stored under a key made of everything that decides what
tracing would give:

- the function's name, the arguments' pytree structure and static (non-array) leaves, the
  shape, dtype and weak type of every array leaf;
- the versions of Python, jax, jaxlib, equinox, diffrax and msfd-jax, and a hash of the
  core's source files (`msfd_jax/*.py`), so that an edited solver never loads an old program;
- the trace-time settings that change the program: x64, the backend, rank promotion,
  matmul precision, equinox's ``EQX_ON_ERROR`` and `_batched.pruning.SKIP_FAR_BLOCKS` (off: the
  unpruned contact that tests and benchmarks compare against).

A later process with the same key deserializes the program (milliseconds) and compiles it,
which the persistent cache turns into a load. Anything else falls back to tracing, with the
same results: no store set (`enable` not called; the library's default), a key not found, a
file that does not read back, or a program that cannot be exported (e.g. one holding host
callbacks, as equinox's runtime checks are under ``EQX_ON_ERROR=raise``).

The store is trusted as JAX's compile cache is (its records are unpickled): keep it in a
directory only you can write, as ``~/.cache/msfd-jax`` is.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import importlib.metadata
import os
import pickle
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import equinox as eqx
import jax

_FORMAT = 1  # bump when the stored record's layout changes
_store: Path | None = None
_source_hash: str | None = None
_programs: dict[str, Program] = {}  # this process's programs by key (`call`)


def enable(path: str | os.PathLike | None) -> Path | None:
    """Store and load serialized programs in `path` (None switches the store off)."""
    global _store
    _store = None if path is None else Path(path).expanduser()
    _programs.clear()
    return _store


def use_with_compile_cache(path: str | os.PathLike) -> Path:
    """JAX's persistent compile cache in `path`, every program cached, and this store in
    `path`/exported: what a CLI process (`cli.common.enable_compilation_cache`) and a
    cluster's worker (`_sweeps.cluster.use_compile_cache`) set up.

    JAX never writes an executable that contains host callbacks to the cache, and equinox's
    runtime checks are host callbacks under its default ``EQX_ON_ERROR=raise``. The solver's
    own (diffrax's input checks) are traced as NaN in every process (`checks_as_nan`); here,
    unless the user chose a mode, every other check of the process's programs is switched to
    ``nan`` too: a failed check then gives NaN, which the solver's non-finite guard reports.
    """
    import equinox._errors

    # The public switch is the environment variable EQX_ON_ERROR, but equinox reads it once,
    # at its own import (equinox/_config.py), and this can only run after `msfd_jax` (hence
    # diffrax and equinox) is imported. Setting os.environ here would change nothing in this
    # process and leak into child processes. So the one way is equinox's module-level
    # default, which `error_if` consults at trace time; it is private, hence guarded: a
    # future equinox without it only loses the cache, never breaks a run. The jax settings
    # below are public configuration.
    if _checks_are_ours():
        equinox._errors.EQX_ON_ERROR = "nan"
    path = Path(path).expanduser()
    jax.config.update("jax_compilation_cache_dir", str(path))
    enable(path / "exported")  # serialized programs: no tracing in a new process
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    return path


def _checks_are_ours() -> bool:
    """Whether equinox's check mode may be set here: the user chose none (``EQX_ON_ERROR`` in
    the environment) and this equinox has the module-level default `use_with_compile_cache`
    explains."""
    import equinox._errors

    return "EQX_ON_ERROR" not in os.environ and hasattr(equinox._errors, "EQX_ON_ERROR")


_checks_lock = threading.Lock()
_checks_depth = 0
_checks_saved: str | None = None


@contextlib.contextmanager
def checks_as_nan():
    """Trace diffrax's input checks inside this block as NaN, not host callbacks.

    diffrax checks its inputs with equinox's runtime checks (``dt0`` has the sign of
    ``t1 - t0``; every ``SaveAt.ts`` increases and lies in ``[t0, t1]``), and under equinox's
    default ``EQX_ON_ERROR=raise`` each is a host callback: JAX then never writes the program to
    its persistent compile cache, nor can `jax.export` serialize it. The solver's inputs meet
    these checks by construction (a positive step from the validated stability limit; the
    sample times a ``linspace`` from 0 to the cap, the shape times sorted and those past the
    cap dropped), so tracing them as ``nan`` (what a CLI process does for every program) changes
    no result and makes every collision program cacheable. A mode the user chose in the
    environment (``EQX_ON_ERROR``) is respected. Nested and concurrent blocks (the sweep's
    worker threads) share one switch, restored when the last block exits.
    """
    import equinox._errors

    global _checks_depth, _checks_saved
    if not _checks_are_ours():
        yield
        return
    with _checks_lock:
        if _checks_depth == 0:
            _checks_saved = equinox._errors.EQX_ON_ERROR
            equinox._errors.EQX_ON_ERROR = "nan"
        _checks_depth += 1
    try:
        yield
    finally:
        with _checks_lock:
            _checks_depth -= 1
            if _checks_depth == 0:
                equinox._errors.EQX_ON_ERROR = _checks_saved


def store() -> Path | None:
    """The directory of serialized programs, or None when they are off."""
    return _store


@dataclasses.dataclass(frozen=True)
class _Leaf:
    """Placeholder for the i-th array output in a stored output template."""

    index: int


class Program:
    """A compiled program of a jitted function for one argument signature.

    `source` says where it came from: ``"loaded"`` (a stored serialized program),
    ``"exported"`` (traced, serialized and stored now) or ``"traced"`` (no store, or the
    program could not be exported; `reason` says why). `make_s`: the seconds tracing and
    compiling it took when it was made, measured now or, for a loaded program, recorded in
    the store by the process that made it (None for a record written before it was kept):
    what another program of its kind would cost to make, which its load time does not tell.
    """

    def __init__(
        self,
        compiled: Callable,
        template: Any,
        source: str,
        reason: str = "",
        make_s: float | None = None,
    ):
        self._compiled = compiled
        self._template = template
        self.source = source
        self.reason = reason
        self.make_s = make_s

    def __call__(self, *args):
        if self._template is None:  # a traced program takes the arguments as they are
            return self._compiled(*args)
        out = self._compiled(*_dynamic(args)[0])
        return jax.tree_util.tree_map(
            lambda x: out[x.index] if isinstance(x, _Leaf) else x,
            self._template,
            is_leaf=lambda x: isinstance(x, _Leaf),
        )


def call(fn: Callable, *args, name: str):
    """``fn(*args)``, through a stored program when the store is on (`compile_program`).

    Without a store, under ``jax.disable_jit()``, or under a transformation (a tracer among
    the arguments), this is ``fn(*args)``: jit's own cache serves repeated calls in a process.
    """
    leaves = jax.tree_util.tree_leaves(args)
    if _store is None or jax.config.jax_disable_jit:  # disable_jit: no compiled program
        return fn(*args)
    if any(isinstance(x, jax.core.Tracer) for x in leaves):
        return fn(*args)
    key = _key_text(name, _dynamic(args)[2])
    if key is None:
        return fn(*args)
    if key not in _programs:
        _programs[key] = compile_program(fn, *args, name=name)
    return _programs[key](*args)


_on_compile: list[Callable[[], None]] = []


def on_compile(callback: Callable[[], None] | None) -> None:
    """Call `callback()` (once per program) before a program is traced and compiled anew,
    never when it is loaded from the store: the CLI says "compiling" only when it does.
    None removes it."""
    _on_compile.clear()
    if callback is not None:
        _on_compile.append(callback)


def _compiling() -> None:
    for callback in _on_compile:
        callback()


def compile_program(fn: Callable, *args, name: str) -> Program:
    """The compiled program of ``fn(*args)`` (`fn` jitted, e.g. by `eqx.filter_jit`).

    Non-array leaves of `args` are static (as in `eqx.filter_jit`); the program is called
    with arguments of the same structure, static values and array shapes.
    """
    dynamic, rebuild, signature = _dynamic(args)
    if _store is None:
        return _traced(fn, args, "no store of serialized programs")
    key_text = _key_text(name, signature)
    if key_text is None:
        return _traced(fn, args, "a static argument has no stable repr (no key)")
    path = _path(name, key_text)
    loaded = _load(path, key_text)
    if loaded is not None:
        exported, template, make_s = loaded
        compiled = jax.jit(exported.call).lower(*dynamic).compile()
        return Program(compiled, template, "loaded", make_s=make_s)
    _compiling()
    tick = time.perf_counter()
    try:
        exported, template = _export(fn, dynamic, rebuild)
        serialized = bytes(exported.serialize())
        # compile what a later process loads: a deserialized program lowers to another
        # module than the fresh one, and only the same module hits the compile cache
        exported = jax.export.deserialize(bytearray(serialized))
    except Exception as error:  # noqa: BLE001 (any export failure falls back to tracing)
        return _traced(fn, args, f"export failed: {type(error).__name__}: {error}")
    compiled = jax.jit(exported.call).lower(*dynamic).compile()
    make_s = time.perf_counter() - tick
    _save(path, key_text, serialized, template, make_s)
    return Program(compiled, template, "exported", make_s=make_s)


def _path(name: str, key_text: str) -> Path:
    """Where the program of `name` under `key_text` is stored (the store must be on)."""
    assert _store is not None
    return _store / f"{name}-{hashlib.sha256(key_text.encode()).hexdigest()[:32]}.jaxexport"


def _traced(fn: Callable, args: tuple, reason: str) -> Program:
    _compiling()
    tick = time.perf_counter()
    compiled = fn.lower(*args).compile()
    return Program(compiled, None, "traced", reason, make_s=time.perf_counter() - tick)


def _dynamic(args: tuple):
    """(array leaves, rebuild(arrays) -> args, signature: structure, statics and avals)."""
    leaves, treedef = jax.tree_util.tree_flatten(args)
    is_array = [eqx.is_array(x) for x in leaves]
    dynamic = [x for x, a in zip(leaves, is_array, strict=True) if a]

    def rebuild(arrays):
        it = iter(arrays)
        pairs = zip(leaves, is_array, strict=True)
        return treedef.unflatten([next(it) if a else x for x, a in pairs])

    statics = [None if a else x for x, a in zip(leaves, is_array, strict=True)]
    avals = [(x.shape, str(x.dtype), bool(getattr(x, "weak_type", False))) for x in dynamic]
    return dynamic, rebuild, (str(treedef), repr(statics), repr(avals))


def signature(args: tuple) -> tuple[str, str, str]:
    """What a jitted function's program depends on in `args`: their structure, static values
    and array shapes and dtypes (a hashable key within a process)."""
    return _dynamic(args)[2]


def _key_text(name: str, signature: tuple) -> str | None:
    if any(" at 0x" in part for part in signature):  # a repr with an address: no stable key
        return None
    import equinox._errors

    environment = {
        "format": _FORMAT,
        "python": sys.version,
        "versions": _versions(),
        "source": source_hash(),
        "backend": jax.default_backend(),
        "x64": bool(jax.config.jax_enable_x64),
        "rank_promotion": str(jax.config.jax_numpy_rank_promotion),
        "matmul_precision": str(jax.config.jax_default_matmul_precision),
        "eqx_on_error": str(getattr(equinox._errors, "EQX_ON_ERROR", "?")),
        # read where it is set, without importing the core (this module stays light)
        "skip_far_blocks": bool(
            getattr(sys.modules.get("msfd_jax._batched.pruning"), "SKIP_FAR_BLOCKS", True)
        ),
    }
    return repr((name, *signature, sorted(environment.items())))


@functools.cache
def _versions() -> dict[str, str]:
    import jaxlib

    try:
        msfd = importlib.metadata.version("msfd-jax")
    except importlib.metadata.PackageNotFoundError:  # a source tree: the source hash decides
        msfd = "0+unknown"
    return {
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "equinox": eqx.__version__,
        # from the metadata: importing diffrax only for its version would cost a loaded
        # program's process ~0.5 s (it is imported only to trace)
        "diffrax": importlib.metadata.version("diffrax"),
        "msfd-jax": msfd,
    }


def source_hash() -> str:
    """sha256 of the core's source files (`msfd_jax/*.py` and its layers, `msfd_jax/_*/*.py`),
    computed once per process: an edit of any module a program is traced from changes it."""
    global _source_hash
    if _source_hash is None:
        digest = hashlib.sha256()
        root = Path(__file__).parents[1]
        for file in sorted([*root.glob("*.py"), *root.glob("_*/*.py")]):
            name = file.relative_to(root).as_posix()
            digest.update(name.encode() + b"\0" + file.read_bytes() + b"\0")
        _source_hash = digest.hexdigest()
    return _source_hash


def _export(fn: Callable, dynamic: list, rebuild: Callable):
    """Trace `fn` once into a `jax.export.Exported` of array leaves, and its output template."""
    template = []
    # the undecorated function: a filter_jit's cached trace may predate the CLI's switch of
    # equinox's checks to NaN (EQX_ON_ERROR), and its host callbacks cannot be exported
    inner = getattr(fn, "__wrapped__", fn)

    def flat(*arrays):
        out = inner(*rebuild(arrays))
        leaves, treedef = jax.tree_util.tree_flatten(out)
        arrays_out, marks = [], []
        for x in leaves:
            if isinstance(x, jax.Array):
                marks.append(_Leaf(len(arrays_out)))
                arrays_out.append(x)
            else:  # a static output (a Python value) is kept in the template
                marks.append(x)
        template.append(treedef.unflatten(marks))
        return arrays_out

    exported = jax.export.export(jax.jit(flat))(*dynamic)
    return exported, template[0]


def _load(path: Path, key_text: str):
    """(Exported, template, make_s) stored at `path` under `key_text`, or None (any
    failure); make_s is None in a record written before it was kept."""
    try:
        record = pickle.loads(path.read_bytes())
        if record.get("key") != key_text:
            return None
        exported = jax.export.deserialize(bytearray(record["exported"]))
        return exported, record["template"], record.get("make_s")
    except Exception:  # noqa: BLE001 (missing, truncated or foreign file: trace instead)
        return None


def _save(
    path: Path, key_text: str, serialized: bytes, template, make_s: float | None = None
) -> None:
    """Write atomically (a temporary file renamed), so a reader never sees half a file."""
    record = {"key": key_text, "exported": serialized, "template": template, "make_s": make_s}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        with os.fdopen(fd, "wb") as f:
            f.write(pickle.dumps(record, protocol=pickle.HIGHEST_PROTOCOL))
        os.replace(tmp, path)
    except OSError:  # a read-only or full disk costs the next process a trace, nothing else
        pass
