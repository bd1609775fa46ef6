"""scripts/measure_tp_pulls.py: the target track's pulls summed over lag and stop frames."""
from __future__ import annotations

import numpy as np
import pytest

from scripts import measure_tp_pulls as mp
from scripts import trace_tp_track as tt


@pytest.fixture(scope="module")
def rec_dir(occlusion_lab_6s):
    return occlusion_lab_6s


def test_frames_are_put_in_kinds_by_gap_and_speeds():
    assert mp.kind_of(0.3, 1.0, 0.8) == "lag"
    assert mp.kind_of(0.1, 1.0, 0.8) is None  # on its person
    assert mp.kind_of(0.3, 0.05, 0.4) == "stop"
    assert mp.kind_of(0.3, 0.05, 0.1) is None  # both still
    assert mp.kind_of(0.05, 0.05, 0.4) == "stop"  # walking on from where the person stands
    assert mp.kind_of(1.2, 1.0, 0.8) is None and mp.kind_of(1.2, 0.05, 0.4) is None  # someone else's or lost
    assert mp.kind_of(0.3, 0.3, 0.8) is None  # neither walking nor standing


def test_pooled_sums_equal_the_traces_pulls_over_the_whole_run(rec_dir):
    """Every frame taken as one kind: the sums by update (cameras pooled) and the motion row are
    ``trace_tp_track --pulls target``'s rows over the whole run, added over the cameras."""
    out = mp.pulls(rec_dir, kinds=lambda gap, person, track: "lag")["lag"]
    lines = tt.trace(rec_dir, 0, 0.0, 10.0, pulls="target")
    k = next(i for i, ln in enumerate(lines) if ln.startswith("pulls towards target"))
    assert f"({out['frames']} frames)" in lines[k]
    want: dict[str, np.ndarray] = {}
    for ln in lines[k + 2:]:
        w = ln.split()
        update = " ".join(w[1:-3]).removeprefix("update_")
        want.setdefault(update, np.zeros(3))[:] += [float(w[-2]), float(w[-1]), int(w[-3])]
    assert set(want) == set(out) - {"frames"}
    for update, v in want.items():
        assert out[update][2] == v[2]
        # the table prints each camera's sum to 3 decimals
        np.testing.assert_allclose(out[update][:2], v[:2], atol=0.0006 * 4 + 1e-9)


def test_the_table_sums_recordings_per_kind_and_the_command_line_runs(rec_dir, capsys):
    a = {"lag": {"frames": 2, "flow": np.array([-0.1, -0.4, 3.0]), "motion": np.array([0.0, 0.1, 2.0])}}
    b = {"lag": {"frames": 3, "flow": np.array([-0.2, -0.2, 4.0])}, "stop": {"frames": 1, "plane own": np.array([0.05, 0.3, 1.0])}}
    lines = mp.table([a, b])
    assert lines[0] == "lag: 5 frames in 2 of 2 recording(s)"
    flow = next(ln for ln in lines if ln.split()[0] == "flow").split()
    assert flow[1:] == ["7", "-0.30", "-0.60", "-6.00", "-0.120"]
    assert "stop: 1 frames in 1 of 2 recording(s)" in lines
    assert mp.table([{}]) == ["lag: 0 frames in 0 of 1 recording(s)", "stop: 0 frames in 0 of 1 recording(s)"]
    assert mp.main([rec_dir]) == 0
    out = capsys.readouterr().out
    assert out.startswith("lag: ") and "\nstop: " in out
    with pytest.raises(SystemExit, match="--jobs must be at least 1"):
        mp.main([rec_dir, "--jobs", "0"])
