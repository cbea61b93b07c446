"""SI design quantities (whole structure) against hand calculations on the small test case."""

import contextlib
import io
import json
import math

import numpy as np
import pytest
from conftest import COMPARE_SMOOTHING, SMALL_MESH

import msfd_jax as m
from msfd_jax._model.si import DISSIPATION_KEYS
from msfd_jax.cli import main

SETTINGS = m.Settings(t_max=1.5, history_points=61, shape_times=(0.5,))
SMALL = [
    "--ring-segments=6",
    "--beam-contact-segments=8",
    "--beam-outer-segments=2",
    "--t-max=1.5",
    "--history-points=61",
    "--shape-times=0.5",
    "--no-cache",
]


@pytest.fixture(scope="module")
def collision():
    return m.run_si(SMALL_MESH, SETTINGS)


def test_energies_are_twice_the_half_model_in_joules(collision):
    si, f = collision.si, collision.fractions
    scales = collision.scales
    k0 = 2 * float(collision.solution.k0) * scales.moment
    assert si["k0_J"] == pytest.approx(k0, rel=1e-14)
    # by hand from the SI inputs: (2G + pi R mu_r) V0^2 / 2, the ring's polygon slightly light
    p = m.PAPER_SI
    mu_r = p["density"] * p["width"] * p["ring_thickness"]
    hand = 0.5 * (p["block_mass"] + math.pi * p["radius"] * mu_r) * p["impact_speed"] ** 2
    assert si["k0_J"] == pytest.approx(hand, rel=0.01)
    for key in DISSIPATION_KEYS:
        assert si["dissipated_J"][key] == pytest.approx(f[key] * si["k0_J"], rel=1e-14)
    dissipated = sum(f[k] for k in DISSIPATION_KEYS) * si["k0_J"]
    assert si["dissipated_total_J"] == pytest.approx(dissipated, rel=1e-14)
    total = si["dissipated_total_J"] + si["energy_left_total_J"]
    assert total == pytest.approx(si["k0_J"], abs=0.02 * si["k0_J"])  # energy balance


def test_peaks_bound_the_saved_shapes_and_history(collision):
    """The engine's per-step peaks against what the saved samples show by hand: never below
    any sample's value, and close to the densest of them."""
    si, sol, scene = collision.si, collision.solution, collision.scene
    R, F = collision.scales.length, collision.scales.force
    beam = scene.chain_index("beam")
    y0 = float(np.asarray(sol.shapes[beam])[0, 0, 1])
    final = abs(float(np.asarray(sol.final.x[beam])[0, 1]) - y0) * R
    assert si["final_beam_deflection_m"] == pytest.approx(final, rel=1e-12)
    ts = np.asarray(sol.ts)
    inside = ts <= float(sol.t_end)
    deflection = np.abs(np.asarray(sol.history["midspan_deflection"])[inside]) * R
    assert si["peak_beam_deflection_m"] >= deflection.max() * (1 - 1e-12)
    assert si["peak_beam_deflection_m"] == pytest.approx(deflection.max(), rel=0.02)
    assert si["peak_beam_deflection_m"] >= final > 0
    # force: both halves of the beam, M_pr / R; a step's spike may lie between two samples
    force = np.asarray(sol.history["contact_force"]).reshape(len(ts), -1)[:, 0][inside]
    assert si["peak_contact_force_N"] >= 2 * force.max() * F * (1 - 1e-12)
    assert 0 < si["mean_contact_force_N"] <= si["peak_contact_force_N"]
    assert si["duration_s"] == pytest.approx(float(sol.t_end) * collision.scales.time)
    # deceleration: the block starts at V0 and slows; its peak exceeds the mean deceleration
    v0 = m.PAPER_SI["impact_speed"]
    assert si["peak_block_deceleration_m_s2"] > 0.5 * v0 / si["duration_s"]
    assert si["peak_block_deceleration_m_s2"] >= si["peak_block_deceleration_10ms_m_s2"] > 0
    assert si["peak_block_deceleration_g"] == pytest.approx(
        si["peak_block_deceleration_m_s2"] / 9.80665
    )
    # the car's side: the block travels at least as far as the ring is crushed plus the beam
    # deflects (the ring's front node S stays on the beam while they touch)
    assert si["peak_block_travel_m"] > si["peak_ring_crush_m"] > 0
    assert si["peak_block_travel_m"] >= si["final_block_travel_m"] > 0


