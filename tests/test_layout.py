"""The house's layout: the packages' layers import only downwards, no import cycle, and the
solver path (one collision) loads neither matplotlib, nor the optimiser, nor diffrax when its
programs are stored."""

import ast
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1]
PACKAGES = ("msfd_jax", "optimise")


def _modules() -> dict[str, Path]:
    """Every module of the two packages by dotted name (a package is its ``__init__``)."""
    out = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Modules of the two packages that `name` imports, anywhere in it (functions included)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            # `from a import b`: b is the submodule a.b when there is one, else a name in a
            targets = [
                f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names
            ]
        else:
            continue
        found.update(t for t in targets if t in modules and t != name)
    return found


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as a list of modules (first = last), or None."""
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    stack: list[str] = []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_no_import_cycle_in_msfd_jax_or_optimise():
    modules = _modules()
    graph = {name: _imports(name, path, modules) for name, path in modules.items()}
    assert "msfd_jax.cli.common" in graph["optimise._cli"]  # the graph sees real edges
    cycle = _cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


# The layers, lowest first (docs/architecture.md draws them). A module may import its own
# layer and those below it; layers on one rank are siblings and may not import each other
# (the two pipelines: the per-chain reference and the batched core).
LAYERS = (
    ("msfd_jax._runtime",),
    ("msfd_jax._model",),
    ("msfd_jax._reference", "msfd_jax._batched"),
    ("msfd_jax._collision",),
    ("msfd_jax._sweeps",),
    ("msfd_jax._plot",),
    ("msfd_jax",),
    ("msfd_jax.studies",),
    ("msfd_jax.cli.common",),
    ("optimise",),
    ("msfd_jax.cli",),
)


def _layer(module: str) -> tuple[int, str]:
    """(rank, layer) of a module: the layer with the longest matching prefix."""
    best = max(
        (
            (len(layer), rank, layer)
            for rank, group in enumerate(LAYERS)
            for layer in group
            if module == layer or module.startswith(layer + ".")
        ),
    )
    return best[1], best[2]


def test_every_module_imports_only_its_layer_and_those_below():
    modules = _modules()
    upward = []
    for name, path in modules.items():
        rank, layer = _layer(name)
        for target in _imports(name, path, modules):
            t_rank, t_layer = _layer(target)
            if t_rank > rank or (t_rank == rank and t_layer != layer):
                upward.append(f"{name} ({layer}) imports {target} ({t_layer})")
    assert not upward, "imports against the layer order:\n" + "\n".join(sorted(upward))


def test_the_layer_test_sees_every_layer_and_a_violation():
    modules = _modules()
    names = {layer for group in LAYERS for layer in group}
    assert names <= set(modules), names - set(modules)  # every layer exists
    # the batched core really imports the model (so the check above is not vacuous), and
    # the ranks order a known downward edge correctly
    assert "msfd_jax._model.scene" in _imports(
        "msfd_jax._batched.flat", modules["msfd_jax._batched.flat"], modules
    )
    assert _layer("msfd_jax._batched.flat")[0] > _layer("msfd_jax._model.scene")[0]
    assert _layer("msfd_jax._reference.dynamics")[0] == _layer("msfd_jax._batched.engine")[0]


def _last_line(code: str) -> str:
    """The last line `code` prints in a fresh interpreter (which must exit cleanly)."""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.strip().splitlines()[-1]


def test_the_solver_path_imports_no_matplotlib():
    code = (
        "import sys; import msfd_jax as m; "
        "m.run(m.CollisionParams(), m.Mesh(6, 8, 2), m.Settings(t_max=0.3)); "
        "print('matplotlib' in sys.modules)"
    )
    assert _last_line(code) == "False"


def test_msfd_run_builds_only_its_parser_and_imports_no_optimiser():
    # issue 11 goal 4: `tune`'s options come from optimise (optax); `msfd run` needs neither
    code = (
        "import sys; from msfd_jax.cli import build_parser; "
        "p = build_parser('run'); p.parse_args(['run', '--json']); "
        "print(sorted(m for m in ('optimise', 'optax', 'matplotlib', 'dask') if m in sys.modules))"
    )
    assert _last_line(code) == "[]"


def test_msfd_run_with_a_stored_program_imports_no_diffrax(tmp_path):
    # issue 11 goal 4: diffrax (with optimistix and lineax, ~0.5 s of CPU) is imported only to
    # trace; a warm `msfd run` loads the stored programs (`msfd_jax._runtime.export`) and runs them
    argv = [
        "run", "--json", "--ring-segments", "6", "--beam-contact-segments", "8",
        "--beam-outer-segments", "2", "--t-max", "0.3", "--history-points", "11",
    ]  # fmt: skip
    code = (
        "import contextlib, io, json, sys; from msfd_jax.cli import main\n"
        "out = io.StringIO()\n"
        f"with contextlib.redirect_stdout(out): rc = main({argv!r})\n"
        "assert rc == 0 and json.loads(out.getvalue())['ok']\n"
        "print(sorted(m for m in ('diffrax', 'optimistix', 'lineax', 'matplotlib', 'optax',"
        " 'dask', 'pandas', 'tqdm') if m in sys.modules))"
    )
    env = {**os.environ, "MSFD_CACHE_DIR": str(tmp_path)}
    lines, notes = [], []
    for _ in range(2):  # the first process traces and stores, the second loads
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=600,
            cwd=tmp_path, env={**env, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])},
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-3000:]
        lines.append(done.stdout.strip().splitlines()[-1])
        notes.append("compiling" in done.stderr)
    assert "diffrax" in lines[0]  # the first traced (so the check below is not vacuous)
    assert lines[1] == "[]"
    # the CLI says it compiles only when it does: not when it loads the stored programs
    assert notes == [True, False]


def test_a_run_refuses_float32_after_the_switch_was_turned_off():
    # `import msfd_jax` turns float64 on for the process; turned off afterwards, a run and a
    # sweep say so instead of computing silently in float32 (README, Gotchas)
    code = (
        "import jax, msfd_jax as m\n"
        "jax.config.update('jax_enable_x64', False)\n"
        "import warnings; warnings.simplefilter('ignore')\n"
        "for call in (lambda: m.run(m.CollisionParams(), m.Mesh(6, 8, 2)),\n"
        "             lambda: m.sweep({'thickness_ratio': [1.0]}, m.Mesh(6, 8, 2))):\n"
        "    try:\n"
        "        call()\n"
        "    except RuntimeError as e:\n"
        "        print('refused' if 'jax_enable_x64' in str(e) else e)\n"
        "print('done')"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["refused", "refused", "done"], done.stdout
