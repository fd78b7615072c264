"""Every bad input raises TypeError (type, dtype) or ValueError (shape, value) with a message that
names the argument and what was expected, and leaves the world exactly as it was."""

import numpy as np
import pytest

import vadop

GOOD = dict(
    positions=np.array([[2.0, 5, 5], [8, 5, 5]]),
    velocities=np.array([[1.0, 0, 0], [0, 0, 0]]),
    radii=np.array([0.5, 0.5]),
    masses=np.array([1.0, 2.0]),
    box=10.0,
)
NAN = float("nan")


def world_with(**changes):
    return vadop.World(**{**GOOD, **changes})


@pytest.mark.parametrize(
    "changes, error, message",
    [
        (dict(positions=GOOD["positions"].astype(np.int64)), TypeError,
         "positions must be a float64 array of shape (n, 3), got int64 of shape (2, 3)"),
        (dict(positions=GOOD["positions"].astype(np.float32)), TypeError, "positions must be a float64 array of shape (n, 3), got float32"),
        (dict(positions=[[2.0, 5, 5], [8, 5, 5]]), TypeError, "positions must be a float64 array of shape (n, 3), got list"),
        (dict(positions=np.zeros(4)), ValueError, "positions must be a float64 array of shape (n, 3), got float64 of shape (4,)"),
        (dict(positions=np.zeros((2, 2))), ValueError, "got float64 of shape (2, 2)"),
        (dict(positions=np.zeros((2, 3, 1))), ValueError, "got float64 of shape (2, 3, 1)"),
        (dict(velocities=np.zeros((3, 3))), ValueError, "velocities must be a float64 array of shape (2, 3), got float64 of shape (3, 3)"),
        (dict(velocities=np.zeros((2, 3), dtype=np.complex128)), TypeError, "velocities must be a float64 array"),
        (dict(velocities=None), TypeError, "velocities must be a float64 array of shape (2, 3), got NoneType"),
        (dict(radii=np.array([0.5])), ValueError, "radii must be a float64 array of shape (2,), got float64 of shape (1,)"),
        (dict(radii=np.array([1, 1])), TypeError, "radii must be a float64 array of shape (2,), got int64"),
        (dict(radii=np.array([0.5, 0.0])), ValueError, "radii[1] must be a finite number > 0, got 0"),
        (dict(radii=np.array([-0.5, 0.5])), ValueError, "radii[0] must be a finite number > 0, got -0.5"),
        (dict(radii=np.array([0.5, NAN])), ValueError, "radii[1] must be a finite number > 0, got NaN"),
        (dict(masses=np.array([1.0, 0.0])), ValueError, "masses[1] must be a finite number > 0, got 0"),
        (dict(masses=np.array([-1.0, 1.0])), ValueError, "masses[0] must be a finite number > 0, got -1"),
        (dict(masses=np.array([1.0, np.inf])), ValueError, "masses[1] must be a finite number > 0, got inf"),
        (dict(masses=np.array([[1.0, 1.0]])), ValueError, "masses must be a float64 array of shape (2,), got float64 of shape (1, 2)"),
        (dict(positions=np.array([[2.0, 5, 5], [8, NAN, 5]])), ValueError, "positions[1] must be finite, got [8.0, NaN, 5.0]"),
        (dict(velocities=np.array([[np.inf, 0, 0], [0, 0, 0]])), ValueError, "velocities[0] must be finite"),
        (dict(positions=np.array([[2.0, 5, 5], [9.8, 5, 5]])), ValueError, "positions[1] = [9.8, 5.0, 5.0] with radii[1] = 0.5 must lie inside the box"),
        (dict(box=-1.0), ValueError, "box as a number is the side of the cube [0, side]^3 and must be finite and > 0, got -1"),
        (dict(box=np.zeros(3)), ValueError, "box must be a number (cube side) or a float64 array of shape (2, 3), got float64 of shape (3,)"),
        (dict(box=np.array([[0, 0, 0], [10, 10, 10]])), TypeError, "box must be a number (cube side) or a float64 array of shape (2, 3), got int64"),
        (dict(box="big"), TypeError, "box must be a number (cube side) or a float64 array of shape (2, 3), got str"),
        (dict(box=np.array([[0.0, 0, 10], [10, 10, 0]])), ValueError, "box must have finite corners with min < max"),
        (dict(method="fast"), ValueError, "method must be one of 'vadop', 'swept-aabb', 'swept-kdop', 'grid', 'discrete', 'brute', got \"fast\""),
        (dict(mode="both"), ValueError, "mode must be 'simulate' or 'detect', got \"both\""),
        (dict(pool_axes=2), ValueError, "axis pool size must be between 3 and 100000, got 2"),
        (dict(pool_axes=-5), ValueError, "pool_axes must be an int between 3 and 100000, got -5"),
        (dict(phi=0.01), ValueError, "phi must be a finite angle in [rho, pi/2]"),
        (dict(restitution=1.5), ValueError, "restitution must lie in [0, 1], got 1.5"),
        (dict(restitution="one"), TypeError, "restitution"),
    ],
)
def test_bad_world_arguments(changes, error, message):
    with pytest.raises(error) as raised:
        world_with(**changes)
    assert message in str(raised.value)


