"""Physics of the simulator against independent formulas and ground truth."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import butter, hilbert, sosfiltfilt

from liquidtouch._core.containers import get_container
from liquidtouch._core.liquids import get_liquid, sugar_mass_fraction
from liquidtouch.errors import CatalogueError, LiquidTouchError
from liquidtouch.sim.slosh import integrate, slosh_system
from liquidtouch.sim.trial import simulate_trial

G = 9.81


# --- liquids -------------------------------------------------------------------------


def test_sugar_160_is_55_to_65_cst_and_table_end_points():
    assert 55.0 <= get_liquid("sugar-water", sugar_concentration=160).viscosity_cst <= 65.0
    assert get_liquid("sugar-water", sugar_concentration=0).viscosity_cst == pytest.approx(1.0)
    # c = 100 g per 100 g water is w = 50 %: the table's 12.6 cSt exactly
    assert sugar_mass_fraction(100.0) == pytest.approx(50.0)
    assert get_liquid("sugar-water", sugar_concentration=100).viscosity_cst == pytest.approx(12.6)
    # density of 50 % sucrose (CRC 1.2296 g/mL)
    assert get_liquid("sugar-water", sugar_concentration=100).density_kg_m3 == pytest.approx(1229.6)


def test_viscosity_rises_with_concentration_and_falls_with_temperature():
    nus = [
        get_liquid("sugar-water", sugar_concentration=c).viscosity_cst for c in range(0, 161, 10)
    ]
    assert np.all(np.diff(nus) > 0)
    water25 = get_liquid("water", temperature_c=25.0).viscosity_cst
    assert water25 == pytest.approx(math.exp(-0.024 * 5), rel=1e-9)  # −2.4 %/°C
    hot = get_liquid("sugar-water", sugar_concentration=150, temperature_c=21.0).viscosity_cst
    cold = get_liquid("sugar-water", sugar_concentration=150, temperature_c=20.0).viscosity_cst
    assert hot / cold == pytest.approx(math.exp(-0.024 - 0.026 * 60.0 / 60.0), rel=0.01)


def test_paper_liquids_log10_viscosity():
    assert get_liquid("olive-oil").log10_viscosity_cst == pytest.approx(1.81, abs=0.01)
    assert get_liquid("corn-oil").log10_viscosity_cst == pytest.approx(1.72, abs=0.01)
    assert get_liquid("mirin").log10_viscosity_cst == pytest.approx(1.34, abs=0.01)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"name": "honey"}, "known liquids: water"),
        ({"name": "sugar-water"}, "needs a sugar concentration"),
        ({"name": "sugar-water", "sugar_concentration": 250.0}, "outside"),
        ({"name": "sugar-water", "sugar_concentration": float("nan")}, "outside"),
        ({"name": "olive-oil", "sugar_concentration": 10.0}, "only applies"),
        ({"name": "water", "temperature_c": 90.0}, "temperature"),
    ],
)
def test_bad_liquids_raise_catalogue_error(kwargs, match):
    with pytest.raises(CatalogueError, match=match):
        get_liquid(**kwargs)


# --- containers ---------------------------------------------------------------------


def test_cylinder_equivalent_depth_and_bad_containers():
    cyl = get_container("cylinder")
    r = cyl.depth_mm / 2
    assert cyl.equivalent_depth_mm(r) == pytest.approx(math.pi * r / 4)  # half full: A/W
    assert cyl.fill_fraction(r) == pytest.approx(0.5)
    assert get_container("grooved-cuboid").fill_fraction(30.0) == pytest.approx(0.5)
    with pytest.raises(CatalogueError, match="known containers: grooved-cuboid"):
        get_container("jar")
    with pytest.raises(CatalogueError, match="does not fit"):
        get_container("glass").check_height(70.0)
    with pytest.raises(CatalogueError, match="does not fit"):
        simulate_trial("water", height_mm=-3.0)


def test_paper_fill_range_is_25_to_75_percent():
    box = get_container("grooved-cuboid")
    assert 0.25 <= box.fill_fraction(16.0) <= 0.3
    assert 0.6 <= box.fill_fraction(40.0) <= 0.75


# --- dynamics -----------------------------------------------------------------------


def test_frequency_rises_with_height_and_matches_dispersion_relation():
    length = get_container("grooved-cuboid").length_mm * 1e-3
    k = math.pi / length
    omegas = []
    for h in np.linspace(16.0, 40.0, 7):
        trial = simulate_trial("water", height_mm=float(h), seed=3)
        h_true = trial.extra["true_height_mm"] * 1e-3
        w0_sq = G * k * math.tanh(k * h_true)
        expected = math.sqrt(w0_sq - trial.true_decay_rate**2)
        # grasp coupling shifts a plastic container's slosh by well under 1 %
        assert trial.true_angular_frequency == pytest.approx(expected, rel=0.01)
        omegas.append(trial.true_angular_frequency)
    assert np.all(np.diff(omegas) > 0)


def test_small_amplitude_decay_matches_stokes_formula():
    liquid = get_liquid("sugar-water", sugar_concentration=60)
    box = get_container("grooved-cuboid")
    h, b, length = 0.028, box.width_mm * 1e-3, box.length_mm * 1e-3
    system = slosh_system(liquid, box, 28.0, wall_factor=1.5, contact_line_damping=0.02)
    k = math.pi / length
    w = math.sqrt(G * k * math.tanh(k * h))
    nu = liquid.viscosity_m2_s
    bracket = 1 / b + 1 / length + k * (1 - 2 * h / length) / math.sinh(2 * k * h)
    expected = 1.5 * math.sqrt(nu * w / 2) * bracket + 2 * nu * k * k + 0.02
    assert system.slow_mode()[0] == pytest.approx(expected, rel=0.02)


def test_decay_rate_rises_with_viscosity():
    cases = [
        ("water", None),
        ("sugar-water", 40.0),
        ("sugar-water", 120.0),
        ("mirin", None),
        ("olive-oil", None),
        ("detergent", None),
    ]
    rates = [
        simulate_trial(name, sugar_concentration=c, height_mm=28.0, seed=5).true_decay_rate
        for name, c in cases
    ]
    assert np.all(np.diff(rates) > 0)
    assert rates[-1] / rates[0] > 10


def test_damping_is_faster_at_large_amplitude():
    system = slosh_system(get_liquid("water"), get_container("grooved-cuboid"), 28.0)
    lam_true, _ = system.slow_mode()
    t = np.arange(0.0, 40.0, 1 / 240)
    y0 = np.zeros(6)
    y0[2] = 0.010  # 10 mm slosh-mass displacement: a steep wave
    x1 = integrate(system, t, lambda _t: 0.0, y0)[2]
    envelope = np.abs(hilbert(x1))
    log_env = np.log(envelope)

    def local_rate(a, b):
        m = (t > a) & (t < b)
        return -np.polyfit(t[m], log_env[m], 1)[0]

    assert local_rate(0.5, 2.0) > 1.5 * lam_true
    late = envelope < 0.0005
    start = t[late][0]
    assert local_rate(start, start + 8.0) == pytest.approx(lam_true, rel=0.05)


def test_energy_decays_after_the_push():
    trial = simulate_trial("water", height_mm=30.0, seed=2)
    t, f = trial.t_s, trial.slosh_force_n()
    sos = butter(4, 3.0, fs=240.0, output="sos")
    f = sosfiltfilt(sos, f - np.median(f))
    end = trial.params.push_end_s
    before = np.sqrt(np.mean(f[t < trial.params.push_start_s] ** 2))
    windows = [np.sqrt(np.mean(f[(t >= a) & (t < a + 2.0)] ** 2)) for a in end + np.arange(5) * 2]
    assert np.all(np.diff(windows) < 0)
    assert windows[0] > 5 * before  # the push excites far more than the lift's residual


def test_heavy_glass_container_changes_the_measured_force():
    """At the slow mode the gel force is the slosh reaction minus the container's inertia.

    ``F = R − M_r·Ẍ`` with the container on the grasp spring: ``F/R = 1/(1 + M_r s²/(K + C s))``
    at the eigenvalue ``s``; a heavy container (mass comparable to the liquid's) amplifies it.
    """
    ratios = {}
    for name in ("grooved-cuboid", "glass"):
        system = slosh_system(get_liquid("water"), get_container(name), 30.0)
        eig, vec = np.linalg.eig(system.state_matrix())
        i = np.argmin(np.abs(eig.imag - system.slow_mode()[1]) + (eig.imag < 0) * 1e9)
        s_, v = eig[i], vec[:, i]
        k, c = system.support_stiffness_n_m, system.support_damping_n_s_m
        gel = k * v[0] + c * v[1]
        lam = system.linear_decay_rates()
        reaction = sum(
            m.mass_kg * (m.natural_frequency**2 * v[2 + 2 * j] + 2 * lam[j] * v[3 + 2 * j])
            for j, m in enumerate(system.modes)
        )
        ratios[name] = abs(gel / reaction)
        if name == "glass":  # mass comparable to the liquid's
            assert system.container_mass_kg > 0.5 * system.liquid_mass_kg
        expected = 1 / abs(1 + system.rigid_mass_kg * s_**2 / (k + c * s_))
        assert ratios[name] == pytest.approx(expected, rel=1e-6)
    assert ratios["grooved-cuboid"] < 1.015
    assert ratios["glass"] > 1.03


def test_loads_follow_conventions_and_weight():
    trial = simulate_trial("olive-oil", height_mm=25.0, seed=1, container="cuboid")
    loads = trial.loads
    n = loads.t_s.size
    assert loads.t_s[0] == 0.0 and loads.duration_s == pytest.approx(13.0)
    assert loads.shear_force_n.shape == (n, 2, 2) and loads.twist_moment_nmm.shape == (n, 2)
    mass_kg = (trial.extra["liquid_mass_g"] + get_container("cuboid").mass_g) * 1e-3
    quiet = loads.t_s < trial.params.push_start_s
    weight = loads.shear_force_n[quiet, :, 1].sum(axis=1).mean()
    assert weight == pytest.approx(-mass_kg * G, rel=0.01)
    assert trial.params.push_start_s < 1.2 and loads.duration_s - trial.params.push_end_s > 10
    assert np.all(loads.normal_force_n > 0)


def test_wrist_sensor_is_much_noisier_than_the_gels():
    trial = simulate_trial("water", height_mm=30.0, seed=4)
    quiet = trial.t_s < trial.params.push_start_s
    gel_noise = np.std(trial.slosh_force_n()[quiet])
    wrist_noise = np.std(np.diff(trial.wrench[quiet, 0])) / math.sqrt(2)
    assert wrist_noise == pytest.approx(1.2, rel=0.15)
    assert wrist_noise > 100 * gel_noise
    assert trial.wrench.shape == (trial.t_s.size, 6)


def test_deterministic_given_seed_and_varies_between_seeds():
    a = simulate_trial("sugar-water", sugar_concentration=50.0, height_mm=20.0, seed=11)
    b = simulate_trial("sugar-water", sugar_concentration=50.0, height_mm=20.0, seed=11)
    c = simulate_trial("sugar-water", sugar_concentration=50.0, height_mm=20.0, seed=12)
    np.testing.assert_array_equal(a.loads.shear_force_n, b.loads.shear_force_n)
    np.testing.assert_array_equal(a.wrench, b.wrench)
    assert a.true_decay_rate == b.true_decay_rate
    assert a.true_decay_rate != c.true_decay_rate
    assert not np.allclose(a.slosh_force_n(), c.slosh_force_n())


def test_given_temperature_is_used_and_bad_arguments_raise():
    trial = simulate_trial("water", height_mm=20.0, temperature_c=25.0)
    assert trial.temperature_c == 25.0
    assert trial.viscosity_cst == pytest.approx(math.exp(-0.024 * 5))
    with pytest.raises(LiquidTouchError, match="too short"):
        simulate_trial("water", height_mm=20.0, duration_s=1.0)
    with pytest.raises(CatalogueError):
        simulate_trial("water", height_mm=20.0, container="bucket")


@settings(max_examples=60, deadline=None)
@given(
    container=st.sampled_from(["grooved-cuboid", "cuboid", "cylinder", "glass"]),
    fraction=st.floats(0.15, 0.85),
    conc=st.floats(0.0, 160.0),
)
def test_mechanical_analogue_is_consistent_over_the_catalogue(container, fraction, conc):
    box = get_container(container)
    liquid = get_liquid("sugar-water", sugar_concentration=conc)
    h = fraction * box.depth_mm
    system = slosh_system(liquid, box, h)
    lam, omega = system.slow_mode()
    assert 0 < lam < omega  # underdamped
    assert sum(m.mass_kg for m in system.modes) < system.liquid_mass_kg
    # a weak higher mode: m3/m1 = tanh(3kh)/(27 tanh(kh)) <= 1/9 (the shallow limit)
    assert system.modes[1].mass_kg <= system.modes[0].mass_kg / 9 * (1 + 1e-9)
    # equivalent depth A/W in the dispersion relation, within the grasp coupling's 1 %
    k = math.pi / (box.length_mm * 1e-3)
    h_eq = box.equivalent_depth_mm(h) * 1e-3
    assert omega == pytest.approx(math.sqrt(G * k * math.tanh(k * h_eq) - lam**2), rel=0.012)
    higher = slosh_system(liquid, box, min(h + 2.0, 0.9 * box.depth_mm)).slow_mode()[1]
    assert higher > omega
