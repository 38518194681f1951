"""The upright bottle's slosh (Bessel first mode), pushes along either axis, fresh noise per
push; and the push planner (planning.push) on them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from liquidtouch._core.containers import get_container
from liquidtouch._core.liquids import get_liquid
from liquidtouch.errors import CatalogueError
from liquidtouch.planning.push import plan_push, reference_steepness
from liquidtouch.sim.slosh import GRAVITY_M_S2, slosh_system
from liquidtouch.sim.trial import simulate_trial


@pytest.mark.parametrize("height", [20.0, 60.0, 150.0])
def test_upright_first_mode_is_the_bessel_root(height):
    box = get_container("upright-bottle")
    system = slosh_system(get_liquid("water"), box, height)
    k = 1.841 / (box.length_mm / 2 * 1e-3)
    expected = math.sqrt(GRAVITY_M_S2 * k * math.tanh(k * height * 1e-3))
    assert system.modes[0].natural_frequency == pytest.approx(expected, rel=1e-3)
    lam, omega = system.slow_mode()  # the grasp's support moves it a little
    assert omega == pytest.approx(expected, rel=0.03)
    # water in a 9 cm bottle: a damping ratio of ~0.5-1 % (Mikishev & Dorozhkin's order)
    assert 0.003 < lam / omega < 0.012
    volume = math.pi * 0.045**2 * height * 1e-3
    assert system.liquid_mass_kg == pytest.approx(1000 * volume, rel=0.01)
    assert system.modes[0].mass_kg < system.liquid_mass_kg


def test_upright_bottle_is_the_same_along_either_axis_and_saturates_when_deep():
    box, water = get_container("upright-bottle"), get_liquid("water")
    assert slosh_system(water, box, 80.0, axis="y").slow_mode() == pytest.approx(
        slosh_system(water, box, 80.0, axis="x").slow_mode()
    )
    deep = [slosh_system(water, box, h).slow_mode()[1] for h in (100.0, 150.0)]
    shallow = [slosh_system(water, box, h).slow_mode()[1] for h in (20.0, 70.0)]
    assert abs(deep[1] - deep[0]) < 0.01 * abs(shallow[1] - shallow[0])


def test_box_pushed_across_sloshes_over_its_width():
    box, water = get_container("grooved-cuboid"), get_liquid("water")
    across = slosh_system(water, box, 30.0, axis="y").modes[0]
    assert across.wavenumber_1_m == pytest.approx(math.pi / (box.width_mm * 1e-3))
    with pytest.raises(CatalogueError, match="along x"):
        get_container("cylinder").along("y")
    with pytest.raises(CatalogueError, match="x or y"):
        box.along("z")


def test_a_repeated_push_draws_fresh_noise_on_the_same_bottle():
    kw = {"height_mm": 30.0, "seed": 4, "duration_s": 4.0}
    first = simulate_trial("water", **kw)
    again = simulate_trial("water", **kw)
    other = simulate_trial("water", **kw, noise_seed=2)
    assert np.array_equal(first.slosh_force_n(), again.slosh_force_n())
    assert other.true_angular_frequency == first.true_angular_frequency
    diff = other.slosh_force_n() - first.slosh_force_n()
    assert 0 < np.std(diff) < 0.2 * np.std(first.slosh_force_n())
    across = simulate_trial("water", **kw, push_axis="y")
    assert across.push_axis == "y"
    assert across.true_angular_frequency > 1.3 * first.true_angular_frequency  # 55 vs 100 mm


@pytest.mark.slow(seconds=12)
def test_plan_upright_deep_cannot_be_resolved_and_box_proposes_its_length():
    bottle = plan_push("upright-bottle", "height_mm", 0.5, fills_mm=[20.0, 120.0])
    assert not bottle.reachable and "120" in bottle.reason
    assert bottle.chosen.reachable == (True, False)
    box = plan_push("grooved-cuboid", "height_mm", 0.5, fills_mm=[20.0, 30.0, 40.0])
    assert box.reachable and box.chosen.axis == "x"
    across = next(a for a in box.axes if a.axis == "y")
    # 55 mm across: ω is far less sensitive to a deep fill than along the 100 mm length
    assert across.limit_std[-1] > 3 * box.chosen.limit_std[-1]
    for a in box.axes:
        assert a.steepness <= reference_steepness() * (1 + 1e-9)
    assert box.protocol_values()["push_axis"] == "x"
    limited = plan_push("grooved-cuboid", fills_mm=[30.0], limits={"push_acceleration_m_s2": 1.0})
    assert all(a.acceleration_m_s2 <= 1.0 for a in limited.axes)


def test_the_rig_pushes_along_either_axis_each_push_with_fresh_noise():
    """Three pushes of one bottle on the rig (no network): x, back along x, then y."""
    import threading

    from liquidtouch.sim.rig.state import Rig

    rig = Rig("mirin", height_mm=25.0, seed=1, gripper_time_scale=0.01, trial_duration_s=5.0)
    rig.begin("GRIP", [25.0, 59.0, 50.0]).run(threading.Event())
    pose = rig.pose()
    lifted = [*pose[:2], pose[2] + 0.05, *pose[3:]]
    rig.begin_move(lifted, 0.5, 5.0).run(threading.Event())
    targets = [
        [lifted[0] + 0.015, *lifted[1:]],
        lifted,
        [lifted[0], lifted[1] + 0.02, *lifted[2:]],
    ]
    forces = []
    for target in targets:
        rig.begin_move(target, 0.3, 3.0).run(threading.Event())
        forces.append(rig.trial.slosh_force_n())
    axes = [(p["push_axis"], round(p["push_distance_mm"], 3)) for p in rig.pushes]
    assert axes == [("x", 15.0), ("x", -15.0), ("y", 20.0)]
    first, back, across = rig.pushes
    assert back["true_angular_frequency"] == first["true_angular_frequency"]
    # across the 55 mm width the slosh is faster than along the 100 mm length
    assert across["true_angular_frequency"] > 1.3 * first["true_angular_frequency"]
    # the push back is the mirror of the first, with its own contact noise
    assert np.corrcoef(forces[0], -forces[1])[0, 1] > 0.9
    assert not np.allclose(forces[0], -forces[1])


def test_plan_with_a_model_counts_its_training_range():
    """A height model of the paper's box (16-40 mm): a fill it was not trained on is out of
    reach whatever the physics' floor; one inside it is judged by the model's own ±."""
    from liquidtouch.models.training import train_regression

    box, rows, heights = get_container("grooved-cuboid"), [], []
    for name in ("water", "mirin", "olive-oil"):
        for h in np.linspace(16, 40, 9):
            rows.append(slosh_system(get_liquid(name), box, h).slow_mode())
            heights.append(h)
    model = train_regression(np.array(rows), {"height_mm": np.array(heights)})
    plan = plan_push(box, "height_mm", 2.0, model=model, fills_mm=[25.0, 50.0])
    along = next(a for a in plan.axes if a.axis == "x")
    assert along.reachable == (True, False) and math.isinf(along.limit_std[1])
