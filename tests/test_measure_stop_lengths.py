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
