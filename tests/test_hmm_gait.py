"""Phone features of the HMM matcher: bobbing feature, magnetometer heading, train-gait."""
from __future__ import annotations

import json

import numpy as np
import pytest

from trackroom.estimators.gait import GaitModel, bobbing_feature, fit_gait, phone_heading
from trackroom.cli import main
from trackroom.dataset import write_recording
from tests.test_hmm_matcher import MEETING, synthetic_recording


def test_bobbing_feature_of_a_sine_is_its_rms():
    # vertical specific force 9.81 + A sin(2 pi f t) in a tilted phone: std over whole cycles = A / sqrt(2)
    t = np.arange(0, 4, 0.01)
    A, f = 2.0, 2.5
    vertical = 9.81 + A * np.sin(2 * np.pi * f * t)
    tilt = np.deg2rad(30)
    acc = np.stack([np.sin(tilt) * vertical, np.zeros_like(t), np.cos(tilt) * vertical], axis=1)
    g = bobbing_feature(t, acc, np.array([2.0, 3.99]), 0.8)  # 0.8 s = 2 cycles
    np.testing.assert_allclose(g, A / np.sqrt(2), rtol=0.02)
    assert bobbing_feature(t, np.tile([0, 0, 9.81], (len(t), 1)), np.array([2.0]), 0.8)[0] == pytest.approx(0, abs=1e-6)


@pytest.mark.parametrize("yaw", [0.0, 1.0, -2.5, np.pi])
def test_phone_heading_inverts_the_field_rotation(yaw):
    field = (0.0, -0.5, 0.0)
    c, s = np.cos(yaw), np.sin(yaw)
    m = np.array([[c * field[0] + s * field[1], -s * field[0] + c * field[1], 0.0]] * 10)
    acc = np.tile([0.0, 0.0, 9.81], (10, 1))
    psi = phone_heading(np.arange(10) * 0.01, acc, m, np.array([0.09]), 0.05, field)
    assert np.angle(np.exp(1j * (psi[0] - yaw))) == pytest.approx(0, abs=1e-9)


@pytest.mark.parametrize("tilt_axis", [0.0, 0.7, 2.0])
def test_phone_heading_of_a_tilted_phone_is_its_yaw(tilt_axis):
    # a phone turned by yaw and then tilted by 25 deg about a horizontal axis: the field (dipping
    # 60 deg, as at mid latitudes) and gravity both read in that tilted frame; the tilt-compensated
    # heading is the direction of the phone's x axis on the floor
    field = np.array([0.0, 0.25, -0.43])
    yaw, tilt = 0.6, np.radians(25)
    a = np.array([np.cos(tilt_axis), np.sin(tilt_axis), 0.0])
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    R_tilt = np.eye(3) + np.sin(tilt) * K + (1 - np.cos(tilt)) * K @ K
    R_yaw = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    R = R_yaw @ R_tilt  # phone frame -> world
    n = 50
    acc = np.tile(R.T @ [0.0, 0.0, 9.81], (n, 1))
    mag = np.tile(R.T @ field, (n, 1))
    x_world = R[:, 0]
    expected = np.arctan2(x_world[1], x_world[0])
    psi = phone_heading(np.arange(n) * 0.01, acc, mag, np.array([0.4]), 0.1, field)
    assert np.angle(np.exp(1j * (psi[0] - expected))) == pytest.approx(0, abs=1e-9)
    # the uncompensated reading (the phone taken as upright) is off by degrees
    upright = phone_heading(np.arange(n) * 0.01, np.tile([0.0, 0.0, 9.81], (n, 1)), mag, np.array([0.4]), 0.1, field)
    assert abs(np.angle(np.exp(1j * (upright[0] - expected)))) > np.radians(5)


def test_fit_gait_recovers_class_parameters():
    rng = np.random.default_rng(1)
    walk = rng.normal(1.2, 0.3, 4000)
    stop = rng.exponential(0.04, 4000)
    m = fit_gait(np.concatenate([walk, stop]), np.r_[np.ones(4000, bool), np.zeros(4000, bool)],
                 rng.vonmises(0, 40, 3000), rng.normal(1.0, 0.3, 3000), 0.8)
    assert m.walk_mu == pytest.approx(1.2, abs=0.02) and m.walk_sigma == pytest.approx(0.3, abs=0.02)
    assert m.stop_scale == pytest.approx(0.04, rel=0.05)
    assert m.heading_kappa == pytest.approx(40, rel=0.1)
    with pytest.raises(ValueError, match="both walking and stopped"):
        fit_gait(walk, np.ones(4000, bool), [], [], 0.8)


def test_train_gait_command(tmp_path, capsys):
    rec = synthetic_recording(MEETING, {"A": "phA", "B": "phB"}, 12.0, seed=3)
    write_recording(rec, tmp_path / "train")
    out = tmp_path / "gait.json"
    assert main(["train-gait", str(tmp_path / "train"), "--out", str(out)]) == 0
    model = GaitModel.from_json(out)
    d = json.loads(out.read_text())
    assert d["source"].startswith("trackroom train-gait")
    # the synthetic bob (3 cm peak to peak at ~1.6 Hz) has an RMS of about 1 m/s^2; standing is noise
    assert 0.5 < model.walk_mu < 1.5
    assert model.stop_scale < 0.2
    assert model.heading_kappa > 100  # ideal magnetometer heading, only 1% field noise
    assert model.walking(np.array([model.walk_mu]))[0] and not model.walking(np.array([0.0]))[0]
    # an unusable input is one clear line, exit status 2
    assert main(["train-gait", str(tmp_path / "nope"), "--out", str(out)]) == 2
    assert "error" in capsys.readouterr().err