def snapshot(world):
    return (world.ids.tolist(), world.positions.tolist(), world.velocities.tolist(), world.radii.tolist(),
            world.masses.tolist(), world.time)


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda w: w.add(np.array([[1.0, 1, 1], [3, 3, NAN]]), np.zeros((2, 3)), np.array([0.5, 0.5])), ValueError, "positions[1] must be finite"),
        (lambda w: w.add(np.array([[1.0, 1, 1]]), np.zeros((1, 3)), np.array([0.5]), np.array([0.0])), ValueError, "masses[0] must be a finite number > 0"),
        (lambda w: w.add(np.array([[1.0, 1, 1]]), np.zeros((2, 3)), np.array([0.5])), ValueError, "velocities must be a float64 array of shape (1, 3)"),
        (lambda w: w.remove(np.array([0, 7])), ValueError, "ids must name live bodies, got 7"),
        (lambda w: w.remove(np.array([1, 1])), ValueError, "ids must not repeat an id, got 1 twice"),
        (lambda w: w.remove(-1), ValueError, "ids must name live bodies, got -1"),
        (lambda w: w.remove(np.array([0.0])), TypeError, "ids must be an int or an int64 array of shape (n,), got float64"),
        (lambda w: w.remove("0"), TypeError, "ids must be an int or an int64 array of shape (n,), got str"),
        (lambda w: w.set_velocities(np.array([0, 1]), np.array([[1.0, 0, 0], [NAN, 0, 0]])), ValueError, "velocities[1] must be finite"),
        (lambda w: w.set_velocities(np.array([0, 1]), np.zeros((1, 3))), ValueError, "velocities must be a float64 array of shape (2, 3)"),
        (lambda w: w.set_velocities(np.array([0, 5]), np.zeros((2, 3))), ValueError, "ids must name live bodies, got 5"),
        (lambda w: w.step(0.0), ValueError, "time step must be a finite number > 0, got 0"),
        (lambda w: w.step(-0.1), ValueError, "time step must be a finite number > 0"),
        (lambda w: w.step(NAN), ValueError, "time step must be a finite number > 0, got NaN"),
        (lambda w: w.step("0.1"), TypeError, "dt"),
        (lambda w: w.volumes(0.1), ValueError, "volumes exist only for method 'vadop' after the first step"),
        (lambda w: w.volumes(-1.0), ValueError, "time step must be a finite number > 0"),
    ],
)
def test_bad_calls_change_nothing(call, error, message):
    world = world_with()
    before = snapshot(world)
    with pytest.raises(error) as raised:
        call(world)
    assert message in str(raised.value)
    assert snapshot(world) == before
    # The world still works.
    world.step(0.1)


def test_overlapping_bodies_in_simulate_mode_fail_at_step_without_stepping():
    world = world_with(positions=np.array([[5.0, 5, 5], [5.5, 5, 5]]))
    before = snapshot(world)
    with pytest.raises(ValueError, match="spheres 0 and 1 overlap"):
        world.step(0.1)
    assert snapshot(world) == before
    # In detect mode bodies may pass through each other: the same scene steps.
    world_with(positions=np.array([[5.0, 5, 5], [5.5, 5, 5]]), mode="detect").step(0.1)


def test_empty_world_and_absurd_speed():
    world = world_with()
    world.remove(np.array([0, 1]))
    with pytest.raises(ValueError, match="the world is empty"):
        world.step(0.1)
    fast = world_with(velocities=np.array([[1e9, 0, 0], [0, 0, 0]]))
    with pytest.raises(ValueError, match="box lengths in one frame"):
        fast.step(1.0)


def test_bad_scene_and_detect_arguments():
    with pytest.raises(ValueError, match="packing fraction must be in"):
        vadop.scene(100, 0.9, 1.0)
    with pytest.raises(ValueError, match="a scene needs at least one sphere"):
        vadop.scene(0)
    with pytest.raises(OverflowError):
        vadop.scene(-1)
    with pytest.raises(ValueError, match="method must be"):
        vadop.scene(10, method="oracle")
    with pytest.raises(TypeError, match="positions must be a float64 array"):
        vadop.detect(np.zeros((2, 3), dtype=np.int32), GOOD["velocities"], GOOD["radii"], box=10.0, dt=0.1, frames=1)
    with pytest.raises(ValueError, match="time step must be a finite number > 0"):
        vadop.detect(GOOD["positions"], GOOD["velocities"], GOOD["radii"], box=10.0, dt=0.0, frames=1)
