"""sim/phone_errors.py: phone errors on the noise-free IMU readings (issue 13)."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from trackroom.scenes.loader import load_scene
from trackroom.sim import phone_errors
from trackroom.sim.simulate import simulate

ERRORS = ["sensors.mag_disturbance_deg=20", "sensors.accel_bias=0.05", "sensors.pocket_yaw_deg=30",
          "sensors.pocket_tilt_deg=10", "sensors.swing_per_min=3"]
# every phone error off (they are on, modestly, by default)
NONE = ["sensors.mag_disturbance_deg=0", "sensors.accel_bias=0", "sensors.pocket_yaw_deg=0",
        "sensors.pocket_tilt_deg=0", "sensors.swing_per_min=0"]


def test_same_seed_same_recording_and_only_the_imu_changes():
    a = simulate(load_scene("bearing_hall", ERRORS), 4, 20.0)
    b = simulate(load_scene("bearing_hall", ERRORS), 4, 20.0)
    plain = simulate(load_scene("bearing_hall", NONE), 4, 20.0)
    for kind in a.observations.tables:
        assert a.observations[kind].equals(b.observations[kind]), kind
    assert a.observations["bearings"].equals(plain.observations["bearings"])
    assert a.truth.people.equals(plain.truth.people)
    assert not a.observations["imu"].equals(plain.observations["imu"])
    # simulator settings, not calibration: an estimator is not told the errors
    assert "pocket_yaw_deg" not in a.calibration.noise


def test_pocket_yaw_turns_the_heading_and_keeps_the_magnitudes():
    scene = load_scene("bearing_hall", NONE + ["sensors.pocket_yaw_deg=30"])
    rng = np.random.default_rng(1)
    n = 50
    r = np.zeros((1, n, 9))
    r[0, :, 0:3] = [0.3, 0.0, 9.81]
    r[0, :, 6:9] = [0.0, -0.5, 0.1]
    out = phone_errors.apply(r, np.full((1, n, 2), 5.0), np.arange(n) * 0.01, scene.floorplan, scene.sensors, rng)
    np.testing.assert_allclose(np.linalg.norm(out[0, :, 6:9], axis=1), np.linalg.norm(r[0, :, 6:9], axis=1))
    turn = np.angle(np.exp(1j * (np.arctan2(out[0, :, 7], out[0, :, 6]) - np.arctan2(r[0, :, 7], r[0, :, 6]))))
    assert np.ptp(turn) < 1e-12 and 0 < abs(turn[0]) <= np.radians(30) + 1e-12
    np.testing.assert_allclose(out[0, :, 2], 9.81)  # no tilt: gravity stays on z


@pytest.mark.parametrize("where, strongest", [((0.3, 5.0), True), ((5.0, 5.0), False)])
def test_disturbance_is_strongest_at_the_walls(where, strongest):
    scene = load_scene("bearing_hall")
    field = phone_errors.disturbance_field(np.random.default_rng(0), scene.floorplan, 20.0, 1.0)
    rng = np.random.default_rng(5)
    near = np.abs(field(np.c_[np.full(200, where[0]), rng.uniform(1, 9, 200)]))
    assert near.max() <= np.radians(20.0) + 1e-12
    assert (near.mean() > np.radians(3.0)) == strongest


def test_defaults_are_modest_and_on():
    s = load_scene("bearing_hall").sensors
    assert s.phone_errors()
    assert (s.pocket_yaw_deg, s.pocket_tilt_deg, s.accel_bias, s.mag_disturbance_deg, s.swing_per_min) == (30, 10, 0.05, 10, 0.5)


def test_no_errors_leave_the_readings_alone():
    scene = load_scene("bearing_hall", NONE)
    assert not scene.sensors.phone_errors()
    r = np.random.default_rng(2).normal(size=(2, 30, 9))
    out = phone_errors.apply(r, np.zeros((2, 30, 2)) + 5, np.arange(30) * 0.01, scene.floorplan, scene.sensors,
                             np.random.default_rng(0))
    np.testing.assert_array_equal(out, r)


def test_swings_and_disturbance_turn_the_readings_about_the_vertical_only():
    scene = load_scene("bearing_hall", NONE + ["sensors.swing_per_min=30", "sensors.mag_disturbance_deg=20"])
    n = 3000
    t = np.arange(n) * 0.01
    r = np.zeros((1, n, 9))
    r[0, :, 0:3] = [0.3, 0.1, 9.81]
    r[0, :, 3:6] = [0.0, 0.0, 0.2]
    r[0, :, 6:9] = [0.0, -0.5, 0.1]
    pos = np.c_[np.linspace(0.3, 5.0, n), np.full(n, 5.0)][None]  # from a wall into the room
    out = phone_errors.apply(r, pos, t, scene.floorplan, scene.sensors, np.random.default_rng(3))
    for j in (0, 6):  # accelerometer, magnetometer: turned, their lengths and vertical parts kept
        np.testing.assert_allclose(np.linalg.norm(out[0, :, j:j + 3], axis=1), np.linalg.norm(r[0, :, j:j + 3], axis=1))
        np.testing.assert_allclose(out[0, :, j + 2], r[0, :, j + 2])
    acc_turn = np.angle(np.exp(1j * (np.arctan2(out[0, :, 1], out[0, :, 0]) - np.arctan2(0.1, 0.3))))
    swinging = np.abs(acc_turn) > 1e-12
    assert 0.05 < swinging.mean() < 0.95  # some samples in a swing, some not
    assert np.abs(acc_turn).max() <= np.radians(30) + 1e-9
    # the magnetometer turns with the swing and, on top of it, with the disturbance, strongest at the wall
    mag_turn = np.angle(np.exp(1j * (np.arctan2(out[0, :, 7], out[0, :, 6]) - np.arctan2(-0.5, 0.0)))) - acc_turn
    assert np.abs(mag_turn[:100]).max() > np.radians(1.0)
    assert np.abs(mag_turn).max() <= np.radians(20) + 1e-9
