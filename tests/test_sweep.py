"""Sweeps: one compiled vmap over chunks equals single runs; grid/list expansion; CSV; CLI.

Every sweep here runs the same four collisions on the small mesh with the shared short
settings and chunk size 3 (rounded up to 16 slots of the batched core), so
the vmapped program is compiled once for the file; the single runs reuse the program that the
other test files compile for `SMALL_MESH` and `SHORT`.
"""

import csv
import dataclasses
import json
import sys

import numpy as np
import pytest
from conftest import COMPARE_SMOOTHING, SHORT, SMALL_MESH

import msfd_jax as m
from msfd_jax._collision.run import FRACTION_KEYS
from msfd_jax._sweeps import shard as _shard
from msfd_jax._sweeps import sweep as _sweep
from msfd_jax._sweeps.sweep import INPUTS, OUTPUTS, SWEEP_SETTINGS, SweepTable, collisions, sweep
from msfd_jax.cli import main
from msfd_jax.cli import sweep as sweep_command

GRID = {"thickness_ratio": [1.0, 2.5], "axial_constraint": [0.0, 1.0]}
POINTS = [(1.0, 0.0), (1.0, 1.0), (2.5, 0.0), (2.5, 1.0)]  # C order: last key fastest
CHUNK = 3
SMOOTH = COMPARE_SMOOTHING  # sweeps compared with single runs (see conftest)


@pytest.fixture(scope="module")
def table():
    return sweep(
        GRID, SMALL_MESH, SHORT, chunk_size=CHUNK, progress=False, contact_smoothing=SMOOTH
    )


def test_grid_expansion_and_list_input():
    columns, grid = collisions({"mass_ratio": [5, 10, 20], "axial_constraint": [True, False]})
    assert grid is not None and list(grid) == ["mass_ratio", "axial_constraint"]
    assert columns["mass_ratio"].tolist() == [5, 5, 10, 10, 20, 20]
    assert columns["axial_constraint"].tolist() == [1, 0, 1, 0, 1, 0]
    # inputs not swept keep the base values (the paper's showcase by default)
    assert set(columns) == set(INPUTS)
    np.testing.assert_array_equal(columns["thickness_ratio"], 2.5)
    base = m.CollisionParams(velocity=0.5)
    rows, grid = collisions([{"thickness_ratio": 1.0}, {"velocity": 0.7}], base)
    assert grid is None
    assert rows["thickness_ratio"].tolist() == [1.0, 2.5]
    assert rows["velocity"].tolist() == [0.5, 0.7]


def test_sweep_equals_single_runs(table):
    assert len(table) == len(POINTS)  # two chunks of 3, the padding of the second dropped
    assert set(table.keys()) == {*INPUTS, *OUTPUTS}
    for i, (thickness, constraint) in enumerate(POINTS):
        assert (table["thickness_ratio"][i], table["axial_constraint"][i]) == (
            thickness,
            constraint,
        )
        params = m.CollisionParams(thickness_ratio=thickness, axial_constraint=constraint)
        single = m.run(params, SMALL_MESH, SHORT, contact_smoothing=SMOOTH).to_json()
        # the same attempts (issue 12 item 1: the h_b/h_r = 1 rows settle their first attempt
        # with 1.04-1.06e-4 K0 open and are rerun at half the step, in the sweep as in run)
        assert table["retries"][i] == single["retries"]
        assert table["safety"][i] == pytest.approx(single["safety"], rel=1e-12)
        # vmap batches the same arithmetic but may reorder float reductions (measured up to
        # 9e-11 relative on these runs' first attempts); 1e-9 still catches any difference in
        # the physics. A rerun runs twice the steps, in a batch of the rerun rows only, and
        # amplifies the reordering further: row 0 at safety 0.35 (7072 steps) measured 1.2e-9
        # and 3.3e-9 relative (kinetic_ring, kinetic_beam; 2.4e-10 K0) in two processes, so a
        # rerun row is held to 1e-8 (a different attempt or step is caught by the asserts on
        # retries, safety and steps)
        rel = 1e-8 if single["retries"] else 1e-9
        fractions = {**single["fractions"], **single["kinetic_split"]}
        for key, value in fractions.items():
            assert table[key][i] == pytest.approx(value, rel=rel, abs=1e-12), key
        assert table["energy_balance_error"][i] == pytest.approx(
            single["energy_balance_error"], rel=1e-6, abs=1e-10
        )
        for key in ("t_end", "dt", "dt_critical", "k0"):
            assert table[key][i] == pytest.approx(single[key], rel=1e-9), key
        assert table["steps"][i] == single["steps"]
        assert table["status"][i] == single["status"]


