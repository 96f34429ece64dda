"""bootnav.core: run-length phases, the time base and its gap rule, the canonical CSV reader, JSON cleaning,
rotation conversions. Expected values are worked out by hand in each test."""

import gzip
import json
import math

import numpy as np
import pytest

from bootnav.core import csvio, jsonio, rotations as rot, timebase as tb
from bootnav.core.runs import runs
from bootnav.errors import InputError

# ----------------------------------------------------------------------------------------------- runs


@pytest.mark.parametrize("mask, starts, stops", [
    ([], [], []),
    ([False] * 5, [], []),
    ([True] * 5, [0], [5]),
    ([True], [0], [1]),
    ([False], [], []),
    ([True, False, False, False], [0], [1]),  # single sample at the start
    ([False, False, True], [2], [3]),  # single sample at the end
    ([False, True, False, True, True, False, True], [1, 3, 6], [2, 5, 7]),
])
def test_runs_edge_cases(mask, starts, stops):
    a, b = runs(np.asarray(mask, dtype=bool))
    assert a.tolist() == starts and b.tolist() == stops
    assert a.dtype == np.int64 and b.dtype == np.int64


def test_runs_min_samples_and_nonzero_values():
    mask = np.array([1, 0, 2, 2, 0, 5, 5, 5], dtype=np.uint8)  # nonzero is True (e.g. saturation bit sets)
    assert [x.tolist() for x in runs(mask)] == [[0, 2, 5], [1, 4, 8]]
    assert [x.tolist() for x in runs(mask, min_samples=3)] == [[5], [8]]
    with pytest.raises(ValueError):
        runs(np.ones((2, 2), bool))


def test_runs_rebuilds_the_mask():
    mask = np.random.default_rng(3).random(10_000) < 0.3
    a, b = runs(mask)
    rebuilt = np.zeros_like(mask)
    for s, e in zip(a, b):
        rebuilt[s:e] = True
    assert np.array_equal(rebuilt, mask) and np.all(a[1:] > b[:-1])  # runs are maximal: separated by a False

# ------------------------------------------------------------------------------------------- timebase


def test_gap_rule_boundary_is_one_and_a_half_periods():
    T = 0.01
    dt = np.array([0.0149, 0.0151, 0.02, 0.0249, 0.0251, 0.1])
    assert tb.gap_mask(dt, T).tolist() == [False, True, True, True, True, True]
    assert tb.missing_samples(dt, T).tolist() == [0, 1, 1, 1, 2, 9]


def test_time_base_dt_gaps_duplicates_and_backward_time():
    t = np.array([0.0, 0.01, 0.02, 0.02, 0.03, 0.06, 0.07])
    b = tb.time_base(t)
    assert b.dt_s[0] == 0.0 and b.nominal_dt_s == pytest.approx(0.01)
    assert b.gaps == [(5, pytest.approx(0.03))] and b.n_duplicates == 1
    with pytest.raises(InputError, match="backwards at sample 2"):
        tb.time_base(np.array([0.0, 0.02, 0.01]))
    with pytest.raises(InputError, match="all timestamps are equal"):
        tb.time_base(np.zeros(3))


def test_time_events_count_missing_samples_with_the_same_rule():
    t = np.r_[np.arange(10) * 0.01, 0.09, 0.09 + np.arange(1, 5) * 0.01 + 0.02]  # one duplicate, 2 missing
    ev = tb.time_events(t, np.arange(t.size) + 2)
    kinds = {e["kind"]: e for e in ev}
    assert set(kinds) == {"duplicate_time", "gap"}
    assert kinds["gap"]["count"] == 2 and kinds["gap"]["sample_index"] == 11 and kinds["gap"]["line"] == 13


def test_unwrap_counter_across_a_wrap_and_a_reset():
    raw = np.array([2**32 - 2000, 2**32 - 1000, 0, 1000, 500, 1500], dtype=np.int64)  # wrap, then 500 µs back
    t, wraps = tb.unwrap_counter(raw)
    assert wraps.tolist() == [2]
    assert (t - t[0]).tolist() == [0, 1000, 2000, 3000, 2500, 3500]


def test_spread_coarse_seconds_puts_partial_seconds_at_their_ends():
    sec = np.repeat([10.0, 11.0, 12.0, 13.0], [2, 4, 4, 1])
    t, per_s = tb.spread_coarse_seconds(sec)
    assert per_s == 4
    assert t.tolist() == [10.5, 10.75, 11.0, 11.25, 11.5, 11.75, 12.0, 12.25, 12.5, 12.75, 13.0]