def test_impulse_against_the_momentum_and_contact_time_against_the_samples(collision):
    """Two independent checks of the mean force's parts.

    - Impulse: the contact is the only force on the ring and block in the impact direction
      (the symmetry plane and the block's guide act across it), so the engine's impulse (the
      sum of |force| x h) equals the change of their momentum, 2 x sum m (v_y - v0_y), up to
      the contact force's slant (a few per mille).
    - Contact time: a history saved at (about) every step, counted by hand over the samples
      that end closed. Samples are diffrax's linear interpolation of the state between steps,
      so the sums differ slightly: 3.4 % here (measured), hence 5 %; the former fault halved
      the time. (The sampled force itself is no check of the impulse: a stiff contact's
      penetration is of the order of the interpolation's error, and the sampled integral came
      out 28 % low here, which is why the engine keeps the sums.)
    """
    sol, scene, sc = collision.solution, collision.scene, collision.scales
    ring = scene.chains[scene.chain_index("ring")]
    v0 = np.asarray(scene.initial_velocity[scene.chain_index("ring")])[:, 1]
    v1 = np.asarray(sol.final.v[scene.chain_index("ring")])[:, 1]
    momentum = 2 * abs(float(np.sum(np.asarray(ring.mass) * (v1 - v0))))
    momentum_si = momentum * sc.force * sc.time
    si = collision.si
    impulse_si = si["mean_contact_force_N"] * si["contact_duration_s"]
    assert impulse_si >= momentum_si * (1 - 1e-9)
    assert impulse_si == pytest.approx(momentum_si, rel=0.01)
    steps = int(sol.steps)
    dense = m.run_si(SMALL_MESH, m.Settings(t_max=1.5, history_points=steps + 1))
    assert int(dense.solution.steps) == steps  # the same run, more samples
    ts = np.asarray(dense.solution.ts)
    inside = ts <= float(dense.solution.t_end) + 1e-12
    force = np.asarray(dense.solution.history["contact_force"]).reshape(len(ts), -1)[:, 0]
    duration = np.sum(np.diff(ts[inside]) * (force[inside][1:] > 0)) * sc.time
    assert dense.si["contact_duration_s"] == pytest.approx(duration, rel=0.05)
    assert dense.si["peak_contact_force_N"] >= 2 * force.max() * sc.force * (1 - 1e-12)


def test_peaks_do_not_depend_on_the_history_samples():
    """Peaks are kept at every step: 61 or 241 saved samples give the same numbers (the
    former sampled peaks moved by 14 % between two t_max's sample grids)."""
    a = m.run_si(SMALL_MESH, SETTINGS).si
    b = m.run_si(SMALL_MESH, m.Settings(t_max=1.5, history_points=241)).si
    for key in (
        "peak_beam_deflection_m",
        "peak_contact_force_N",
        "mean_contact_force_N",
        "peak_block_deceleration_m_s2",
        "peak_ring_crush_m",
        "peak_block_travel_m",
    ):
        assert a[key] == pytest.approx(b[key], rel=1e-12), key


def _finite_si(si):
    for key, value in si.items():
        if isinstance(value, dict):
            _finite_si(value)
        elif not isinstance(value, bool):
            assert math.isfinite(value), key


@pytest.mark.parametrize(
    "inputs",
    [
        {},  # the paper's SI case: aluminium, 30 m/s, g = 10
        {"impact_speed": 20.0, "block_mass": 200.0},  # the README's line
        # steel ring and beam, a 1.5 t car at 100 km/h
        {
            "impact_speed": 27.8,
            "block_mass": 1500.0,
            "youngs_modulus": 210e9,
            "yield_stress": 355e6,
            "density": 7850.0,
        },
    ],
    ids=["paper", "readme", "steel"],
)
def test_si_quantities_at_the_derived_cap(inputs):
    """t_max=None (the derived cap) on a coarse mesh: every quantity finite, mean force below
    the peak (the former boolean trapezoid halved the contact time: mean > peak for steel)."""
    si = m.run_si(SMALL_MESH, **inputs).si
    _finite_si(si)
    assert 0 < si["mean_contact_force_N"] <= si["peak_contact_force_N"]
    assert si["peak_beam_deflection_m"] >= si["final_beam_deflection_m"] > 0


@pytest.mark.slow
def test_paper_si_case_on_the_paper_mesh():
    """The paper's SI case on its own mesh at t_max=None: peak mid-span deflection 140.5 mm
    (the half-span is 1.5 m; the paper's Fig. 13 shows ~0.28 R = 0.14 m), mean force < peak."""
    si = m.run_si().si
    _finite_si(si)
    assert si["peak_beam_deflection_m"] == pytest.approx(0.1405, abs=0.005)
    assert 0 < si["mean_contact_force_N"] < si["peak_contact_force_N"]


