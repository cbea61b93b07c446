"""Property-based input tests of the Python API (issue 12 item 6; the CLI's are in
test_properties_cli.py).

Random values *and* random types (None, bools, ints, huge ints, floats with nan/inf/huge/tiny/
negative/zero, strings, complex, lists, numpy scalars and arrays of several shapes) for every
field of `CollisionParams`, `Mesh` and `Settings`. The property: the input is either accepted,
and then a run ends with a known status and, when it reports success, finite numbers; or it is
refused with a ValueError/TypeError whose message names the parameter and, for a range, states
the allowed range. Never another exception type, a NaN in a success, or a hang.

Runs share one compiled program: conftest's SMALL_MESH, a short t_max and a small static step
bound (`RUN`); only dynamic numbers vary. Meshes and static settings are checked without a run
(each would compile anew). Example counts are bounded (`hypothesis.settings` below).
"""

import dataclasses
import math
import warnings

import hypothesis.extra.numpy as hnp
import numpy as np
import pytest
from conftest import SMALL_MESH
from hypothesis import HealthCheck, event, given
from hypothesis import settings as hsettings
from hypothesis import strategies as st

import msfd_jax as m
from msfd_jax._batched.results import FAILED, RESULTS
from msfd_jax._model.params import _RANGES

# One compiled program for every run here: static fields fixed, numbers dynamic.
RUN = m.Settings(t_max=0.1, history_points=11, shape_times=(), max_steps=256)
SUCCESS = {r.status for r in RESULTS if r not in FAILED}
FAST = hsettings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
RUNS = hsettings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])

SPECIAL = [math.nan, math.inf, -math.inf, 0.0, -0.0, 1e308, -1e308, 5e-324, 1e-300, -1.0]
JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-1000, 1000),
    st.integers(min_value=2**63) | st.integers(max_value=-(2**63)),
    st.just(10**5000),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(SPECIAL),
    st.text(max_size=4),
    st.complex_numbers(max_magnitude=10),
    st.lists(st.floats(-10, 1e3), max_size=3),
    st.lists(st.text(max_size=2), min_size=1, max_size=2),
    hnp.arrays(
        np.float64,
        hnp.array_shapes(min_dims=0, max_dims=2, min_side=0, max_side=2),
        elements=st.floats(-10, 1e3),
    ),
    st.builds(np.float32, st.floats(-10, 1e3, width=32)),
    st.builds(np.int64, st.integers(-5, 50)),
    st.just(np.bool_(True)),
    st.just(object()),
    st.dictionaries(st.text(max_size=2), st.integers(), max_size=1),
)


def in_range(low: float, high: float) -> st.SearchStrategy:
    """Floats between low and high, log-uniform where both are positive, ends included."""
    if low > 0:
        return st.floats(math.log(low), math.log(high)).map(math.exp)
    return st.floats(low, high)


# Values a designer would try: the field's allowed range (runs mostly succeed there).
PLAUSIBLE = {
    "thickness_ratio": in_range(0.2, 8.0),
    "modulus_ratio": in_range(100.0, 2000.0),
    "slenderness": in_range(5.0, 40.0),
    "mass_ratio": in_range(0.5, 200.0),
    "velocity": in_range(0.05, 3.0),
    "span_ratio": in_range(2.5, 10.0),
    "width_ratio": in_range(0.2, 5.0),
    "axial_constraint": st.sampled_from([0.0, 1.0, True, False, 0, 1]),
}
# The allowed range's ends and beyond (the extremes must run or fail with a status too).
EDGES = {
    name: st.sampled_from([low, high, low * 0.5, high * 2, -high, math.nextafter(low, math.inf)])
    for name, (low, high, _, _) in _RANGES.items()
}
EDGES["span_ratio"] = st.sampled_from([2.0, 2.0001, 1e4, 1e4 * 1.01, 0.0, -3.0])


def params_values() -> st.SearchStrategy:
    fields = list(m.CollisionParams().scalars())  # the profile: tests/test_graded*.py
    return st.fixed_dictionaries(
        {},
        optional={f: st.one_of(PLAUSIBLE[f], PLAUSIBLE[f], EDGES[f], JUNK) for f in fields},
    )


def check_refusal(error: Exception, names) -> None:
    """A refusal: ValueError/TypeError naming one of `names`, with the range for a range."""
    assert isinstance(error, ValueError | TypeError), repr(error)
    text = str(error)
    assert "\n" not in text.strip(), text
    assert any(n in text for n in names), f"{text!r} names none of {sorted(names)}"
    if "out of range" in text or "must be finite" in text:
        assert "allowed" in text, text


def check_collision(collision: m.Collision, settings: m.Settings = RUN) -> None:
    """A run that ended: a known status, and finite numbers where it reports success."""
    status = collision.status
    event(f"ran: {status}")
    assert status in {r.status for r in RESULTS}, status
    assert collision.message, "a run must say how it ended"
    if status in SUCCESS:
        numbers = [*collision.fractions.values(), collision.energy_balance_error]
        numbers += [float(collision.solution.t_end), float(collision.solution.k0)]
        assert all(math.isfinite(x) for x in numbers), (status, numbers)
        assert abs(collision.energy_balance_error) <= float(settings.energy_guard), status


def attempt(build, names):
    """`build()` or None after checking that its refusal is a clean one."""
    try:
        with warnings.catch_warnings():
            # equinox warns when a numpy scalar goes into a static field (Mesh counts); the
            # value is then checked (np.int64 accepted, np.float32 refused) like any other
            warnings.filterwarnings("ignore", "A JAX array is being set as static")
            return build()
    except Exception as error:  # noqa: BLE001 (the property is about which exception)
        check_refusal(error, names)
        event(f"refused: {type(error).__name__}")
        return None


