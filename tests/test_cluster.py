"""Sweeps on a real Dask LocalCluster (2 worker processes, no mocks), rows written as they
finish, and resume.

One cluster serves the module; its workers share a compile cache in a temporary directory.
Every sweep here runs the same six collisions on a coarse mesh in tasks of two (three tasks),
so each process compiles one program. The in-process sweep is the reference.
"""

import csv
import json
import os
import signal
import time

import numpy as np
import pytest
from conftest import COMPARE_SMOOTHING

import msfd_jax as m
from msfd_jax._sweeps import cluster as _cluster
from msfd_jax._sweeps.store import open_store
from msfd_jax._sweeps.sweep import INPUTS, OUTPUTS, SweepTable, _numerics, sweep
from msfd_jax.cli import main

pytest.importorskip("distributed")

MESH = m.Mesh(ring_segments=8, beam_contact_segments=10, beam_outer_segments=3)
SETTINGS = m.Settings(t_max=1.0, history_points=2, shape_times=())
GRID = {"thickness_ratio": [1.0, 2.0, 3.0], "mass_ratio": [5.0, 10.0]}
OPTIONS = dict(chunk_size=2, contact_smoothing=COMPARE_SMOOTHING)  # see conftest


class Interrupted(Exception):
    """What a killed sweep looks like to the caller: an exception after some rows."""


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("compile-cache")


@pytest.fixture(scope="module")
def client(cache):
    client = _cluster.connect("local:2")
    yield client
    _cluster.close(client)


@pytest.fixture(scope="module")
def reference():
    return sweep(GRID, MESH, SETTINGS, **OPTIONS)


def cluster_sweep(client, cache, **kwargs):
    return sweep(GRID, MESH, SETTINGS, **OPTIONS, client=client, compile_cache=cache, **kwargs)


def assert_same_rows(table: SweepTable, reference: SweepTable) -> None:
    assert list(table.keys()) == list(reference.keys())
    for key in (*INPUTS, *OUTPUTS):
        if key == "wall_time_s":
            continue
        if reference[key].dtype.kind == "f":
            np.testing.assert_allclose(table[key], reference[key], rtol=1e-12, atol=1e-12)
        else:
            np.testing.assert_array_equal(table[key], reference[key], err_msg=key)


def test_cluster_sweep_equals_in_process(client, cache, reference, tmp_path):
    assert len(client.scheduler_info()["workers"]) == 2
    table = cluster_sweep(client, cache, output=tmp_path / "rows.parquet")
    assert_same_rows(table, reference)
    assert table.computed.all()
    # the workers stored the queue's programs with the cache (`_export`): later workers,
    # and the tests below, load them instead of tracing
    assert any((cache / "exported").glob("queue_segment-*.jaxexport"))
    # the Parquet store ends as one table in the grid's order
    store = tmp_path / "rows.parquet"
    assert sorted(p.name for p in store.iterdir()) == ["meta.json", "table.parquet"]
    back = SweepTable(open_store(store).finished())
    assert_same_rows(back, reference)


def test_the_first_task_primes_the_compile_cache_before_the_others_start(client, cache):
    """Workers that meet a program at the same moment all miss the persistent cache and all
    compile it (this module's first sweep did: its two workers compiled one exported program
    at once, 16.7 CPU-s). With a compile cache, the first task runs alone; the others start
    after it has finished."""

    def solve(columns):  # a task that says when it ran (cloudpickled by value)
        start = time.time()
        time.sleep(0.3)
        n = len(columns["x"])
        return {"start": np.full(n, start), "end": np.full(n, time.time())}

    ran = {}

    def on_rows(rows, outputs):
        ran[int(rows[0])] = (float(outputs["start"][0]), float(outputs["end"][0]))

    rows = np.arange(6)
    _cluster.solve_on_cluster(
        client, solve, {"x": rows.astype(float)}, rows, 2, {}, on_rows, compile_cache=cache
    )
    assert sorted(ran) == [0, 2, 4]
    primed = ran[0][1]
    assert all(start >= primed for first_row, (start, _) in ran.items() if first_row != 0), ran


def test_interrupted_cluster_sweep_resumes_computing_only_the_missing(
    client, cache, reference, tmp_path
):
    path = tmp_path / "rows.csv"

    def kill_after_first_task(rows, outputs):
        raise Interrupted

    with pytest.raises(Interrupted):
        cluster_sweep(client, cache, output=path, on_rows=kill_after_first_task)
    written = SweepTable.read_csv(path)
    assert len(written) == 2  # the first finished task; the others were cancelled
    with path.open("a") as stream:  # and a kill in the middle of writing a row
        stream.write("2.0,5.0,1.3")
    seen = []
    table = cluster_sweep(
        client, cache, output=path, resume=True, on_rows=lambda r, o: seen.extend(r.tolist())
    )
    assert_same_rows(table, reference)
    kept = {tuple(written[k][i] for k in INPUTS) for i in range(2)}
    done_before = [tuple(table[k][i] for k in INPUTS) in kept for i in range(len(table))]
    np.testing.assert_array_equal(table.computed, ~np.asarray(done_before))
    assert sorted(seen) == np.flatnonzero(table.computed).tolist()  # only the missing rows
    assert_same_rows(SweepTable.read_csv(path), reference)  # the file, in the grid's order

    # a resume of the finished sweep computes nothing
    again = cluster_sweep(client, cache, output=path, resume=True, on_rows=seen.append)
    assert not again.computed.any() and len(seen) == 4
    assert_same_rows(again, reference)


