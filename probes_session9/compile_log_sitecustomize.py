# probe: log every JAX trace/lower/compile and persistent-cache hit of every process to one file
import logging, os, sys, time, re
_LOG = os.environ.get("COMPLOG_FILE")
if _LOG:
    class _H(logging.Handler):
        def emit(self, record):
            try:
                msg = record.getMessage()
                if not ("Finished" in msg or "cache hit" in msg or "cache miss" in msg.lower()):
                    return
                who = os.environ.get("PYTEST_CURRENT_TEST", "") or ("sub:" + os.getcwd().split("/")[-1] + ":" + " ".join(sys.argv[:3])[:80])
                with open(_LOG, "a") as f:
                    f.write(f"{os.getpid()}\t{time.time():.2f}\t{who}\t{msg[:300]}\n")
            except Exception:
                pass
    h = _H(); h.setLevel(logging.DEBUG)
    for name in ("jax._src.dispatch", "jax._src.interpreters.pxla", "jax._src.compiler", "jax._src.compilation_cache", "jax._src.pjit", "jax._src.interpreters.mlir"):
        lg = logging.getLogger(name); lg.addHandler(h); lg.setLevel(logging.DEBUG); lg.propagate = False
    os.environ.setdefault("JAX_LOG_COMPILES", "1")
