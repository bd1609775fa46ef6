"""scripts/explain_tp_errors.py: target_planes' confirmed tracks read against the walking movers."""
import numpy as np
import pandas as pd
import pytest

from scripts.explain_tp_errors import summary, track_errors

T = np.round(np.arange(0, 3.0, 0.1), 1)


def mover(name, start, v, walking=True):
    p = np.asarray(start, float) + np.outer(T, v)
    return pd.DataFrame({"t": T, "person_id": name, "x": p[:, 0], "y": p[:, 1], "vx": v[0], "vy": v[1], "walking": walking})


def track(tid, start, v, mode, confirmed=True):
    p = np.asarray(start, float) + np.outer(T, v)
    return pd.DataFrame({"t": T, "track_id": tid, "x": p[:, 0], "y": p[:, 1], "vx": v[0], "vy": v[1], "mode": mode,
                         "confirmed": confirmed})


def test_a_lagging_track_is_measured_behind_and_slow_and_a_good_one_on_its_mover():
    """Mover a walks east at 1 m/s, its track 0.2 m behind and 0.1 m aside, at 0.8 m/s relative
    speed at the start (the offset grows 0.02 m a frame); mover b walks north 3 m away, its
    track exact. An unconfirmed track on a and a standing mover are not measured."""
    movers = pd.concat([mover("a", (0, 0), (1.0, 0.0)), mover("b", (3, 3), (0.0, 1.0)),
                        mover("s", (6, 0), (0.0, 0.0), walking=False)], ignore_index=True)
    internal = pd.concat([track(1, (-0.2, 0.1), (0.8, 0.0), "merged"), track(2, (3, 3), (0.0, 1.0), "planes"),
                          track(3, (0.05, 0.0), (1.0, 0.0), "area", confirmed=False), track(4, (6, 0), (0, 0), "predicted")],
                         ignore_index=True)
    E = track_errors(internal, movers)
    a = E[E["track_id"] == 1].sort_values("t")
    assert set(E["track_id"]) == {1, 2}  # 3 unconfirmed, 4 on a standing person
    assert (a["person_id"] == "a").all() and (a["mode"] == "merged").all() and (a["pair"] == "apart").all()
    lag = -0.2 - 0.2 * T[: len(a)]
    assert np.allclose(a["along"], lag) and np.allclose(a["speed"], 0.8)
    assert np.allclose(a["err"], np.hypot(lag, 0.1))
    b = E[E["track_id"] == 2]
    assert np.allclose(b["err"], 0.0) and np.allclose(b["speed"], 1.0) and (b["person_id"] == "b").all()
    S = summary(E).set_index("mode")
    assert list(S.index) == ["planes", "merged"]  # the modes' order
    assert S.loc["merged", "frames"] == len(a) and S.loc["merged", "speed_median"] == pytest.approx(0.8)
    assert S.loc["merged", "along_median"] == pytest.approx(np.median(lag))


def test_a_track_more_than_a_metre_off_is_not_matched_and_a_pair_within_a_metre_is_beside():
    """Two movers 0.6 m apart walking east: both tracks matched, both 'beside'; a track 1.5 m from
    every mover is matched to none."""
    movers = pd.concat([mover("a", (0, 0), (1.0, 0.0)), mover("b", (0, 0.6), (1.0, 0.0))], ignore_index=True)
    internal = pd.concat([track(1, (0, 0), (1.0, 0.0), "planes"), track(2, (0, 0.6), (1.0, 0.0), "area"),
                          track(3, (0, 2.1), (1.0, 0.0), "planes")], ignore_index=True)
    E = track_errors(internal, movers)
    assert set(E["track_id"]) == {1, 2} and (E["pair"] == "beside").all()
    assert track_errors(internal.iloc[:0], movers).empty