def test_timing_summary_measures_jitter_on_regular_steps_only():
    dt = np.tile([0.009, 0.011], 50)
    dt[10] = 0.05  # a gap: not jitter
    s = tb.timing_summary(np.r_[0.0, np.cumsum(dt)])
    assert s["rate_measured_hz"] == pytest.approx(1 / 0.011)  # median of 49 x 9 ms and 50 x 11 ms + the gap
    assert s["jitter_s"] == pytest.approx(0.001, rel=0.01)

# ---------------------------------------------------------------------------------------------- csvio


def _canonical_text(n: int, gyro: bool = True) -> str:
    t = np.arange(n) * 0.005
    cols = [t, 0.1 * np.sin(t), 0.2 * np.cos(t), 9.80665 + 0 * t] + ([0.01 * t, -0.02 * t, 0 * t] if gyro else [])
    head = ",".join(csvio.IMU_HEADER if gyro else csvio.ACC_HEADER)
    return head + "\n" + "\n".join(",".join(repr(float(c[i])) for c in cols) for i in range(n)) + "\n"


def test_read_imu_csv_keeps_every_value_exactly(tmp_path):
    text = _canonical_text(500)
    p = tmp_path / "imu.csv.gz"
    p.write_bytes(gzip.compress(text.encode()))
    r = csvio.read_imu_csv(p)
    expect = np.loadtxt(text.splitlines()[1:], delimiter=",")
    assert np.array_equal(r.t_s, expect[:, 0]) and np.array_equal(r.acc_mps2, expect[:, 1:4])
    assert np.array_equal(r.gyro_radps, expect[:, 4:7]) and r.bad_lines == []
    assert r.line_numbers.tolist() == list(range(2, 502))


def test_read_imu_csv_acc_only_file_has_no_gyro(tmp_path):
    p = tmp_path / "acc.csv"
    p.write_text(_canonical_text(50, gyro=False))
    r = csvio.read_imu_csv(p)
    assert r.gyro_radps is None and r.acc_mps2.shape == (50, 3)


