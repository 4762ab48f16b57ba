"""Tracker readings as CSV, and judging readings already taken (no new measurements)."""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.io.tracker_csv import TrackerReadings, read_tracker_csv, write_tracker_csv
from rmbench.tracker import judge_readings, reading_errors, register_readings

HEADER = "location,q_j1,q_j2,x,y,z,x_nom,y_nom,z_nom"


def readings(n=4, sigma=True):
    rng = np.random.default_rng(0)
    return TrackerReadings(np.repeat(np.arange(n // 2), 2), ("j1", "j2"),
                           np.repeat(rng.normal(size=(n // 2, 2)), 2, axis=0), rng.normal(size=(n, 3)),
                           rng.normal(size=(n, 3)), np.full((n, 3), 5e-5) if sigma else None,
                           ("units: rad, m",))


def test_csv_round_trip_keeps_every_value(tmp_path):
    path = tmp_path / "r.csv"
    original = readings()
    write_tracker_csv(path, original)
    back = read_tracker_csv(path)
    assert back.joints == ("j1", "j2") and back.comments == ("units: rad, m",)
    for name in ("location", "q", "measured", "nominal", "sigma"):
        assert np.array_equal(getattr(back, name), getattr(original, name))


def test_csv_round_trip_keeps_time_and_temperature_and_allows_no_model_columns(tmp_path):
    from dataclasses import replace

    path = tmp_path / "r.csv"
    original = replace(readings(), nominal=None, t=np.arange(4) * 15.0,
                       temperature=np.array([20.0, 20.5, 21.0, 21.2]))
    write_tracker_csv(path, original)
    back = read_tracker_csv(path)
    assert back.nominal is None
    for name in ("t", "temperature", "measured"):
        assert np.array_equal(getattr(back, name), getattr(original, name))


@pytest.mark.parametrize("text, message", [
    ("location,q_j1,q_j2,x,y,x_nom,y_nom,z_nom\n0,0,0,1,2,1,2,3\n", "missing column.*z"),
    (HEADER.replace(",z_nom", "") + "\n0,0,0,1,2,3,1,2\n", "all of x_nom, y_nom, z_nom or none"),
    ("location,x,y,z,x_nom,y_nom,z_nom\n0,1,2,3,1,2,3\n", r"no joint columns"),
    (HEADER + "\n0,0.1,0.2,1,nan,3,1,2,3\n", "line 2: column y is 'nan', not finite"),
    (HEADER + "\n0,0.1,0.2,1,,3,1,2,3\n", "line 2: column y is not a number"),
    (HEADER + "\n0,0.1,0.2,1,2,3,1,2\n", "line 2: 8 fields, expected 9"),
    (HEADER + ",sigma_x,sigma_y,sigma_z\n0,0.1,0.2,1,2,3,1,2,3,1e-5,0,1e-5\n",
     "sigma must be finite and > 0"),
    (HEADER + ",sigma_x\n0,0.1,0.2,1,2,3,1,2,3,1e-5\n", "all of sigma_x, sigma_y, sigma_z or none"),
    (HEADER + "\n0,0.1,0.2,1,2,3,1,2,3\n0,0.3,0.2,1,2,3,1,2,3\n", "different joint angles"),
], ids=["missing-column", "nominal-partial", "no-joints", "nan", "empty-field", "short-row", "sigma-zero",
        "sigma-partial", "inconsistent-location"])
def test_malformed_csv_is_refused_with_a_clear_message(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_tracker_csv(path)


def test_registration_removes_a_rigid_transform_between_model_and_tracker():
    rng = np.random.default_rng(1)
    nominal = rng.uniform(-1, 1, (20, 3))
    rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rot *= np.sign(np.linalg.det(rot))
    measured = nominal @ rot.T + [3.0, -1.0, 0.5]
    assert np.max(np.abs(register_readings(measured, nominal))) < 1e-12


def test_reading_errors_without_registration_are_measured_minus_nominal():
    measured, nominal = np.array([[1.0, 2.0, 3.0], [0.5, 0.0, -1.0]]), np.array([[1.0, 1.5, 3.5], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(reading_errors(measured, nominal, register=False), measured - nominal)


def test_reading_errors_with_registration_are_the_registered_ones():
    rng = np.random.default_rng(2)
    nominal = rng.uniform(-1, 1, (12, 3))
    measured = nominal + [0.2, 0.0, -0.1] + rng.normal(0, 1e-3, (12, 3))
    np.testing.assert_array_equal(reading_errors(measured, nominal), register_readings(measured, nominal))


def test_judging_lists_the_locations_the_sequential_test_would_remeasure():
    # η = 1, σ = 0.1: location 7 reads 1.3 (p* ≈ 0.997), location 3 reads 1.1 (p* = 0.68); the
    # others are inside. P* > 0.9; re-measuring location 7 alone would bring P* to 0.68 ≤ α.
    loc = np.array([3, 5, 7, 9])
    judged = judge_readings(loc, np.array([1.1, 0.2, 1.3, -0.5]), np.full(4, 0.1), 1.0, 0.9,
                            max_per_location=10)
    assert judged.result.rejected and judged.to_remeasure.tolist() == [7]
    assert not judged.conclusive


def test_judging_is_conclusive_when_the_location_to_remeasure_is_at_its_cap():
    judged = judge_readings(np.array([0, 0, 1]), np.array([1.5, 1.5, 0.0]), np.full(3, 0.1), 1.0,
                            0.9, max_per_location=2)
    assert judged.result.rejected and judged.at_cap.tolist() == [True] and judged.conclusive


def test_judging_refuses_non_positive_sigma():
    with pytest.raises(InputError, match="sigma finite and > 0"):
        judge_readings(np.array([0]), np.array([0.1]), np.array([0.0]), 1.0)
