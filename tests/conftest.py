"""Test set-up: float64, no silent rank promotion, and compiled programs shared across tests."""

import os
import shutil
import subprocess
import sys
import tempfile

# XLA:CPU's fusion emitters take about half of each program's compile time in this suite,
# which compiles several hundred collision programs (the same program: 6.7 s -> 2.5 s to
# compile on this machine, the warm run unchanged, the regression record's partitions equal
# to 7e-18 K0; docs/performance.md, "Compile time"). The suite turns them off for itself and
# for every process it starts (docs blocks, notebooks' kernels, the CLI), through XLA_FLAGS,
# read when a process starts its backend. An XLA that does not know the flag aborts the
# process, so the controller asks a child interpreter first and sets it only if accepted;
# workers inherit the environment. MSFD_TEST_FUSION_EMITTERS=1 keeps XLA's default.
FAST_COMPILE_FLAG = "--xla_cpu_use_fusion_emitters=false"
_FLAG_CHECKED = "MSFD_TEST_XLA_FLAGS_CHECKED"


def _with_fast_compile() -> None:
    if os.environ.get(_FLAG_CHECKED) or os.environ.get("MSFD_TEST_FUSION_EMITTERS") == "1":
        return
    os.environ[_FLAG_CHECKED] = "1"
    flags = f"{os.environ.get('XLA_FLAGS', '')} {FAST_COMPILE_FLAG}".strip()
    probe = "import jax; jax.numpy.zeros(1).block_until_ready()"
    env = {**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu"}
    accepted = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True)
    if accepted.returncode == 0:
        os.environ["XLA_FLAGS"] = flags


_with_fast_compile()

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import hypothesis  # noqa: E402
import pytest  # noqa: E402

import msfd_jax as m  # noqa: E402

# The property tests (tests/test_properties*.py) draw new examples on every local run, where a
# failure is a finding; CI (CI=true) replays a fixed sequence of examples instead, so that a
# submission lands or fails on its own code, not on the draw (a local run found an SI radius
# whose R^3 overflowed float64, stop 19). `--hypothesis-profile default` overrides.
hypothesis.settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    hypothesis.settings.load_profile("ci")

# One persistent compile cache for the whole session, shared by pytest-xdist's workers and by
# every interpreter a test starts (docs blocks, notebooks' kernels, the CLI in a subprocess: JAX
# reads the environment variables below at import). A program traced again in another process,
# or after the memory-map guard below dropped it, is then loaded instead of compiled: the
# collision programs are cacheable since diffrax's input checks are traced as NaN, not host
# callbacks (`_runtime.export.checks_as_nan`). The controller makes the directory and removes it
# at the end; set MSFD_TEST_COMPILE_CACHE to keep a warm one between runs.
TEST_CACHE_ENV = "MSFD_TEST_COMPILE_CACHE"
CACHE_MIN_COMPILE_S = 0.5  # smaller programs compile about as fast as they load
_made_cache: list[str] = []


def pytest_configure(config):
    path = os.environ.get(TEST_CACHE_ENV)
    if path is None:  # the controller (or a run without workers): workers inherit the variable
        path = tempfile.mkdtemp(prefix="msfd-test-compile-cache-")
        os.environ[TEST_CACHE_ENV] = path
        _made_cache.append(path)
    os.environ["JAX_COMPILATION_CACHE_DIR"] = path
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = str(CACHE_MIN_COMPILE_S)
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", CACHE_MIN_COMPILE_S)


def pytest_unconfigure(config):
    for path in _made_cache:
        shutil.rmtree(path, ignore_errors=True)


# One small mesh for every test that does not need the paper's: compiled once, reused.
SMALL_MESH = m.Mesh(ring_segments=6, beam_contact_segments=8, beam_outer_segments=2)
SHORT = m.Settings(t_max=1.5, history_points=31, shape_times=(0.5,))
# Tests comparing batched with single runs on SMALL_MESH smooth the contact (width in R): the
# sharp contact, stiff since issue 9, chatters there and amplifies the rounding differences
# of a vmapped program exponentially (7e-4 K0 by tau = 0.6); smoothed, they agree to ~1e-13
# (`python -m msfd_jax.studies.scripts.numerics_checks`, "Rounding amplification").
COMPARE_SMOOTHING = 1e-3


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the marks (its loadgroup suffix)
def pytest_collection_modifyitems(config, items):
    """pytest-xdist (`--dist loadgroup`) hands out tests one by one, so a module's tests land
    on both workers and each worker builds the module's fixtures again: a module-scoped
    fixture (a design, a LocalCluster with its own compile cache, a batch of runs) was made
    twice. A test that uses a module-scoped fixture runs in its module's group, so each such
    fixture is made once; the other tests still spread over the workers. A test that names
    its own group (a doc's blocks, tests/test_docs.py) keeps it."""
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        info = getattr(item, "_fixtureinfo", None)
        definitions = getattr(info, "name2fixturedefs", {}) or {}
        if any(defs and defs[-1].scope == "module" for defs in definitions.values()):
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))


@pytest.fixture(autouse=True)
def _no_export_store_leaks():
    """A test that runs the CLI in-process switches the export store on (as the CLI does);
    later tests must see the library's default (off) again."""
    from msfd_jax._runtime import export as _export

    before = _export.store()
    yield
    _export.enable(before)


_CACHE_OPTIONS = (
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


@pytest.fixture(autouse=True)
def _no_compilation_cache_leaks():
    """A test that runs the CLI in-process without ``--no-cache`` (the cluster and SI sweeps)
    points JAX's persistent compilation cache at its own directory for the whole process, as
    the CLI does. Later tests see the suite's cache again, so they do not write every program
    they compile into a test's temporary directory."""
    from jax.experimental.compilation_cache import compilation_cache

    before = {name: getattr(jax.config, name) for name in _CACHE_OPTIONS}
    yield
    after = {name: getattr(jax.config, name) for name in _CACHE_OPTIONS}
    if after != before:
        for name, value in before.items():
            jax.config.update(name, value)
        compilation_cache.reset_cache()  # the cache object keeps the directory it opened


# The suite shares compiled programs across files, but XLA:CPU holds ~1300 memory mappings per
# collision program, and past vm.max_map_count (65 530) the next compilation segfaults (CI of
# stop 19, in tests/test_sweep.py at 65 304 mappings; msfd_jax/_runtime/mappings.py). Below the
# library's own guard (0.75 of the limit, which would warn, an error here) the suite drops
# its compiled programs after a test once half the limit is used; later tests recompile.
SUITE_RELEASE_AT = 0.5


@pytest.fixture(autouse=True)
def _stay_under_the_memory_map_limit():
    yield
    from msfd_jax._runtime import mappings as _mappings

    _mappings.release(SUITE_RELEASE_AT)


@pytest.fixture(scope="session")
def small_mesh():
    return SMALL_MESH


@pytest.fixture(scope="session")
def showcase():
    """The paper's showcase (Fig. 13) on the paper's mesh, run once for the whole session."""
    return m.run()
