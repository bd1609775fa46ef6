"""The HTML report of a comparison (``trackroom report``, ``compare --html``) and ``show --tracks``."""
from __future__ import annotations

import base64
import json
import re
import shutil
from html.parser import HTMLParser

import cv2
import numpy as np
import pandas as pd
import pytest

from trackroom.cli import main

ESTIMATORS = "ekf,target_planes[multi_person=true]"


class Page(HTMLParser):
    """The tables (id -> header cells, body rows of cell texts) and image sources of a page."""

    def __init__(self, text: str):
        super().__init__()
        self.tables: dict[str, dict] = {}
        self.images: list[str] = []
        self._table = self._row = self._cell = None
        self._in_head = False
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self._table = self.tables.setdefault(a.get("id", f"t{len(self.tables)}"), {"header": [], "rows": []})
        elif tag == "thead":
            self._in_head = True
        elif tag == "tr" and self._table is not None:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = ""
        elif tag == "img":
            self.images.append(a.get("src", ""))

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self._row.append(self._cell.strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            (self._table["header"] if self._in_head else self._table["rows"]).append(self._row)
            self._row = None
        elif tag == "thead":
            self._in_head = False
        elif tag == "table":
            self._table = None


@pytest.fixture(scope="module")
def comparison(tmp_path_factory):
    """A small comparison (two short analytic scenes, two seeds, EKF and target planes) with --html."""
    out = tmp_path_factory.mktemp("report") / "cmp"
    rc = main(["compare", "--scenes", "occlusion_lab,overhead_lab", "--seeds", "0-1", "--estimators", ESTIMATORS,
               "--duration", "3", "--set", "walkers.count=2", "--out", str(out), "--html", "--quiet"])
    assert rc == 0
    return out


def decode_png(src: str) -> np.ndarray:
    assert src.startswith("data:image/png;base64,"), src[:40]
    img = cv2.imdecode(np.frombuffer(base64.b64decode(src.split(",", 1)[1]), np.uint8), cv2.IMREAD_COLOR)
    assert img is not None
    return img


def test_compare_html_writes_the_report_with_table_images_and_provenance(comparison):
    page = Page((comparison / "report.html").read_text())
    results = pd.read_csv(comparison / "results.csv")
    # the summary: one row per scene and estimator that ran, a column for every metric results.csv holds
    summary = page.tables["summary-table"]
    ok = results[results["status"] == "ok"]
    assert len(summary["rows"]) == len(ok.groupby(["scene", "estimator"]))
    header = " ".join(summary["header"][0])
    for m in ("mota", "motp", "idf1", "rmse", "id_switches"):
        assert m in header
    mota = ok[(ok["scene"] == "overhead_lab[walkers.count=2]") & (ok["estimator"] == "ekf")]["mota"].mean()
    row = next(r for r in summary["rows"] if r[0] == "overhead_lab[walkers.count=2]" and r[2] == "ekf")
    col = next(i for i, h in enumerate(summary["header"][0]) if h.startswith("mota"))
    assert float(row[col].split()[0]) == pytest.approx(mota, rel=1e-3)
    # every run, every column of results.csv; the skipped runs with their reason
    assert len(page.tables["runs-table"]["rows"]) == len(results) == 8
    assert len(page.tables["runs-table"]["header"][0]) == len(results.columns)
    assert "needs boxes observations" in json.dumps(page.tables["not-run-table"]["rows"])
    # images: the plots compare wrote, a top-down view per scene, the target planes' status timeline
    plots = list(comparison.glob("metric_*.png")) + [comparison / "error_over_time.png"]
    assert len(page.images) == len(plots) + 2 + 1
    for src in page.images:
        img = decode_png(src)
        assert img.shape[0] > 100 and img.shape[1] > 100 and img.std() > 5  # not blank
    text = (comparison / "report.html").read_text()
    assert "tracks over the truth" in text and "camera status per track" in text
    # provenance: the command, versions, seeds, scene hashes
    prov = json.loads((comparison / "provenance.json").read_text())
    assert prov["command_text"] in text.replace("&#39;", "'")
    assert "trackroom compare --scenes occlusion_lab,overhead_lab" in prov["command_text"]
    versions = {r[0]: r[1] for r in page.tables["versions-table"]["rows"]}
    assert versions["trackroom"] == prov["versions"]["trackroom"] and "numpy" in versions
    assert {r[0] for r in page.tables["scenes-table"]["rows"]} == {"occlusion_lab[walkers.count=2]",
                                                                  "overhead_lab[walkers.count=2]"}
    assert all(re.fullmatch(r"[0-9a-f]{64}", r[3]) for r in page.tables["scenes-table"]["rows"])


def test_compare_keeps_tracks_and_the_camera_status(comparison):
    status = list(comparison.glob("runs/occlusion_lab*/seed0/target_planes*.status.parquet"))
    assert len(status) == 1
    st = pd.read_parquet(status[0])
    assert list(st.columns) == ["t", "track_id", "camera", "status", "reason"]
    assert set(st["status"]) <= {"tracking", "merged", "unreliable", "lost"} and "tracking" in set(st["status"])
    assert not list(comparison.glob("runs/*/seed0/ekf*.status.parquet"))  # the EKF keeps none
    assert len(list(comparison.glob("runs/*/seed*/*.tracks.csv"))) == 6  # every ok run


def test_report_shows_every_metric_column_results_csv_holds(comparison, tmp_path, capsys):
    d = tmp_path / "cmp"
    shutil.copytree(comparison, d)
    results = pd.read_csv(d / "results.csv")
    results.insert(len(results.columns), "my_score", np.where(results["status"] == "ok", 0.5 + 0.01 * results["seed"], np.nan))
    results.to_csv(d / "results.csv", index=False)
    assert main(["report", str(d), "--out", str(tmp_path / "r.html")]) == 0
    assert capsys.readouterr().out.startswith(f"wrote {tmp_path / 'r.html'}")
    page = Page((tmp_path / "r.html").read_text())
    header = page.tables["summary-table"]["header"][0]
    col = [i for i, h in enumerate(header) if h.split()[0] == "my_score"]
    assert len(col) == 1
    row = page.tables["summary-table"]["rows"][0]
    assert row[col[0]] == "0.505 [0.5, 0.51]"


def test_report_without_kept_recordings_says_why(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", "--scenes", "overhead_lab", "--seeds", "0", "--estimators", "ekf", "--duration", "2",
                 "--set", "walkers.count=1", "--no-cache", "--out", str(out), "--quiet"]) == 0
    assert main(["report", str(out)]) == 0
    text = (out / "report.html").read_text()
    assert "its recording was not kept (compare --no-cache)" in text
    assert len(Page(text).tables["summary-table"]["rows"]) == 1