def test_the_former_si_velocity_name_is_accepted_with_a_warning():
    with pytest.warns(DeprecationWarning, match="impact_speed"):
        params, _ = m.from_si(**{**_without("impact_speed"), "velocity": 30.0})
    assert params == m.from_si(**m.PAPER_SI)[0]
    with pytest.raises(TypeError, match="impact_speed"):
        m.from_si(**{**m.PAPER_SI, "velocity": 30.0})


def _without(key):
    return {k: v for k, v in m.PAPER_SI.items() if k != key}


def test_fractions_do_not_depend_on_the_saved_motion(collision):
    plain = m.run(collision.params, SMALL_MESH, SETTINGS)
    for key, value in plain.fractions.items():
        assert collision.fractions[key] == pytest.approx(value, abs=1e-12)


def test_cli_si_json_and_table():
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", *SMALL, "--si", "--json"]) == 0
    record = json.loads(out.getvalue())
    si = record["si"]
    for key in (
        "k0_J",
        "dissipated_J",
        "peak_beam_deflection_m",
        "peak_contact_force_N",
        "peak_block_deceleration_m_s2",
        "duration_s",
        "energy_left_J",
        "scales",
    ):
        assert key in si
    assert set(si["dissipated_J"]) == set(DISSIPATION_KEYS)
    assert record["si_inputs"]["impact_speed"] == 30.0
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", *SMALL, "--si"]) == 0
    text = out.getvalue()
    assert "kJ" in text and "kN" in text and "mm" in text and "m/s^2" in text


def test_si_figures_and_axes_arguments(collision, tmp_path):
    from matplotlib.figure import Figure

    from msfd_jax._plot import plot_collision, plot_energies, plot_partition, plot_shapes
    from msfd_jax._sweeps.sweep import SweepTable

    fig = plot_collision(collision, tmp_path / "si.png")
    labels = {ax.get_xlabel() for ax in fig.axes} | {ax.get_ylabel() for ax in fig.axes}
    assert "t [ms]" in labels and "energy [kJ] (whole structure)" in labels and "y [m]" in labels
    assert r"$\tau$" not in labels  # panel (d)'s colour scale too is in ms
    assert (tmp_path / "si.png").stat().st_size > 0
    plain = plot_collision(collision, si=False)
    assert r"$E / K_0$" in {ax.get_ylabel() for ax in plain.axes}
    # ax= draws on the caller's axes; a sweep table gives one bar per row
    host = Figure()
    left, right = host.subplots(1, 2)
    assert plot_energies(collision, left) is host and plot_shapes(collision, right) is host
    table = SweepTable(
        {
            **{k: np.array([v, v]) for k, v in collision.fractions.items()},
            "thickness_ratio": np.array([1.5, 2.5]),
            "velocity": np.array([0.8, 0.8]),
        }
    )
    # msfd sweep --plot: stacked shares against the one swept input, a failed row marked
    from msfd_jax._plot import plot_sweep

    swept = SweepTable(
        {
            **{k: np.array([v, v, v]) for k, v in collision.fractions.items()},
            "thickness_ratio": np.array([1.0, 2.5, 4.0]),
            "axial_constraint": np.ones(3),
            "result": np.array([1, 1, 3]),
            "status": np.array(["settled", "settled", "energy balance broken"]),
        }
    )
    fig = plot_sweep(swept, tmp_path / "sweep.png")
    assert fig.axes[0].get_xlabel() == "thickness_ratio" and (tmp_path / "sweep.png").exists()
    assert "failed run (not data)" in [t.get_text() for t in fig.axes[0].get_legend().texts]
    bars = Figure().subplots()
    plot_partition(table, ax=bars)
    assert [t.get_text() for t in bars.get_yticklabels()] == [
        "thickness_ratio = 1.5",
        "thickness_ratio = 2.5",
    ]


def test_si_sweep_rows_equal_si_runs(tmp_path, capsys):
    """A whole SI sweep (two beam thicknesses in metres): each row's SI columns equal run_si.

    Smoothed contact, as every batched-against-single comparison (conftest: the sharp contact
    of these thin beams amplifies the batch's rounding differences to ~1e-4 K0)."""
    out = tmp_path / "si.csv"
    argv = [
        "sweep", "--si", "--beam-thickness", "0.004,0.006", *SMALL[:4], "-q", "--no-cache",
        "--csv", str(out), f"--contact-smoothing={COMPARE_SMOOTHING}",
    ]  # fmt: skip
    assert main(argv) == 0
    table = m.SweepTable.read_csv(out)
    assert len(table) == 2
    for i, h in enumerate((0.004, 0.006)):
        single = m.run_si(
            SMALL_MESH, m.Settings(t_max=1.5), beam_thickness=h, contact_smoothing=COMPARE_SMOOTHING
        )
        si = single.si
        assert table["si_beam_thickness"][i] == h
        assert table["k0_J"][i] == pytest.approx(si["k0_J"], rel=1e-12)
        assert table["duration_s"][i] == pytest.approx(si["duration_s"], rel=1e-9)
        assert table["beam_bending_J"][i] == pytest.approx(
            si["dissipated_J"]["beam_bending"], rel=1e-6, abs=1e-9 * si["k0_J"]
        )
        for key in (
            "peak_beam_deflection_m",
            "peak_ring_crush_m",
            "mean_contact_force_N",
            "peak_block_deceleration_m_s2",
        ):
            # a per-step maximum of the contact's spike carries the batch's rounding: 1.3e-6
            # measured on the deceleration, hence 1e-5 (the energies above keep 1e-6)
            assert table[key][i] == pytest.approx(si[key], rel=1e-5), key