def test_the_error_is_normalised_by_the_tracks_own_covariance_and_counted_beyond_the_99_percent_gate():
    """Mover a walks east; its track 0.1 m ahead with a position variance of 0.1^2 along x: d2 = 1,
    inside the gate; mover b's track 0.5 m off with a spread of 0.1 m: d2 = 25, beyond it.
    Without the covariance columns d2 is NaN and the summary's consistency columns too."""
    movers = pd.concat([mover("a", (0, 0), (1.0, 0.0)), mover("b", (3, 3), (0.0, 1.0))], ignore_index=True)
    internal = pd.concat([track(1, (0.1, 0.0), (1.0, 0.0), "planes"), track(2, (3.5, 3.0), (0.0, 1.0), "area")], ignore_index=True)
    internal["cxx"], internal["cxy"], internal["cyy"] = 0.01, 0.0, 0.04
    E = track_errors(internal, movers)
    assert np.allclose(E.loc[E["track_id"] == 1, "d2"], 1.0) and np.allclose(E.loc[E["track_id"] == 2, "d2"], 25.0)
    S = summary(E).set_index("mode")
    assert S.loc["planes", "beyond99"] == 0.0 and S.loc["area", "beyond99"] == 1.0
    assert S.loc["area", "d2_median"] == pytest.approx(25.0)
    bare = track_errors(internal.drop(columns=["cxx", "cxy", "cyy"]), movers)
    assert bare["d2"].isna().all() and summary(bare)["beyond99"].isna().all()


def test_frames_where_a_corner_camera_sees_the_movers_feet_below_its_image_are_told_apart():
    """The four test cameras (corners of an 8 x 7 m room, 2.6 m up): mover a walks 1 m from the
    south-west camera, whose image the feet are below of (``below``); mover b walks in the middle
    of the room, seen whole by all four. Without cameras every frame is not ``below``. The
    summary by ``below`` splits the frames."""
    from scripts.explain_tp_errors import feet_below
    from tests.test_target_planes import four_cameras

    cams = {c.name: (np.asarray(c.P, float), float(c.width), float(c.height)) for c in four_cameras()}
    assert feet_below(cams, (1.0, 0.8)) and not feet_below(cams, (4.0, 3.5))
    assert [n for n in cams if feet_below({n: cams[n]}, (1.0, 0.8))] == ["sw"]
    movers = pd.concat([mover("a", (0.8, 0.8), (0.1, 0.0)), mover("b", (3.5, 3.5), (0.1, 0.0))], ignore_index=True)
    movers["vx"] = 0.5  # walking (the positions move 0.1 m/s: they stay where they are)
    internal = pd.concat([track(1, (0.8, 0.85), (0.1, 0.0), "area"), track(2, (3.5, 3.5), (0.1, 0.0), "planes")],
                         ignore_index=True)
    E = track_errors(internal, movers, cams)
    assert E.loc[E["track_id"] == 1, "below"].all() and not E.loc[E["track_id"] == 2, "below"].any()
    assert not track_errors(internal, movers)["below"].any()
    S = summary(E, ("below",)).set_index("below")
    assert S.loc[True, "frames"] == S.loc[False, "frames"] == len(T)
    assert S.loc[True, "err_median"] == pytest.approx(0.05) and S.loc[False, "err_median"] == pytest.approx(0.0)


def test_single_reads_the_single_target_run_the_rmse_target_scores(tmp_path, monkeypatch, capsys):
    """``--single``: the tracks of ``experiment_tsutsui.run_target`` (the clicked target's run, whose
    track ids ``trace_tp_track`` uses), not of the multi-person run; without it, the multi-person
    run's. Each run is the real one, watched."""
    import scripts.experiment_tsutsui as ts
    from scripts.explain_tp_errors import errors, main
    from trackroom.dataset import write_recording
    from trackroom.scenes.loader import load_scene
    from trackroom.sim.simulate import simulate

    d = tmp_path / "seed_3"
    write_recording(simulate(load_scene("occlusion_lab"), 3, 3.0, "analytic"), d)
    calls = []
    run_target, multi_estimator = ts.run_target, ts.multi_estimator
    monkeypatch.setattr(ts, "run_target", lambda rec, params=None: calls.append("single") or run_target(rec, params))
    monkeypatch.setattr(ts, "multi_estimator", lambda rec, params=None: calls.append("multi") or multi_estimator(rec, params))
    single = errors(str(d), {}, single=True)
    assert calls == ["single"]
    multi = errors(str(d), {})
    assert calls == ["single", "multi"]
    for E in (single, multi):
        assert len(E) and (E["recording"] == str(d)).all()
    assert main([str(d), "--single"]) == 0 and calls[-1] == "single"
    assert "(single-target run)" in capsys.readouterr().out
