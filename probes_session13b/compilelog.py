import os, time, collections
from jax._src import monitoring
_events = []
_cur = {"test": "collect"}
def _lis(event, duration, **kw):
    if "backend_compile" in event or "cache_retrieval" in event or "jaxpr_trace" in event or "to_mlir" in event:
        _events.append((_cur["test"], event.split("/")[-1], kw.get("fun_name", "?"), duration))
monitoring.register_event_duration_secs_listener(_lis)
def pytest_runtest_setup(item):
    _cur["test"] = item.nodeid
def pytest_sessionfinish(session):
    out = os.environ.get("COMPILELOG", "/tmp/plug/log.tsv")
    with open(out, "w") as f:
        for t, e, n, d in _events:
            f.write(f"{t}\t{e}\t{n}\t{d:.3f}\n")