def test_list_input_gives_the_same_rows(table, capsys):
    rows = [dict(thickness_ratio=t, axial_constraint=a) for t, a in POINTS]
    listed = sweep(
        rows, SMALL_MESH, SHORT, chunk_size=CHUNK, progress=True, contact_smoothing=SMOOTH
    )
    assert listed.grid is None and table.grid is not None
    for key in (*INPUTS, *OUTPUTS):
        if key != "wall_time_s":  # same program, same chunks: identical numbers
            np.testing.assert_array_equal(listed[key], table[key], err_msg=key)
    assert "4/4" in capsys.readouterr().err  # the tqdm bar


def test_csv_round_trip(table, tmp_path):
    back = SweepTable.read_csv(table.to_csv(tmp_path / "sweep.csv"))
    assert list(back.keys()) == list(table.keys())
    for key in table.keys():
        assert back[key].dtype.kind == table[key].dtype.kind, key
        np.testing.assert_array_equal(back[key], table[key], err_msg=key)  # floats exact


def test_failed_runs_are_rows_with_status_and_message():
    # an energy guard far below the O(1e-4) balance error of these runs stops every one;
    # the guard is a traced number, so this reuses the compiled program
    strict = dataclasses.replace(SHORT, energy_guard=1e-12)
    failed = sweep(GRID, SMALL_MESH, strict, chunk_size=CHUNK, progress=False)
    assert failed.failed.all()
    assert set(failed["status"]) == {"energy balance broken"}
    assert all("broke its energy balance" in text for text in failed["message"])


@pytest.mark.parametrize(
    "spec, match",
    [
        ({"thickness_ratio": [1.0, -1.0]}, "thickness_ratio"),
        ([{"velocity": 0.8}, {"velocity": float("nan")}], "velocity"),
        ({"span_ratio": [1.5]}, "span_ratio"),  # inside the contact region OC = 2R
        ({"thickness": [1.0]}, "unknown sweep inputs"),
        ({"mass_ratio": []}, "at least one value"),
    ],
)
def test_bad_values_refused_before_compiling(spec, match, monkeypatch):
    def compiled(*args, **kwargs):
        raise AssertionError("a compiled program was called with unchecked inputs")

    monkeypatch.setattr(_shard, "_solve_chunk", compiled)  # the sharded path (moved there)
    monkeypatch.setattr(_sweep, "_critical_chunk", compiled)
    monkeypatch.setattr(_sweep, "run_queue", compiled)
    with pytest.raises(ValueError, match=match):
        sweep(spec, SMALL_MESH, SHORT, chunk_size=CHUNK, progress=False)


def strict_json(text: str):
    """Strict JSON (tests/test_cli.py): a bare NaN or Infinity is refused."""

    def refuse(constant: str):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("missing", [("h5py",), ("h5netcdf",), ("xarray",)])