def test_report_of_a_folder_that_is_no_comparison_is_one_line(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "results.csv").write_bytes(b"")
    (bad / "spec.toml").write_text('scenes = ["overhead_lab"]\n')
    (bad / "provenance.json").write_text("{}")
    cases = [(tmp_path / "nowhere", "no such folder"), (tmp_path / "empty", "not a trackroom compare folder (no results.csv"),
             (bad, "results.csv: not a readable CSV")]
    for folder, needle in cases:
        assert main(["report", str(folder)]) == 2
        out = capsys.readouterr()
        assert out.out == "" and needle in out.err and len(out.err.strip().splitlines()) == 1, out.err
        assert not (folder / "report.html").exists()


# ----------------------------------------------------------------------------- show --tracks
@pytest.fixture(scope="module")
def two_walkers(tmp_path_factory):
    rec = tmp_path_factory.mktemp("show") / "rec"
    assert main(["generate", "overhead_lab", "--seed", "3", "--duration", "4", "--set", "walkers.count=2",
                 "--out", str(rec), "--quiet"]) == 0
    return rec


def switched_tracks(rec_dir) -> tuple[pd.DataFrame, float, str]:
    """The truth as tracks, except that person p0 changes from track 10 to track 11 half-way."""
    from trackroom.dataset import read_recording
    from trackroom.metrics.score import evaluation_frames

    rec = read_recording(rec_dir)
    times = evaluation_frames(rec)
    t_switch = float(times[len(times) // 2])
    rows = []
    for pid, g in rec.truth.people.groupby("person_id"):
        for t in times:
            k = int(np.argmin(np.abs(g["t"].to_numpy() - t)))
            tid = (10 if t < t_switch else 11) if pid == "p0" else 20
            rows.append({"t": t, "track_id": tid, "x": g["x"].iloc[k], "y": g["y"].iloc[k]})
    return pd.DataFrame(rows), t_switch, "p0"


def test_show_tracks_marks_a_constructed_identity_switch(two_walkers, tmp_path, capsys):
    import matplotlib.pyplot as plt

    from trackroom.dataset import read_recording
    from trackroom.metrics.score import evaluate
    from trackroom.topdown import draw_tracks, identity_switches

    tracks, t_switch, person = switched_tracks(two_walkers)
    rec = read_recording(two_walkers)
    sw = identity_switches(evaluate(rec, tracks))
    assert len(sw) == 1
    s = sw.iloc[0]
    assert (s["person_id"], s["previous"], s["track_id"]) == (person, 10, 11) and s["t"] == pytest.approx(t_switch)
    g = rec.truth.people[rec.truth.people["person_id"] == person]
    k = int(np.argmin(np.abs(g["t"].to_numpy() - t_switch)))
    assert np.hypot(s["x"] - g["x"].iloc[k], s["y"] - g["y"].iloc[k]) < 1e-6  # at the person's true position
    # drawn: a red cross there, labelled old -> new
    fig, ax = plt.subplots()
    assert draw_tracks(ax, rec, tracks) == 1
    marks = [ln for ln in ax.lines if ln.get_label() == "identity switch"]
    assert len(marks) == 1 and np.allclose(marks[0].get_xydata(), [[s["x"], s["y"]]])
    assert any(t.get_text() == f"{person}: 10\u219211" for t in ax.texts)
    plt.close(fig)
    # the command writes the picture next to the CSV
    csv = tmp_path / "switch.csv"
    tracks.to_csv(csv, index=False)
    assert main(["show", str(two_walkers), "--tracks", str(csv)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {tmp_path / 'switch.png'}"
    img = cv2.imread(str(tmp_path / "switch.png"))
    assert img is not None and img.shape[1] > 600
    red = (img[:, :, 2] > 200) & (img[:, :, 1] < 60) & (img[:, :, 0] < 60)
    assert red.sum() > 20  # the switch marker


@pytest.mark.parametrize("text,needle", [
    ("t,track_id,x\n0.0,1,2.0\n", "missing columns ['y']"),
    ("t,track_id,x,y\n0.0,1,abc,3.0\n", "column 'x' must hold finite numbers; line 2 has 'abc'"),
    ("", "not a readable CSV"),
    ("t,track_id,x,y\n", "no track rows to draw"),
])
def test_show_tracks_with_a_bad_csv_is_one_line(two_walkers, tmp_path, capsys, text, needle):
    csv = tmp_path / "bad.csv"
    csv.write_text(text)
    assert main(["show", str(two_walkers), "--tracks", str(csv)]) == 2
    out = capsys.readouterr()
    assert out.out == "" and needle in out.err and len(out.err.strip().splitlines()) == 1, out.err
    assert not (tmp_path / "bad.png").exists()


def test_show_tracks_needs_a_recording(tmp_path, capsys):
    assert main(["show", "overhead_lab", "--tracks", str(tmp_path / "t.csv")]) == 2
    assert "--tracks needs a recording folder" in capsys.readouterr().err