def test_python_sweep_takes_si_inputs_and_gives_si_columns():
    """`sweep` with SI keys: a grid over the impact speed (block mass fixed), each row's SI
    columns equal to `run_si`'s (smoothed contact, as above); the grid is the SI axes; mixing
    SI inputs and groups is refused; NetCDF variables carry their units."""
    settings = m.Settings(t_max=1.5, history_points=2, shape_times=())
    table = m.sweep(
        {"impact_speed": [20.0, 30.0], "block_mass": [200.0]}, SMALL_MESH, settings,
        contact_smoothing=COMPARE_SMOOTHING,
    )  # fmt: skip
    assert list(table.grid) == ["si_impact_speed", "si_block_mass"]
    for i, v in enumerate((20.0, 30.0)):
        si = m.run_si(
            SMALL_MESH, m.Settings(t_max=1.5), impact_speed=v, block_mass=200.0,
            contact_smoothing=COMPARE_SMOOTHING,
        ).si  # fmt: skip
        assert table["si_impact_speed"][i] == v
        for key in (
            "k0_J",
            "peak_beam_deflection_m",
            "peak_contact_force_N",
            "mean_contact_force_N",
            "contact_duration_s",
            "duration_s",
        ):
            assert table[key][i] == pytest.approx(si[key], rel=1e-5), key
        assert 0 < table["mean_contact_force_N"][i] <= table["peak_contact_force_N"][i]
    with pytest.raises(ValueError, match="cannot be combined with SI inputs"):
        m.sweep({"impact_speed": [20.0], "thickness_ratio": [2.0]}, SMALL_MESH, settings)
    from msfd_jax._model.si import units_of

    assert units_of("peak_beam_deflection_m") == "m" and units_of("si_impact_speed") == "m/s"
    assert units_of("peak_block_deceleration_m_s2") == "m/s^2" and units_of("k0") is None


@pytest.mark.parametrize(
    "change, match",
    [
        ({"radius": 5.7e102}, "slenderness"),  # R^3 overflowed float64 (hypothesis found it)
        ({"ring_thickness": 1e200}, "slenderness"),  # h_r^2 overflowed
        ({"density": 1e-300, "width": 1e-300}, "mass_ratio .* must be finite"),
    ],
)
def test_extreme_si_inputs_are_refused_naming_a_group(change, match):
    """Finite SI values whose scales overflow or underflow float64 are refused with the
    group they break (the CLI adds the SI options it is made of), never an OverflowError."""
    with pytest.raises(ValueError, match=match):
        m.from_si(**{**m.PAPER_SI, **change})
    params, scales = m.from_si(**m.PAPER_SI)  # the paper's case is unchanged
    assert math.isfinite(scales.time) and params.slenderness == pytest.approx(10.0)


def test_from_si_keeps_the_former_python_float_arithmetic():
    """from_si moved to float64 numpy (overflow refused, not raised): its groups and scales
    are those of the former Python-float formulas bit for bit, on random SI inputs."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        si = {k: v * float(np.exp(rng.uniform(-0.5, 0.5))) for k, v in m.PAPER_SI.items()}
        params, scales = m.from_si(**si)
        mu_r = si["density"] * si["width"] * si["ring_thickness"]
        m_pr = si["yield_stress"] * si["width"] * si["ring_thickness"] ** 2 / 4.0
        t = math.sqrt(mu_r * si["radius"] ** 3 / m_pr)
        assert params.slenderness == si["radius"] / si["ring_thickness"]
        assert params.mass_ratio == 0.5 * si["block_mass"] / (mu_r * si["radius"])
        assert params.velocity == si["impact_speed"] * t / si["radius"]
        assert (scales.moment, scales.time, scales.force) == (m_pr, t, m_pr / si["radius"])
