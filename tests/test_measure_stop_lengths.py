"""scripts/measure_stop_lengths.py: the movers' stops in a truth table, on synthetic tables."""
from __future__ import annotations

import numpy as np
import pandas as pd

from scripts.measure_stop_lengths import stop_lengths, summary


def _walker(name, t, speed):
    return pd.DataFrame({"t": t, "person_id": name, "vx": speed, "vy": 0.0})


def test_stops_are_the_slow_runs_of_half_a_second_or_more_and_those_at_the_ends_are_censored():
    t = np.round(np.arange(0.0, 20.0, 0.01), 2)
    v = np.ones_like(t)
    v[(t >= 2.0) & (t < 10.0)] = 0.0  # a stop of 8 s inside the recording (samples 2.00 ... 9.99)
    v[(t >= 12.0) & (t < 12.3)] = 0.01  # a turn through a low speed: too short to be a stop
    v[t >= 17.0] = 0.02  # stands until the end: censored
    people = pd.concat([_walker("target", t, v), _walker("distractor", t, np.where(t < 4.0, 0.0, 1.0)),
                        _walker("standing1", t, np.zeros_like(t))], ignore_index=True)
    s = stop_lengths(people)
    assert list(s.person_id) == ["target", "target", "distractor"]  # standing people are not movers
    assert np.allclose(s.length, [7.99, 2.99, 3.99])
    assert s.censored.tolist() == [False, True, True]
    tab = summary(s)
    assert tab.loc["inside", "stops"] == 1 and np.isclose(tab.loc["inside", "max"], 7.99)
    assert tab.loc["censored", "stops"] == 2 and np.isclose(tab.loc["censored", "max"], 3.99)
    assert summary(stop_lengths(people[people.person_id == "standing1"])).loc["inside", "stops"] == 0


def test_walking_time_per_stop_begun_and_the_chance_of_a_stop_by_speed():
    from scripts.measure_stop_lengths import onset_by_speed, onset_frames, switching

    t = np.round(np.arange(0.0, 20.0, 0.01), 2)
    v = np.ones_like(t)
    v[(t >= 4.0) & (t < 5.0)] = np.linspace(1.0, 0.06, 100)  # slows to a stop ...
    v[(t >= 5.0) & (t < 8.0)] = 0.0                          # ... of 3 s
    v[(t >= 12.0) & (t < 12.1)] = 0.08                        # a turn through a low speed, no stop
    v[t >= 18.0] = 0.0                                        # stands to the end: censored, begun inside
    people = pd.concat([_walker("target", t, v), _walker("distractor", t, np.where(t < 3.0, 0.0, 1.0))], ignore_index=True)
    stops = stop_lengths(people)
    sw = switching(people, stops)
    assert sw["stops_begun"] == 2  # the distractor's stop at the start began before the recording
    assert np.isclose(sw["walking_s"], 2 * 19.99 - stops.length.sum())
    frames = onset_frames(people, stops)
    assert not frames.empty and set(frames.columns) == {"speed", "onset"}
    assert frames.onset.sum() == 2  # the frame before each stop begun
    assert np.allclose(sorted(frames[frames.onset].speed), [1.0 - 0.94 * 90 / 99, 1.0])  # 4.9 s, 17.9 s
    tab = onset_by_speed(frames)
    assert tab.frames.sum() == len(frames)
    assert tab.loc[tab.index[1], "p_onset"] == 1.0  # [0.1, 0.15): the one frame in it, before the stop
    assert np.isclose(tab.p_onset.iloc[-1], 1 / tab.frames.iloc[-1])  # the abrupt stop at 18 s
