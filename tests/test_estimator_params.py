"""Estimator parameters: every Config field documented (type, default, one-line doc) and listed by
`trackroom estimators`; values parsed strictly by the field's type from the command line, from
dicts (compare TOML) and from the name[k=v] syntax."""
from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import pytest

from trackroom.cli import main
from trackroom.compare import parse_estimator
from trackroom.estimators import available, get
from trackroom.estimators.base import EstimatorError, coerce_param, coerce_value
from trackroom.estimators.runner import parse_params

ROOT = Path(__file__).resolve().parents[1]


def test_every_config_field_has_a_doc():
    undocumented = [f"{name}.{f.name}" for name, cls in available().items() for f in dataclasses.fields(cls.Config)
                    if not str(f.metadata.get("doc", "")).strip()]
    assert not undocumented, f"Config fields without metadata={{'doc': ...}}: {undocumented}"


def test_every_config_default_is_of_its_fields_type():
    """A default that is not of its field's type is refused, as a value given for it would be (a
    stray trailing comma after ``param(True, ...)`` makes the default a tuple, which is truthy and
    would silently turn an option on)."""
    wrong = []
    for name, cls in available().items():
        for f in dataclasses.fields(cls.Config):
            if f.default is dataclasses.MISSING:
                continue
            try:
                coerce_value(cls, f.name, f.default)
            except EstimatorError as e:
                wrong.append(str(e))
    assert not wrong, wrong
    with pytest.raises(EstimatorError, match="expected true or false"):
        coerce_value(get("target_planes"), "merged_evidence", (True,))


def test_listing_prints_every_parameter():
    r = subprocess.run([sys.executable, "-m", "trackroom", "estimators"], capture_output=True, text=True, cwd=ROOT,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    for name, cls in available().items():
        assert f"\n{name}  (bundled)\n" in r.stdout
        block = r.stdout.split(f"\n{name}  (bundled)\n")[1].split("\n\n")[0]
        for f in dataclasses.fields(cls.Config):
            line = next((ln for ln in block.splitlines() if ln.split()[:1] == [f.name]), None)
            assert line is not None, f"{name}.{f.name} not listed"
            assert f.metadata["doc"] in line  # with its doc, on its own line
    assert "needs: floor_detections and imu observations" in r.stdout  # hmm_matcher
    assert "needs: floor_detections or bearings observations" in r.stdout  # ekf
    assert "file: path to a gait-model JSON" in r.stdout  # a parameter that takes a file says so


def test_estimate_list_is_the_listing(capsys):
    assert main(["estimate", "--list"]) == 0
    out = capsys.readouterr().out
    assert main(["estimators"]) == 0
    assert capsys.readouterr().out == out and "target_planes  (bundled)" in out


@pytest.mark.parametrize("name,key,text,value", [
    ("ekf", "smooth", "true", True), ("ekf", "smooth", "FALSE", False), ("ekf", "confirm_m", "4", 4),
    ("ekf", "accel_psd", "1", 1.0), ("ekf", "accel_psd", "2.5e-1", 0.25), ("ekf", "filter", "ukf", "ukf"),
    ("ekf", "filter", '"ukf"', "ukf"), ("qp_smoother", "sigma_px", "none", None), ("qp_smoother", "sigma_px", "2", 2.0),
    ("target_planes", "initial_xy", "[1, 2.5]", [1.0, 2.5]), ("target_planes", "initial_xy", "None", None),
    ("target_planes", "initial_window", '["cam_a", 1, 2, 3, 4]', ["cam_a", 1, 2, 3, 4]),
    ("hmm_matcher", "gait_model", "gait.json", "gait.json"),
])
def test_command_line_values_parse_by_type(name, key, text, value):
    got = coerce_param(get(name), key, text)
    assert got == value and type(got) is type(value)


@pytest.mark.parametrize("name,key,text,expected", [
    ("ekf", "smooth", "maybe", "expected true or false, got 'maybe'"),
    ("ekf", "smooth", "1", "expected true or false, got '1'"),
    ("ekf", "confirm_m", "2.5", "expected an integer, got '2.5'"),
    ("ekf", "confirm_m", "true", "expected an integer, got 'true'"),
    ("ekf", "accel_psd", "nan", "expected a finite number, got 'nan'"),
    ("ekf", "accel_psd", "inf", "expected a finite number, got 'inf'"),
    ("ekf", "accel_psd", "fast", "expected a finite number, got 'fast'"),
    ("qp_smoother", "sigma_px", "wide", "expected a finite number or none, got 'wide'"),
    ("target_planes", "initial_xy", "3", "expected a list such as [1.0, 1.0] or none, got '3'"),
    ("target_planes", "initial_xy", "[1, true]", "expected a list such as [1.0, 1.0] (item 2: expected a finite number)"),
    ("ekf", "no_such", "1", "unknown parameter 'no_such'"),
])
def test_bad_command_line_values_are_refused(name, key, text, expected):
    with pytest.raises(EstimatorError, match=f"^{name}: .*{re.escape(expected)}"):
        coerce_param(get(name), key, text)


def test_dict_values_are_checked_too():
    ekf = get("ekf")
    assert parse_params(ekf, {"smooth": True, "accel_psd": 1, "confirm_m": 2}) == {"smooth": True, "accel_psd": 1.0,
                                                                                 "confirm_m": 2}
    for key, bad, expected in (("smooth", "yes", "expected true or false, got 'yes'"), ("smooth", 1, "true or false"),
                               ("confirm_m", 2.0, "an integer"), ("accel_psd", True, "a finite number"),
                               ("filter", 3, "expected text, got 3")):
        with pytest.raises(EstimatorError, match=expected):
            parse_params(ekf, {key: bad})
        with pytest.raises(EstimatorError, match=expected):
            ekf(**{key: bad})  # the constructor checks as well: Python callers get the same
    assert coerce_value(get("target_planes"), "initial_xy", (1, 2)) == [1.0, 2.0]


def test_name_brackets_syntax_is_strict():
    e = parse_estimator("target_planes[initial_xy=[1, 2];multi_person=true]")
    assert dict(e.params) == {"initial_xy": [1.0, 2.0], "multi_person": True}
    assert dict(parse_estimator("ekf[smooth=true,filter=ukf]").params) == {"smooth": True, "filter": "ukf"}
    with pytest.raises(EstimatorError, match="ekf: parameter smooth: expected true or false, got 'maybe'"):
        parse_estimator("ekf[smooth=maybe]")


def test_bad_param_on_the_command_line_exits_2_with_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-m", "trackroom", "estimate", str(tmp_path), "--estimator", "ekf",
                        "--param", "smooth=maybe", "--out", str(tmp_path / "t.csv")],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == ["trackroom estimate: error: ekf: parameter smooth: expected true or false, got 'maybe'"]


def test_a_parameter_without_default_must_be_given():
    from trackroom.estimators.base import Estimator

    class NeedsK(Estimator):  # not registered: the constructor alone is under test
        name = "needs_k"

        @dataclasses.dataclass
        class Config:
            k: int

    with pytest.raises(EstimatorError, match=r"needs_k: give parameter\(s\) \['k'\]"):
        NeedsK()
    assert NeedsK(k=3).config.k == 3
