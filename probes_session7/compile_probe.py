"""Per-test compile time (local probe, not committed)."""
import json, os, time
import pytest
from jax import monitoring

_acc = {"backend": 0.0, "trace": 0.0, "lower": 0.0, "n": 0, "hits": 0, "retr": 0.0}

def _dur(event, duration, **kw):
    if event == "/jax/core/compile/backend_compile_duration":
        _acc["backend"] += duration; _acc["n"] += 1
    elif event == "/jax/core/compile/jaxpr_trace_duration":
        _acc["trace"] += duration
    elif event == "/jax/core/compile/jaxpr_to_mlir_module_duration":
        _acc["lower"] += duration
    elif event == "/jax/compilation_cache/cache_retrieval_time_sec":
        _acc["retr"] += duration

def _ev(event, **kw):
    if event == "/jax/compilation_cache/cache_hits":
        _acc["hits"] += 1

monitoring.register_event_duration_secs_listener(_dur)
monitoring.register_event_listener(_ev)
_out = f"/tmp/probe/per_test_{os.environ.get('PYTEST_XDIST_WORKER','main')}.jsonl"

@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    before = dict(_acc); t0 = time.perf_counter()
    yield
    wall = time.perf_counter() - t0
    rec = {k: _acc[k] - before[k] for k in _acc}
    rec["wall"] = wall; rec["id"] = item.nodeid
    with open(_out, "a") as f:
        f.write(json.dumps(rec) + "\n")
