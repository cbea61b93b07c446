import sys, msfd_jax
from msfd_jax._runtime import export as ex
orig = ex.compile_program
def wrapped(fn, *args, name):
    dyn, _, sig = ex._dynamic(args)
    p = orig(fn, *args, name=name)
    print("PROGRAM", name, p.source, [d.shape for d in dyn][:1], file=sys.stderr)
    return p
ex.compile_program = wrapped
import msfd_jax._sweeps.queue as q
for mod in list(sys.modules.values()):
    if getattr(mod, "compile_program", None) is orig:
        mod.compile_program = wrapped
from msfd_jax.cli import main
sys.exit(main(sys.argv[1:]))