def test_netcdf_without_its_modules_is_refused_before_the_sweep(
    missing, monkeypatch, tmp_path, capsys
):
    """Found missing after the sweep, the table would be lost: refused first, exit 2."""
    for name in ("netCDF4", *missing):  # netCDF4: xarray's other NetCDF-4 engine
        monkeypatch.setitem(sys.modules, name, None)  # find_spec gives None: not installed

    def ran(*args, **kwargs):
        raise AssertionError("the sweep ran")

    monkeypatch.setattr(sweep_command, "sweep", ran)
    path = tmp_path / "grid.nc"
    code = main(["sweep", "--velocity", "0.8,0.9", "--netcdf", str(path), "--no-cache", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and missing[0] in err and "pip install 'msfd-jax[sweep]'" in err
    assert not path.exists()


def test_only_a_grid_maps_to_xarray(table):
    rows = SweepTable(dict(table.columns))
    with pytest.raises(ValueError, match="full grid"):
        rows.to_xarray()


def test_cli_sweep(table, tmp_path, capsys):
    small = ["--ring-segments", "6", "--beam-contact-segments", "8", "--beam-outer-segments", "2"]
    short = ["--t-max", "1.5", "--history-points", "31", "--shape-times", "0.5"]
    grid = ["--thickness-ratio", "1:2.5:2", "--axial-constraint", "both"]
    out = tmp_path / "sweep.csv"
    smooth = ["--contact-smoothing", str(SMOOTH)]
    argv = ["sweep", *grid, *small, *short, *smooth, "--chunk-size", "3", "--no-cache"]
    netcdf = tmp_path / "sweep.nc"
    assert main([*argv, "--csv", str(out), "--netcdf", str(netcdf), "--json", "-q"]) == 0
    rows = strict_json(capsys.readouterr().out)
    assert [r["steps"] for r in rows] == table["steps"].tolist()
    assert [r["beam_bending"] for r in rows] == table["beam_bending"].tolist()
    # a setting not given (dt: from --safety; t_max given) is null in JSON, empty in the CSV
    assert rows[0]["settings_dt"] is None and rows[0]["settings_t_max"] == 1.5
    with out.open() as stream:
        first = next(csv.DictReader(stream))
    assert first["settings_dt"] == "" and first["settings_t_max"] == "1.5"
    back = SweepTable.read_csv(out)
    assert len(back) == 4 and np.isnan(back["settings_dt"]).all()
    xarray = pytest.importorskip("xarray")
    with xarray.open_dataset(netcdf) as data:  # the [sweep] extra writes it (h5py included)
        assert data["beam_bending"].shape == (2, 2)
    # --resume reads the finished table back (empty fields included) and computes nothing
    assert main([*argv, "--csv", str(out), "--resume", "-q"]) == 0
    assert "4 of them read back" in capsys.readouterr().out
    # the list form reads the CSV back: same collisions, same numbers
    assert (
        main(
            [
                "sweep",
                "--from-csv",
                str(out),
                *small,
                *short,
                *smooth,
                "--chunk-size",
                "3",
                "--no-cache",
                "--no-progress",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "4 collisions" in printed and "0 failed" in printed
    assert main(["sweep", "--mass-ratio", "5,-1", "--no-cache"]) == 2
    assert "--mass-ratio" in capsys.readouterr().err


def test_sharded_sweep_over_two_host_devices_equals_vmap(table, tmp_path):
    """`--shard --host-devices 2` (a fresh process: XLA's device count is fixed at start-up)
    gives the same rows as the unsharded sweep: each device runs its half of the chunk."""
    import subprocess
    import sys

    small = ["--ring-segments", "6", "--beam-contact-segments", "8", "--beam-outer-segments", "2"]
    short = ["--t-max", "1.5", "--history-points", "31", "--shape-times", "0.5"]
    grid = ["--thickness-ratio", "1:2.5:2", "--axial-constraint", "both"]
    out = tmp_path / "sharded.csv"
    smooth = ["--contact-smoothing", str(SMOOTH)]  # the table's (see SMOOTH)
    argv = ["sweep", *grid, *small, *short, *smooth, "--chunk-size", "4", "--no-cache"]
    argv += ["--no-progress", "--shard", "--host-devices", "2", "--csv", str(out)]
    done = subprocess.run(
        [sys.executable, "-m", "msfd_jax.cli", *argv], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    sharded = SweepTable.read_csv(out)
    for key in ("beam_bending", "ring_bending", "beam_axial", "t_end"):
        np.testing.assert_allclose(sharded[key], table.columns[key], rtol=1e-9, atol=1e-12)


def test_line_progress_prints_each_line_and_counts_steps(capsys):
    from msfd_jax._runtime.progress import LineProgress

    bar = LineProgress(2, "tune", unit=" iterations")
    bar("tune: it   1  first line")
    bar.note("a note that is no step")
    bar("tune: it   2  second line")
    bar.close()
    err = capsys.readouterr().err
    assert "first line" in err and "second line" in err and "a note" in err
    assert "2/2" in err and "msfd tune" in err


ROWS20 = [dict(thickness_ratio=t, velocity=v, axial_constraint=a) for t in (1.0, 1.5, 2.0, 2.5, 3.0)
          for v in (0.7, 0.82) for a in (0.0, 1.0)]  # fmt: skip


@pytest.fixture(scope="module")
def one_worker():
    return sweep(ROWS20, SMALL_MESH, SHORT, chunk_size=CHUNK, contact_smoothing=SMOOTH, workers=1)


def test_more_collisions_than_slots_refill_and_equal_single_runs(one_worker):
    """20 collisions in 16 slots (chunk 3 rounds up to 16): four slots are refilled from the
    queue as their first collisions stop; every row equals its single run."""
    table = one_worker
    assert len(table) == 20
    assert table.timing["slots"] == 16 and table.timing["workers"] == 1
    assert table.timing["segments"] > 1  # the refilled slots ran on after the first ones
    for i, row in enumerate(ROWS20):
        single = m.run(m.CollisionParams(**row), SMALL_MESH, SHORT, contact_smoothing=SMOOTH)
        out = single.to_json()
        assert table["steps"][i] == out["steps"]
        for key, value in out["fractions"].items():
            assert table[key][i] == pytest.approx(value, rel=1e-9, abs=1e-12), (i, key)


def test_worker_threads_give_the_same_rows(one_worker, monkeypatch):
    """Two threads of 16 slots fed from one queue give exactly the rows of one thread: a
    collision's result does not depend on its slot. 40 collisions: refills in both."""
    rows = ROWS20 + [{**r, "mass_ratio": 5.0} for r in ROWS20]
    two = sweep(rows, SMALL_MESH, SHORT, chunk_size=CHUNK, contact_smoothing=SMOOTH, workers=2)
    assert two.timing["workers"] == 2 and two.timing["slots"] == 16
    assert two.timing["segments"] > 2
    one = sweep(rows[20:], SMALL_MESH, SHORT, chunk_size=CHUNK, contact_smoothing=SMOOTH, workers=1)
    for key in OUTPUTS:
        if key == "wall_time_s":
            continue
        first, second = np.asarray(two[key])[:20], np.asarray(two[key])[20:]
        np.testing.assert_array_equal(np.asarray(one_worker[key]), first, err_msg=key)
        np.testing.assert_array_equal(np.asarray(one[key]), second, err_msg=key)
    # one worker of 32 slots: 8 refills, then the tail moves into a program of 16 slots (the
    # payback rule off: here the tail is far shorter than a compilation)
    from msfd_jax._sweeps import queue as _queue

    monkeypatch.setattr(_queue, "TAIL_PAYBACK", 0.0)
    wide = sweep(rows, SMALL_MESH, SHORT, chunk_size=32, contact_smoothing=SMOOTH, workers=1)
    assert wide.timing["slots"] == 32 and wide.timing["compactions"] >= 1
    for key in OUTPUTS:
        if key != "wall_time_s":
            np.testing.assert_array_equal(np.asarray(wide[key]), np.asarray(two[key]), key)


@pytest.mark.parametrize("workers", [0, -1, 1.5, True, "2", 10**6])
def test_bad_worker_count_refused(workers):
    with pytest.raises((TypeError, ValueError), match=r"workers \(None: one per core\)"):
        sweep(GRID, SMALL_MESH, SHORT, chunk_size=CHUNK, workers=workers)


def test_an_error_in_a_worker_thread_reaches_the_caller():
    def fail(rows, outputs):
        raise RuntimeError("disk full")

    rows = ROWS20 + [{**r, "mass_ratio": 5.0} for r in ROWS20]
    with pytest.raises(RuntimeError, match="disk full"):
        sweep(rows, SMALL_MESH, SHORT, chunk_size=CHUNK, contact_smoothing=SMOOTH, workers=2,
              on_rows=fail)  # fmt: skip


def _tail_sweep():
    """ROWS20 on the small mesh through one worker's slots (the tail tests' sweep)."""
    return sweep(ROWS20, SMALL_MESH, SHORT, chunk_size=CHUNK, contact_smoothing=SMOOTH,
                 workers=1)  # fmt: skip


def _tail_rule_costs(monkeypatch) -> list:
    """At each decision of the tail rule from now on, (the cost it compares with, the
    seconds the sweep spent making its first programs), appended to the list returned."""
    from msfd_jax._sweeps import queue as _queue

    costs = []
    compact = _queue._SweepQueue.compact

    def compact_seen(self, slots):
        costs.append((self.make_times[0], self.compile_times[0]))
        return compact(self, slots)

    monkeypatch.setattr(_queue._SweepQueue, "compact", compact_seen)
    return costs


def test_the_scalar_tail_gives_the_same_rows(monkeypatch):
    """The tail's last collisions move to 4, 2 and 1 slots (`_queue.TAIL_SLOTS`): their rows
    equal those of a tail kept at 16 slots, every column (a collision's arithmetic does not
    depend on the slot count). A tail whose new program would not pay for its compilation
    (`_queue.TAIL_PAYBACK`) stays in its slots."""
    from msfd_jax._sweeps import queue as _queue

    assert _queue._tail_size(3, 16) == 4 and _queue._tail_size(1, 4) == 1
    assert _queue._tail_size(5, 16) == 16 and _queue._tail_size(9, 64) == 16

    monkeypatch.setattr(_queue, "TAIL_PAYBACK", 1e9)  # no compilation ever pays
    assert _tail_sweep().timing["compactions"] == 0
    monkeypatch.setattr(_queue, "TAIL_PAYBACK", 0.0)  # every one does
    scalar = _tail_sweep()
    assert scalar.timing["compactions"] >= 1
    monkeypatch.setattr(_queue, "TAIL_SLOTS", 0)  # the tail stays at MIN_SLOTS
    wide = _tail_sweep()
    assert wide.timing["compactions"] == 0
    for key in OUTPUTS:
        if key != "wall_time_s":
            np.testing.assert_array_equal(np.asarray(wide[key]), np.asarray(scalar[key]), key)


def test_a_warm_run_keeps_the_cold_run_s_tail(tmp_path, monkeypatch):
    """The tail's payback rule compares with what making the first programs cost, also when
    they were loaded from the store: their load time once let a warm run compile programs of
    fewer slots that the cold run had kept from (the same CLI sweep run again with `--parquet`:
    three new programs, 16 s -> 21 s)."""
    from msfd_jax._runtime import export as _export
    from msfd_jax._sweeps import queue as _queue

    _export.enable(tmp_path)  # the autouse fixture switches the store off again
    made = []
    real = _export.compile_program

    def seen(fn, *args, name):
        program = real(fn, *args, name=name)
        made.append((name, program.source, program.make_s))
        return program

    monkeypatch.setattr(_queue._export, "compile_program", seen)
    costs = _tail_rule_costs(monkeypatch)
    cold = _tail_sweep()
    cold_made, made[:], costs[:] = list(made), [], []
    warm = _tail_sweep()
    queue_programs = [m for m in made if m[0].startswith("queue_")]
    assert queue_programs and all(source == "loaded" for _, source, _ in queue_programs)
    # each loaded program knows what the cold run paid to make it, and the rule compares
    # with that, not with the warm run's loading
    cold_cost = {name: make_s for name, source, make_s in cold_made if source == "exported"}
    assert all(make_s == cold_cost[name] for name, _, make_s in queue_programs)
    first = [cold_cost[n] for n in ("queue_segment", "queue_report", "queue_refill")]
    assert costs and all(rule == sum(first) for rule, _ in costs)
    assert all(loading < rule for rule, loading in costs)
    assert warm.timing["compactions"] == cold.timing["compactions"]
    assert warm.timing["slots"] == cold.timing["slots"]
    for key in OUTPUTS:
        if key != "wall_time_s":
            np.testing.assert_array_equal(np.asarray(warm[key]), np.asarray(cold[key]), key)


def test_a_second_sweep_in_a_process_keeps_the_first_one_s_tail(monkeypatch):
    """Made again in one process, a sweep's programs come from jit's own cache in ~0 s (or
    from JAX's persistent cache, for the trace and the load); the payback rule still compares
    with what making them cost (`_queue._MAKE_S`), so a second sweep of the same shape
    compiles no tail program the first one kept from (notebooks/reproduce.py: its Fig. 16
    sweep, the shape of Fig. 10's, compiled three tail sizes, 10 s, for a run of 2.5 s)."""

    costs = _tail_rule_costs(monkeypatch)
    first = _tail_sweep()
    before, costs[:] = [rule for rule, _ in costs], []
    second = _tail_sweep()
    assert before and costs and min(rule for rule, _ in costs) >= max(before) > 0.1
    assert second.timing["compactions"] == first.timing["compactions"]
    # every program of the second from jit's cache (a new tail size compiles for seconds)
    assert second.timing["compile_s"] < 1.0


def test_a_retry_in_the_tail_makes_the_refill_program_it_needs(monkeypatch):
    """Once the queue is empty the tail's smaller programs leave the refill program out (a
    compilation of seconds that only a retry needs); a collision solved again after the tail
    has moved makes it then. Forced here: the first collision reported after a compaction is
    asked to be solved again (as an open energy balance would ask). Its rows equal those of
    the same sweep, the same collision solved again, that never moves its tail."""
    from msfd_jax._collision import attempts as _attempts
    from msfd_jax._sweeps import queue as _queue

    forced, seen, late = {}, {}, []  # forced: {row: the attempt after which it goes again}
    take, needs_retry, compact = (
        _attempts.Attempts.take,
        _attempts.needs_retry,
        _queue._SweepQueue.compact,
    )
    programs_for = _queue._SweepQueue.programs_for

    def take_seen(self, rows, part, attempts):
        seen["rows"], seen["attempts"] = np.asarray(rows), np.asarray(attempts)
        if seen.get("compacted") and not forced:
            forced[int(rows[0])] = int(np.broadcast_to(attempts, np.shape(rows))[0])
        return take(self, rows, part, attempts)

    def retry_forced(result, dt, dt_critical, error, attempt):
        again = [forced.get(int(r)) == int(a) for r, a in zip(seen["rows"], attempt, strict=True)]
        return needs_retry(result, dt, dt_critical, error, attempt) | np.asarray(again)

    def compact_seen(self, slots):
        compact(self, slots)
        seen["compacted"] = seen.get("compacted") or slots.compactions > 0

    def programs_seen(self, size, state, refill=True):
        have = self.programs.get(size)
        if refill and have is not None and have[2] is None:
            late.append(size)
        return programs_for(self, size, state, refill)

    monkeypatch.setattr(_attempts.Attempts, "take", take_seen)
    monkeypatch.setattr(_attempts, "needs_retry", retry_forced)
    monkeypatch.setattr(_queue._SweepQueue, "compact", compact_seen)
    monkeypatch.setattr(_queue._SweepQueue, "programs_for", programs_seen)
    monkeypatch.setattr(_queue, "TAIL_PAYBACK", 0.0)
    moved = _tail_sweep()
    ((row, attempt),) = forced.items()
    assert moved.timing["compactions"] >= 1 and late
    assert int(np.asarray(moved["retries"])[row]) == attempt + 1
    seen.clear()  # the same collision solved again, from the start on (`forced` kept)
    monkeypatch.setattr(_queue, "TAIL_PAYBACK", 1e9)
    kept = _tail_sweep()
    assert kept.timing["compactions"] == 0
    for key in OUTPUTS:
        if key != "wall_time_s":
            np.testing.assert_array_equal(np.asarray(moved[key]), np.asarray(kept[key]), key)


def test_the_default_slots_follow_the_platform(monkeypatch):
    """A sweep not told its slots takes 32 per worker on a CPU and 8192 on a GPU."""
    from msfd_jax._sweeps import queue as _queue

    assert _queue.default_slots() == _queue.DEFAULT_SLOTS == 32
    monkeypatch.setattr(_queue, "platform", lambda: "gpu")
    assert _queue.default_slots() == _queue.GPU_DEFAULT_SLOTS == 8192


def test_the_gpu_tail_rule_gives_the_same_rows(one_worker, monkeypatch):
    """On a GPU the tail moves to fewer slots in steps of four down to `GPU_TAIL_FLOOR`
    (`_queue._tail_size_gpu`); run here through that rule (the platform and the floor
    patched), the rows equal the CPU rule's, every column."""
    from msfd_jax._sweeps import queue as _queue

    floor = _queue.GPU_TAIL_FLOOR
    assert _queue._tail_size_gpu(8192, 8192) == 8192  # all running
    assert _queue._tail_size_gpu(2049, 8192) == 8192  # more than a quarter
    assert _queue._tail_size_gpu(2048, 8192) == 2048 and _queue._tail_size_gpu(600, 8192) == floor
    assert _queue._tail_size_gpu(3, floor) == floor and _queue._tail_size_gpu(0, 8192) == 8192
    monkeypatch.setattr(_queue, "platform", lambda: "gpu")
    monkeypatch.setattr(_queue, "GPU_TAIL_FLOOR", 4)
    monkeypatch.setattr(_queue, "TAIL_PAYBACK", 0.0)
    gpu = sweep(ROWS20, SMALL_MESH, SHORT, chunk_size=CHUNK, contact_smoothing=SMOOTH, workers=1)
    assert gpu.timing["compactions"] == 1  # 16 slots, then 4
    for key in OUTPUTS:
        if key != "wall_time_s":
            np.testing.assert_array_equal(np.asarray(gpu[key]), np.asarray(one_worker[key]), key)


def test_a_retry_runs_in_the_queue_as_it_would_alone(monkeypatch):
    """A row rerun at half the step (issue 12) goes back into the running queue (no pass of
    its own after the sweep) and gives exactly the row of a sweep at that step."""
    from msfd_jax._collision import attempts as _attempts

    lean = dataclasses.replace(SWEEP_SETTINGS, max_steps=2**14)
    rows = [{}, {"thickness_ratio": 1.5}, {"thickness_ratio": 3.0}]
    # on the coarse mesh these close their balance only to ~1e-4-2e-4 K0 at safety 0.7: each
    # is rerun (test_reliability.py), some twice
    table = sweep(rows, SMALL_MESH, lean, workers=1)
    assert all(r >= 1 for r in table["retries"])
    assert table.timing["steps"] > int(np.sum(table["steps"]))  # the first attempts too
    monkeypatch.setattr(_attempts, "BALANCE_RETRIES", 0)
    for safety in sorted(set(np.asarray(table["safety"]).round(12).tolist())):
        these = np.flatnonzero(np.isclose(table["safety"], safety))
        at = dataclasses.replace(lean, safety=float(0.7 * 0.5 ** table["retries"][these[0]]))
        alone = sweep([rows[i] for i in these], SMALL_MESH, at, workers=1)
        assert list(alone["retries"]) == [0] * len(these)
        for key in ("steps", "t_end", "dt", "energy_balance_error", *FRACTION_KEYS):
            np.testing.assert_array_equal(table[key][these], alone[key], err_msg=key)


def test_si_sweep_summary_shows_the_si_inputs():
    """``msfd sweep --si``: the summary names the swept SI inputs with their units."""
    n = 2
    columns = {k: np.full(n, 1.0) for k in INPUTS}
    columns["thickness_ratio"] = np.array([2.0, 3.0])
    columns |= {k: np.full(n, 0.1) for k in FRACTION_KEYS}
    columns |= {"t_end": np.full(n, 4.0), "status": np.array(["settled"] * n)}
    columns |= {"result": np.zeros(n, np.int64), "si_beam_thickness": np.array([0.06, 0.09])}
    columns["si_radius"] = np.full(n, 0.05)  # not swept: not shown
    text = sweep_command.summary(SweepTable(columns, wall_time_s=1.0))
    head = text.splitlines()[0].split()
    assert head[:4] == ["h_b", "[m]", "thickness", "beam_bending"]
    assert "0.09" in text and "R [m]" not in text