def test_in_process_sweep_interrupted_and_resumed(reference, tmp_path):
    path = tmp_path / "rows.csv"
    groups = []

    def kill_after_the_first_group(rows, outputs):
        groups.append(rows)
        raise Interrupted

    with pytest.raises(Interrupted):
        sweep(GRID, MESH, SETTINGS, **OPTIONS, output=path, on_rows=kill_after_the_first_group)
    # the groups are the collisions that stopped in the same segment of the batched core
    written = {int(i) for g in groups for i in g}
    assert 0 < len(written) < len(reference)
    assert len(SweepTable.read_csv(path)) == len(written)
    table = sweep(GRID, MESH, SETTINGS, **OPTIONS, output=path, resume=True)
    assert table.computed.tolist() == [i not in written for i in range(len(reference))]
    assert_same_rows(table, reference)


def test_a_lost_worker_s_tasks_are_rerun(client, cache, reference):
    killed = []

    def kill_a_busy_worker(rows, outputs):
        busy = [w for w, tasks in client.processing().items() if tasks]
        if busy and not killed:
            pid = client.run(os.getpid, workers=busy[:1])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    table = cluster_sweep(client, cache, task_size=1, on_rows=kill_a_busy_worker)
    assert killed  # a worker died with a task in flight; the nanny restarts it
    assert_same_rows(table, reference)


def test_resume_refuses_other_numerics_and_other_collisions(reference, tmp_path):
    path = tmp_path / "rows.csv"
    with pytest.raises(ValueError, match="exists; resume it"):
        path.write_text("")
        sweep(GRID, MESH, SETTINGS, **OPTIONS, output=path)
    reference.to_csv(path)
    with pytest.raises(ValueError, match="no collision of this sweep"):
        sweep({"thickness_ratio": [1.0]}, MESH, SETTINGS, **OPTIONS, output=path, resume=True)
    other = _numerics(m.Mesh(8, 10, 4), SETTINGS, COMPARE_SMOOTHING, 0.0)
    (tmp_path / "rows.csv.meta.json").write_text(json.dumps(other))
    with pytest.raises(ValueError, match="another mesh \\(see"):
        sweep(GRID, MESH, SETTINGS, **OPTIONS, output=path, resume=True)
    with pytest.raises(ValueError, match=r"\.csv or \.parquet"):
        sweep(GRID, MESH, SETTINGS, **OPTIONS, output=tmp_path / "rows.txt")


def test_worker_threads_are_refused_with_a_client():
    """A cluster's tasks run one thread each: a thread count beside a client would be ignored,
    so it is refused (before the client is used: a stand-in object serves)."""
    with pytest.raises(ValueError, match="workers=2 sets this process's threads"):
        sweep(GRID, MESH, SETTINGS, **OPTIONS, client=object(), workers=2)


COARSE = ["--ring-segments", "8", "--beam-contact-segments", "10", "--beam-outer-segments", "3"]
CLI_GRID = ["--thickness-ratio", "1,2,3", "--mass-ratio", "5,10", "--t-max", "1.0"]
CLI_OPTIONS = ["--chunk-size", "2", "--contact-smoothing", str(COMPARE_SMOOTHING), "-q"]


def test_cli_cluster_sweep_writes_the_in_process_rows(reference, cache, tmp_path, monkeypatch):
    monkeypatch.setenv("MSFD_CACHE_DIR", str(cache))  # the workers' cache, warm by now
    out = tmp_path / "rows.csv"
    argv = ["sweep", *CLI_GRID, *COARSE, *CLI_OPTIONS, "--cluster", "local:2", "--csv", str(out)]
    assert main(argv) == 0
    written = SweepTable.read_csv(out)
    # the CLI's table adds its provenance columns (issue 14): mesh_* and settings_*
    extra = set(written.keys()) - set(reference.keys())
    assert extra and all(k.startswith(("mesh_", "settings_")) for k in extra), extra
    assert_same_rows(SweepTable({k: written[k] for k in reference.keys()}), reference)
    with out.open() as stream:
        assert len(list(csv.reader(stream))) == 1 + len(reference)
    assert main([*argv, "--resume"]) == 0  # nothing left to compute


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--cluster", "local:0"], "--cluster: cluster must be local:N"),
        (["--cluster", "localhost:8786"], "or tcp://HOST:PORT"),
        (["--resume"], "--resume needs --csv"),
        (["--task-size", "4"], "--task-size needs --cluster"),
        (["--cluster", "local:2", "--shard"], "--shard"),
        (["--cluster", "local:2", "--workers", "2"], "size the cluster instead"),
        (["--csv", "rows.txt"], "must end in .csv"),
    ],
)
def test_cli_refuses_bad_cluster_and_output_options(extra, message, capsys):
    assert main(["sweep", "--no-cache", "-q", *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_local_workers_keep_this_process_s_xla_flags(monkeypatch):
    """The workers' one-thread flags come after this process's XLA_FLAGS (a LocalCluster's
    env replaces a variable it names: a user's flags, the suite's too, would be lost)."""
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=2")
    env = _cluster._with_own_flags(_cluster.WORKER_ENV)
    assert env["XLA_FLAGS"] == (
        "--xla_force_host_platform_device_count=2 " + _cluster.WORKER_ENV["XLA_FLAGS"]
    )
    monkeypatch.delenv("XLA_FLAGS")
    assert _cluster._with_own_flags(_cluster.WORKER_ENV) == _cluster.WORKER_ENV
    assert _cluster._with_own_flags({"OTHER": "1"}) == {"OTHER": "1"}
