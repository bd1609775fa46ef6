"""scripts/experiment_tsutsui.py: the issue-12 measurement's perception draws."""
from __future__ import annotations

import pytest

from scripts import experiment_tsutsui as ts


def test_a_perception_draw_redraws_the_windows_and_keeps_the_walkers():
    """``--draw K`` (``run(..., draw=K)``): an analytic recording's camera tables drawn anew
    through the perception model, the same people on the same paths (so the same click); draw 0
    is the seed's own recording, drawn the same every time."""
    rec0, _, m0 = ts.run("analytic", 3.0, 5)
    rec0b, _, _ = ts.run("analytic", 3.0, 5, draw=0)
    rec1, _, m1 = ts.run("analytic", 3.0, 5, draw=1)
    assert rec0.observations["boxes"].equals(rec0b.observations["boxes"])
    assert not rec0.observations["boxes"].equals(rec1.observations["boxes"])
    assert rec0.truth.people.equals(rec1.truth.people)
    assert ts.click(rec0) == ts.click(rec1)
    assert "perception_draw" not in m0 and m1["perception_draw"] == 1


def test_a_draw_is_refused_where_nothing_is_simulated(capsys):
    for argv in (["--sensing", "rendered", "--draw", "1"], ["--sensing", "analytic", "--draw", "-1"]):
        with pytest.raises(SystemExit):
            ts.main(argv)
        assert "--draw K" in capsys.readouterr().err
