"""SI design quantities (whole structure) against hand calculations on the small test case."""

import contextlib
import io
import json
import math

import numpy as np
import pytest
from conftest import COMPARE_SMOOTHING, SMALL_MESH

import msfd_jax as m
from msfd_jax._si import DISSIPATION_KEYS, motion
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
    hand = 0.5 * (p["block_mass"] + math.pi * p["radius"] * mu_r) * p["velocity"] ** 2
    assert si["k0_J"] == pytest.approx(hand, rel=0.01)
    for key in DISSIPATION_KEYS:
        assert si["dissipated_J"][key] == pytest.approx(f[key] * si["k0_J"], rel=1e-14)
    dissipated = sum(f[k] for k in DISSIPATION_KEYS) * si["k0_J"]
    assert si["dissipated_total_J"] == pytest.approx(dissipated, rel=1e-14)
    total = si["dissipated_total_J"] + si["energy_left_total_J"]
    assert total == pytest.approx(si["k0_J"], abs=0.02 * si["k0_J"])  # energy balance


def test_peaks_against_the_saved_shapes_and_history(collision):
    si, sol, scene = collision.si, collision.solution, collision.scene
    R = collision.scales.length
    beam = scene.chain_index("beam")
    y0 = float(np.asarray(sol.shapes[beam])[0, 0, 1])
    final = abs(float(np.asarray(sol.final.x[beam])[0, 1]) - y0) * R
    assert si["final_beam_deflection_m"] == pytest.approx(final, rel=1e-12)
    # the user's shape time 0.5 is among the saved ones; the peak bounds it and the final one
    ts = np.asarray(sol.shape_ts)
    at = int(np.argmin(np.abs(ts - 0.5)))
    mid = abs(float(np.asarray(sol.shapes[beam])[at, 0, 1]) - y0) * R
    assert si["peak_beam_deflection_m"] >= max(mid, final) > 0
    # the peak is the largest of the sampled shapes inside the run (hand maximum)
    keep = ts <= float(sol.t_end)
    ys = np.asarray(sol.shapes[beam])[keep, 0, 1]
    assert si["peak_beam_deflection_m"] == pytest.approx(np.max(np.abs(ys - y0)) * R, rel=1e-12)
    # force: both halves of the beam, M_pr / R
    force = np.asarray(sol.history["contact_force"]).reshape(len(sol.ts), -1).sum(-1)
    force = force[np.asarray(sol.ts) <= float(sol.t_end)]
    hand = 2 * force.max() * collision.scales.force
    assert si["peak_contact_force_N"] == pytest.approx(hand, rel=1e-12)
    assert si["duration_s"] == pytest.approx(float(sol.t_end) * collision.scales.time)
    # deceleration: the block starts at V0 and slows; its peak exceeds the mean deceleration
    moved = motion(collision)
    assert moved["t"][0] == 0.0 and np.all(np.diff(moved["t"]) > 0)
    v0 = m.PAPER_SI["velocity"]
    assert si["peak_block_deceleration_m_s2"] > 0.5 * v0 / si["duration_s"]
    assert si["peak_block_deceleration_g"] == pytest.approx(
        si["peak_block_deceleration_m_s2"] / 9.80665
    )


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
    assert record["si_inputs"]["velocity"] == 30.0
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", *SMALL, "--si"]) == 0
    text = out.getvalue()
    assert "kJ" in text and "kN" in text and "mm" in text and "m/s^2" in text


def test_si_figures_and_axes_arguments(collision, tmp_path):
    from matplotlib.figure import Figure

    from msfd_jax._plot import plot_collision, plot_energies, plot_partition, plot_shapes
    from msfd_jax._sweep import SweepTable

    fig = plot_collision(collision, tmp_path / "si.png")
    labels = {ax.get_xlabel() for ax in fig.axes} | {ax.get_ylabel() for ax in fig.axes}
    assert "t [ms]" in labels and "energy [kJ] (whole structure)" in labels and "y [m]" in labels
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
        assert params.velocity == si["velocity"] * t / si["radius"]
        assert (scales.moment, scales.time, scales.force) == (m_pr, t, m_pr / si["radius"])