def test_truncated_gzip_keeps_the_intact_lines_and_reports_the_cut_line(tmp_path):
    text = _canonical_text(20_000)
    z = gzip.compress(text.encode())
    p = tmp_path / "imu.csv.gz"
    p.write_bytes(z[: len(z) // 2])  # a copy interrupted half way
    r = csvio.read_imu_csv(p)
    full = np.loadtxt(text.splitlines()[1:], delimiter=",")
    n = r.t_s.size
    assert 1000 < n < 20_000
    assert np.array_equal(r.t_s, full[:n, 0]) and np.array_equal(r.gyro_radps, full[:n, 4:7])
    assert len(r.bad_lines) == 1
    line, why = r.bad_lines[0]
    assert line == n + 2 and "truncated" in why  # header is line 1, samples 2..n+1, the cut line is next


def test_bad_lines_are_skipped_with_their_numbers_and_too_many_is_one_line_error(tmp_path):
    lines = _canonical_text(200).splitlines()
    lines[10] = "0.05,1,2"  # line 11: 3 fields
    lines[20] = lines[20].replace(",", ",x", 1)  # line 21: not a number
    lines[30] = "nan," + lines[30].split(",", 1)[1]  # line 31: NaN time
    p = tmp_path / "imu.csv"
    p.write_text("\n".join(lines) + "\n")
    r = csvio.read_imu_csv(p, max_bad_fraction=0.05)
    assert [ln for ln, _ in r.bad_lines] == [11, 21, 31] and r.t_s.size == 197
    assert "3 fields" in r.bad_lines[0][1] and "not a number" in r.bad_lines[1][1] and "NaN" in r.bad_lines[2][1]
    with pytest.raises(InputError) as exc:
        csvio.read_imu_csv(p)  # 3 of 200 > 1 %
    msg = str(exc.value)
    assert "\n" not in msg and str(p) in msg and "line 11" in msg


def test_wrong_header_is_an_input_error_naming_line_1(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("time,ax,ay,az\n0,0,0,9.8\n")
    with pytest.raises(InputError, match=r"x\.csv: line 1: not a canonical IMU CSV"):
        csvio.read_imu_csv(p)

# ---------------------------------------------------------------------------------------------- jsonio


def test_to_jsonable_makes_strict_json():
    doc = {"nan": float("nan"), "inf": np.float32(np.inf), "i": np.int64(3), "arr": np.array([1.5, np.nan]),
           "big": np.zeros((10, 10)), 7: (1, np.bool_(True))}
    out = jsonio.to_jsonable(doc)
    assert json.loads(json.dumps(out, allow_nan=False)) == {
        "nan": None, "inf": None, "i": 3, "arr": [1.5, None], "big": {"shape": [10, 10], "dtype": "float64"},
        "7": [1, True]}
    assert jsonio.to_jsonable(np.zeros(100), max_array_size=None) == [0.0] * 100


def test_read_json_file_errors_name_file_and_position(tmp_path):
    p = tmp_path / "s.json"
    p.write_text('{"a": 1,\n "b": }')
    with pytest.raises(InputError, match=r"s\.json: invalid JSON at line 2 column 7"):
        jsonio.read_json_file(p, "settings file")
    with pytest.raises(InputError, match="settings file not found"):
        jsonio.read_json_file(tmp_path / "none.json", "settings file")

# ------------------------------------------------------------------------------------------- rotations

C = math.sqrt(0.5)


@pytest.mark.parametrize("rpy, q", [
    ((0.0, 0.0, 0.0), [1, 0, 0, 0]),
    ((math.pi / 2, 0.0, 0.0), [C, C, 0, 0]),  # roll 90°: half-angle 45° about x
    ((0.0, math.pi / 2, 0.0), [C, 0, C, 0]),
    ((0.0, 0.0, math.pi / 2), [C, 0, 0, C]),
    ((0.0, math.pi / 2, math.pi / 2), [0.5, -0.5, 0.5, 0.5]),  # q_z(90°) ⊗ q_y(90°), multiplied out by hand
])
def test_quat_from_euler_against_hand_computed_values(rpy, q):
    assert np.allclose(rot.quat_from_euler_zyx(*rpy), q, atol=1e-15)


def test_dcm_and_quaternion_agree_and_round_trip():
    c = rot.dcm_from_euler_zyx(0.0, math.pi / 2, math.pi / 2)
    assert np.allclose(c @ [1, 0, 0], [0, 0, -1], atol=1e-15)  # pitch 90° sends body x down; yaw keeps it there
    q = rot.quat_from_euler_zyx(0.0, math.pi / 2, math.pi / 2)
    v = rot.quat_multiply(rot.quat_multiply(q, [0, 1, 0, 0]), rot.quat_conjugate(q))
    assert np.allclose(v, [0, 0, 0, -1], atol=1e-15)
    rpy = np.array([[0.3, -0.4, 2.5], [-3.0, 1.2, -0.1]])
    assert np.allclose(rot.euler_zyx_from_quat(rot.quat_from_euler_zyx(*rpy.T)), rpy, atol=1e-12)


def test_canonical_sign_and_continuous_option():
    yaw = 1.5 * math.pi  # half angle 135°: cos < 0
    assert rot.quat_from_euler_zyx(0.0, 0.0, yaw)[0] == pytest.approx(C)
    raw = rot.quat_from_euler_zyx(0.0, 0.0, yaw, canonical=False)
    assert raw[0] == pytest.approx(-C) and raw[3] == pytest.approx(C)
    yaws = np.linspace(0, 4 * math.pi, 400)
    q = rot.quat_from_euler_zyx(0 * yaws, 0 * yaws, yaws, canonical=False)
    assert np.abs(np.diff(q, axis=0)).max() < 0.05  # no sign flip along a growing yaw


def test_atomic_write_is_all_or_nothing(tmp_path):
    from bootnav.core import atomic

    target = tmp_path / "out.csv"
    target.write_text("old\n")

    def half_then_fail(tmp):
        tmp.write_text("half")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError):
        atomic.replace_with(target, half_then_fail)
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    with pytest.raises(KeyboardInterrupt):
        with atomic.replacing(target) as f:
            f.write(b"partial")
            raise KeyboardInterrupt
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    with atomic.replacing(target, "w") as f:
        f.write("new\n")
        assert target.read_text() == "old\n"  # nothing under the name until the block ends
    assert target.read_text() == "new\n"
    atomic.write_text(tmp_path / "fresh.json", "{}\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fresh.json", "out.csv"]


def test_registry_enters_names_once_and_lists_them_for_an_unknown_one():
    from bootnav.core.registry import Registry, description

    reg = Registry("widget")

    @reg.register("a")
    class A:
        """Makes widgets of kind a.

        More text."""

    assert reg == {"a": A} and A.name == "a" and reg.get_class("a") is A and description(A) == "Makes widgets of kind a."
    with pytest.raises(ValueError, match="widget 'a' registered twice"):
        reg.register("a")(type("B", (), {}))
    with pytest.raises(ValueError, match=r"unknown widget 'c'; choose one of a$"):
        reg.get_class("c")


def test_every_registry_names_its_classes_by_their_registered_name():
    from bootnav.postproc.detectors import DETECTORS as STANCE
    from bootnav.postproc.pdr.detectors import DETECTORS as STEPS
    from bootnav.postproc.pdr.length import LENGTH_MODELS

    for reg in (STANCE, STEPS, LENGTH_MODELS):
        assert len(reg) >= 7 and all(cls.name == name for name, cls in reg.items())
    for reg in (STEPS, LENGTH_MODELS):  # the parameters saved with a PDR result
        assert all(isinstance(cls().to_dict(), dict) for cls in reg.values())
