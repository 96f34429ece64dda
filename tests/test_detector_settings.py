"""The stance detector's settings validate themselves: ``{"method": ..., "params": {...}}`` whose schema is the
registered detector class; a settings file, an API keyword and a CLI flag are checked by the same code and
refused with the same message; a settings file saved by bootnav 0.1.0 (flat ``<method>_<param>`` fields,
``tests/data/settings_saved_by_v0.1.0_2026-12-02.json``, written by ``bootnav process --save-settings``) loads
and builds the detector it built then."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

import bootnav
from bootnav.errors import InputError
from bootnav.postproc import cli_process
from bootnav.postproc.detectors import DETECTORS, DetectorSettings, parameter_fields
from bootnav.postproc.detectors.adaptive import AdaptiveDetector
from bootnav.postproc.detectors.base import ThresholdDetector
from bootnav.postproc.detectors.shoe import ShoeDetector
from bootnav.postproc.settings import ProcessSettings

SAVED = Path(__file__).parent / "data" / "settings_saved_by_v0.1.0_2026-12-02.json"


def _cli_settings(*argv: str) -> ProcessSettings:
    p = argparse.ArgumentParser()
    cli_process.add_arguments(p)
    return cli_process.build_settings(p.parse_args(["x.h5", "--out", "o", *argv]))


def test_a_settings_file_of_the_previous_version_loads_and_builds_the_same_detector():
    flat = json.loads(SAVED.read_text())["detector"]
    assert "params" not in flat and flat["method"] == "shoe"  # the old layout
    s = ProcessSettings.from_file(SAVED)
    assert s.detector.method == "shoe" and s.detector.detect_clipping is True
    assert s.detector.build(9.8) == ShoeDetector(gravity_mps2=9.8)  # every saved value was the default
    # saved again, it is in the new layout and reads back equal
    again = ProcessSettings.from_json(s.to_json())
    assert again == s and set(again.to_dict()["detector"]) == {"method", "params", "detect_clipping"}


def test_params_are_the_detector_class_fields_with_the_class_defaults():
    for name, cls in DETECTORS.items():
        s = DetectorSettings(name)
        assert set(s.params) == set(parameter_fields(cls)) and "gravity_mps2" not in s.params
        assert s.build(9.81) == cls(gravity_mps2=9.81)
    assert DetectorSettings().build(9.81) == AdaptiveDetector(gravity_mps2=9.81)


@pytest.mark.parametrize("params,message", [
    ({"threshold": -1.0}, r"params.threshold must be > 0"),
    ({"threshold": True}, r"params.threshold: expected a finite number"),
    ({"window_s": 0.0}, r"params.window_s must be > 0"),
    ({"min_stance_s": -0.1}, r"params.min_stance_s: a duration cannot be negative"),
    ({"sigma_gyro_radps": 0.0}, r"params.sigma_gyro_radps must be > 0"),
    ({"alpha": 0.3}, r"stance detector 'shoe' has no parameter\(s\) \['alpha'\]; its parameters: .*threshold"),
])
def test_file_api_keyword_and_constructor_refuse_the_same_way(params, message):
    with pytest.raises(ValueError, match=message):
        DetectorSettings("shoe", params)
    with pytest.raises(InputError, match="settings.detector: " + message):
        ProcessSettings.from_dict({"detector": {"method": "shoe", "params": params}})
    t = np.arange(400) / 100.0
    with pytest.raises(InputError, match="settings.detector: " + message):
        bootnav.process(t, np.zeros((400, 3)), np.zeros((400, 3)), detector={"method": "shoe", "params": params})


def test_cli_threshold_goes_through_the_same_validation():
    assert _cli_settings("--detector", "shoe", "--threshold", "2e5").detector.build().threshold == 2e5
    with pytest.raises(InputError, match=r"--threshold -1: params.threshold must be > 0"):
        _cli_settings("--detector", "shoe", "--threshold", "-1")
    # the default detector reads its threshold off the recording: the flag is an error, not silently ignored
    with pytest.raises(InputError, match=r"--threshold 3: stance detector 'adaptive' has no parameter\(s\) \['threshold'\]"):
        _cli_settings("--threshold", "3")
    fixed = sorted(n for n, c in DETECTORS.items() if issubclass(c, ThresholdDetector))
    assert "adaptive" not in fixed and "shoe" in fixed
    for name in fixed:
        assert _cli_settings("--detector", name, "--threshold", "0.5").detector.params["threshold"] == 0.5


def test_cli_detector_over_a_settings_file_keeps_its_params_only_for_the_same_method(tmp_path):
    f = tmp_path / "s.json"
    f.write_text(json.dumps({"detector": {"method": "shoe", "params": {"window_s": 0.04}}}))
    assert _cli_settings("--settings", str(f), "--detector", "shoe").detector.params["window_s"] == 0.04
    ared = _cli_settings("--settings", str(f), "--detector", "ared").detector
    assert ared.method == "ared" and ared.params["window_s"] == DetectorSettings("ared").params["window_s"]


def test_an_assignment_is_validated_and_a_refused_one_changes_nothing():
    s = DetectorSettings("shoe", {"threshold": 2e5})
    with pytest.raises(ValueError, match="threshold must be > 0"):
        s.params = {"threshold": -2.0}
    assert s == DetectorSettings("shoe", {"threshold": 2e5})
    s.method = "adaptive"  # another detector: its own defaults, not the old one's parameters
    assert s == DetectorSettings("adaptive")
    with pytest.raises(ValueError, match="unknown stance detector"):
        s.method = "glrt"
    assert s.method == "adaptive"


def test_api_keyword_with_another_method_starts_from_that_methods_defaults():
    from bootnav.api import _merged

    base = ProcessSettings().to_dict()
    merged = ProcessSettings.from_dict(_merged(base, {"detector": {"method": "mv"}}))
    assert merged.detector == DetectorSettings("mv")


def test_dataclasses_replace_with_another_method_gives_that_methods_defaults():
    import dataclasses

    s = DetectorSettings("adaptive", {"alpha": 0.25}, detect_clipping=False)
    shoe = dataclasses.replace(s, method="shoe")
    assert shoe == DetectorSettings("shoe", detect_clipping=False)
    assert dataclasses.replace(s, detect_clipping=True).params["alpha"] == 0.25  # same method: kept
    with pytest.raises(ValueError, match="has no parameter"):  # an explicit dict is checked, never dropped
        DetectorSettings("shoe", dict(s.params))
    assert json.loads(json.dumps(ProcessSettings(detector=s).to_dict()))["detector"]["params"]["alpha"] == 0.25
