"""Where a new ``msfd run`` process spends its time, stage by stage (issue 11, goal 4).

One process doing what ``msfd run --json`` does for the showcase, with the wall and CPU time
of each stage: imports, the scene, the stability limit and step bound (`prepare`), the
solver's program (traced and compiled, or loaded: `msfd_jax._export`), the run, the JSON.
Run it twice with the same ``MSFD_CACHE_DIR``: the second process is the warm one. Works on
a source tree without `msfd_jax._export` too (``PYTHONPATH=SRC``), for a before/after.

    MSFD_CACHE_DIR=/tmp/c python benchmarks/startup_stages.py   # twice; the 2nd is warm

(Run it as a script, not with ``-m`` from the repository: ``-m`` puts the working directory
first on sys.path, which imports this tree whatever PYTHONPATH says.)
"""

import resource
import time

marks = []


def mark(name: str) -> None:
    r = resource.getrusage(resource.RUSAGE_SELF)
    marks.append((name, time.perf_counter(), r.ru_utime + r.ru_stime))


mark("start")
import jax  # noqa: E402

mark("import jax")
import msfd_jax as m  # noqa: E402

mark("import msfd_jax")
from msfd_jax._simulate import Settings, _simulate, prepare  # noqa: E402
from msfd_jax.cli.common import enable_compilation_cache  # noqa: E402

enable_compilation_cache()
mark("import msfd_jax.cli, cache on")
params, mesh, settings = m.CollisionParams(), m.Mesh(), Settings()
scene = jax.block_until_ready(m.ring_on_beam(params, mesh))
mark("ring_on_beam")
args = prepare(scene, settings)
mark("prepare (stability limit, step bound)")
try:
    from msfd_jax._export import compile_program
except ImportError:  # a tree from before the export store
    program, source = _simulate.lower(*args).compile(), "traced"
else:
    program = compile_program(_simulate, *args, name="simulate")
    source = program.source
mark(f"solver program ({source}) and compile or cache load")
solution = jax.block_until_ready(program(*args))
mark("run")
record = m.Collision(params, mesh, scene, solution, 0.0, settings=settings).to_json()
mark("JSON record")
for (_, t0, c0), (name, t1, c1) in zip(marks, marks[1:], strict=False):
    print(f"{name:55s} wall {t1 - t0:6.3f} s  CPU {c1 - c0:6.3f} s")
print(
    f"{'total':55s} wall {marks[-1][1] - marks[0][1]:6.3f} s  CPU {marks[-1][2]:6.3f} s "
    f"(steps {record['steps']}, t_end {record['t_end']:.6f})"
)