@FAST
@given(values=params_values())
def test_collision_params_are_accepted_or_refused_naming_the_field(values):
    p = attempt(lambda: m.CollisionParams(**values), set(values))
    if p is None:
        return
    for name, value in values.items():  # what was accepted is a real number (or array)
        kind = np.asarray(getattr(p, name)).dtype.kind
        assert kind in "biuf", (name, value)


@RUNS
@given(values=params_values())
def test_collision_params_run_or_are_refused(values):
    collision = attempt(
        lambda: m.run(m.CollisionParams(**values), SMALL_MESH, RUN, check=False), set(values)
    )
    if collision is not None:
        check_collision(collision)


COUNTS = st.one_of(st.integers(-5, 60), st.integers(min_value=10**5), JUNK)


@FAST
@given(
    values=st.fixed_dictionaries(
        {},
        optional={
            "ring_segments": COUNTS,
            "beam_contact_segments": COUNTS,
            "beam_outer_segments": COUNTS,
            "contact_region": st.one_of(in_range(0.1, 20.0), JUNK),
        },
    )
)
def test_mesh_is_accepted_or_refused_naming_the_field(values):
    """No run (a new mesh compiles anew): an accepted mesh must be usable as a static key."""
    mesh = attempt(lambda: m.Mesh(**values), set(values))
    if mesh is None:
        return
    hash(mesh)  # a static field of the compiled program: must be hashable
    for name in ("ring_segments", "beam_contact_segments", "beam_outer_segments"):
        count = getattr(mesh, name)
        assert isinstance(count, int | np.integer) and not isinstance(count, bool | np.bool_)
        assert count <= 10_000, (name, count)  # more compiles and runs for ever
    assert np.ndim(mesh.contact_region) == 0 and math.isfinite(float(mesh.contact_region))
    long_beam = m.CollisionParams(span_ratio=1e4)
    m.validate(long_beam, mesh)


SETTINGS_NUMBERS = ("safety", "t_max", "t_min", "settle_window", "settle_tolerance")
SETTINGS_NUMBERS += ("settle_residual", "energy_guard")
SETTINGS_STATIC = {
    "dt": st.one_of(st.none(), in_range(1e-6, 1e3), JUNK),
    "stop_when_settled": st.one_of(st.booleans(), JUNK),
    "history_points": COUNTS,
    "shape_times": st.one_of(
        st.tuples(), st.tuples(st.floats(0, 2)), st.tuples(JUNK), st.tuples(JUNK, JUNK), JUNK
    ),
    "max_steps": st.one_of(st.none(), COUNTS),
    "substeps": COUNTS,
    "contact_loop": st.one_of(
        st.none(), st.sampled_from(["blocks", "listed", "dense", "pruned"]), JUNK
    ),
}


@FAST
@given(
    values=st.fixed_dictionaries(
        {},
        optional={
            **{k: st.one_of(in_range(1e-3, 5.0), JUNK) for k in SETTINGS_NUMBERS},
            **SETTINGS_STATIC,
        },
    )
)
def test_settings_are_accepted_or_refused_naming_the_field(values):
    s = attempt(lambda: m.Settings(**values), set(values))
    if s is None:
        return
    # static fields key the compiled program: hashable; numbers single and finite
    static = ("stop_when_settled", "history_points", "shape_times", "contact_loop")
    hash(tuple(getattr(s, f) for f in static))
    numbers = [(name, getattr(s, name)) for name in (*SETTINGS_NUMBERS, "dt")]
    numbers += [("shape_times", t) for t in s.shape_times]
    for name, value in numbers:
        if value is not None:
            assert np.ndim(value) == 0 and math.isfinite(float(value)), (name, value)
    for name in ("history_points", "substeps", "max_steps"):
        count = getattr(s, name)
        assert count is None or (isinstance(count, int | np.integer) and count <= 2**40), name


@RUNS
@given(
    values=st.fixed_dictionaries(
        {},
        optional={
            "safety": st.one_of(in_range(0.05, 1.0), in_range(1.0, 10.0), JUNK),
            "t_max": st.one_of(in_range(1e-3, 0.5), in_range(0.5, 1e4), JUNK),
            "t_min": st.one_of(in_range(1e-3, 1.0), JUNK),
            "settle_window": st.one_of(in_range(1e-3, 1.0), JUNK),
            "settle_tolerance": st.one_of(in_range(1e-9, 1.0), JUNK),
            "settle_residual": st.one_of(in_range(1e-9, 1.0), JUNK),
            "energy_guard": st.one_of(in_range(1e-6, 1e3), JUNK),
        },
    ),
    velocity=PLAUSIBLE["velocity"],
)
def test_settings_numbers_run_or_are_refused(values, velocity):
    """The dynamic numbers of Settings through a run (same compiled program throughout)."""
    settings = attempt(lambda: dataclasses.replace(RUN, **values), set(values))
    if settings is None:
        return
    params = m.CollisionParams(velocity=velocity)
    collision = attempt(lambda: m.run(params, SMALL_MESH, settings, check=False), set(values))
    if collision is not None:
        check_collision(collision, settings)


@pytest.mark.parametrize("value", [np.array([0.5, 0.7]), [0.7], (0.7,), np.ones((1, 1))])
def test_settings_numbers_are_single_values(value):
    # found by the properties above: arrays were accepted and failed inside the solve
    with pytest.raises(ValueError, match="safety must be a single value"):
        m.Settings(safety=value)
