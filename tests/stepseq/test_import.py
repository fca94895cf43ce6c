import csv
import json

import numpy as np
import pytest

from legplan.errors import SpecError
from legplan.stepseq import import_steps, sequence_records, StepSequence
from legplan.stepseq.robotinfo import robot_sha256, urdf_joint_order


def _base_records(robot):
    """Three valid configurations: all legs down, leg lm lifted 4 cm, all down again."""
    q = robot.q_nominal.copy()
    feet = robot.foot_positions(q)[0]
    stance = np.ones((3, robot.n_legs), bool)
    stance[1, 1] = False
    Q = np.repeat(q[None], 3, axis=0)
    Q[1, 7 + 4] = 0.35  # femur_lm up: foot off the ground
    seq = StepSequence(q=Q, stance=stance, footholds=np.where(stance[..., None], feet, np.nan),
                       robot=robot.name, robot_sha256="", leg_names=[l.name for l in robot.legs],
                       joint_names=robot.joint_names)
    return sequence_records(seq)


def _write_csv(path, records):
    header = list(dict.fromkeys(k for r in records for k in r))
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in records:
            w.writerow(["" if (v := r.get(k)) is None or (isinstance(v, float) and np.isnan(v)) else v
                        for k in header])
    return path


def _import(tmp_path, robot, validator, records, name="steps.csv"):
    path = tmp_path / name
    if name.endswith(".csv"):
        _write_csv(path, records)
    else:
        path.write_text(json.dumps({"configurations": records}))
    return import_steps(path, robot, validator, urdf_order=urdf_joint_order(robot),
                        robot_sha256=robot_sha256(robot))


def _issues(result, severity="error"):
    return [(i.row, i.field) for i in result.issues if i.severity == severity]


def test_valid_records_import_without_issues(tmp_path, scarab, validator):
    result = _import(tmp_path, scarab, validator, _base_records(scarab))
    assert result.issues == []
    assert result.sequence.stance.sum(axis=1).tolist() == [6, 5, 6]
    assert np.isnan(result.sequence.footholds[1, 1]).all()


def test_wrong_dimension_and_unknown_joint(tmp_path, scarab, validator):
    records = _base_records(scarab)
    del records[0]["tibia_rr"]
    records[2]["tibia_xx"] = 0.0
    result = _import(tmp_path, scarab, validator, records)
    assert (0, "tibia_rr") in _issues(result)
    assert (2, "tibia_xx") in _issues(result)
    assert result.sequence is None


def test_joints_as_urdf_ordered_list_with_wrong_length(tmp_path, scarab, validator):
    records = _base_records(scarab)
    for r in records:
        values = [r.pop(n) for n in urdf_joint_order(scarab)]
        r["joints"] = values
    records[1]["joints"] = records[1]["joints"][:-1]
    result = _import(tmp_path, scarab, validator, records, name="steps.json")
    assert _issues(result) == [(1, "joints")]


def test_quaternion_norm_error_and_normalisation_warning(tmp_path, scarab, validator):
    records = _base_records(scarab)
    records[0]["qw"] = 1.0 + 5e-7
    records[2]["qw"] = 1.01
    result = _import(tmp_path, scarab, validator, records)
    assert _issues(result) == [(2, "qw")]
    records[2]["qw"] = 1.0
    result = _import(tmp_path, scarab, validator, records)
    assert _issues(result) == []
    assert _issues(result, "warning") == [(0, "qw")]
    assert [(i.row, i.field) for i in result.errors(strict=True)] == [(0, "qw")]
    np.testing.assert_allclose(np.linalg.norm(result.sequence.q[0, 3:7]), 1.0, atol=1e-15)


def _rz_ry_rx(roll, pitch, yaw):
    """R = Rz(yaw) Ry(pitch) Rx(roll), written out from the elementary rotations."""
    c, s = np.cos, np.sin
    rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    ry = np.array([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    rz = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    return rz @ ry @ rx


def _quaternion_matrix(q):
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_rpy_orientation_is_rz_ry_rx(tmp_path, scarab, validator):
    angles = [(0.0, 0.0, 0.0), (0.3, -0.2, 1.1), (-0.25, 0.15, -2.4)]  # distinct roll, pitch, yaw
    records = _base_records(scarab)
    for r, (roll, pitch, yaw) in zip(records, angles):
        for k in ("qx", "qy", "qz", "qw"):
            r.pop(k)
        r.update(roll=roll, pitch=pitch, yaw=yaw)
    result = _import(tmp_path, scarab, validator, records)
    assert result.sequence is not None  # tilted rows may have physical issues, the orientation parsed
    for q, (roll, pitch, yaw) in zip(result.sequence.q, angles):
        np.testing.assert_allclose(_quaternion_matrix(q[3:7]), _rz_ry_rx(roll, pitch, yaw), atol=1e-12)
    swapped = _rz_ry_rx(1.1, -0.2, 0.3)  # roll and yaw exchanged must not match
    assert np.abs(_quaternion_matrix(result.sequence.q[1, 3:7]) - swapped).max() > 0.1


def test_joint_outside_limits(tmp_path, scarab, validator):
    records = _base_records(scarab)
    records[1]["coxa_rf"] = 0.6
    assert (1, "coxa_rf") in _issues(_import(tmp_path, scarab, validator, records))


def test_stance_foot_off_the_terrain(tmp_path, scarab, validator):
    records = _base_records(scarab)
    records[1]["z"] += 0.005  # every stance foot 5 mm up
    issues = _issues(_import(tmp_path, scarab, validator, records))
    assert (1, "stance_lf") in issues and (1, "stance_lm") not in issues  # lm is swing


def test_fewer_than_three_stance_legs(tmp_path, scarab, validator):
    records = _base_records(scarab)
    for r in records:  # the same two stance legs in every row: no stance-set change to report
        for leg in ("lf", "lm", "lr", "rm"):
            r[f"stance_{leg}"] = 0
    result = _import(tmp_path, scarab, validator, records)
    count_errors = [i for i in result.issues if i.field == "stance" and i.severity == "error"]
    assert [i.row for i in count_errors] == [0, 1, 2]
    assert all("2 stance legs, at least 3" in i.message for i in count_errors)


def test_com_outside_support_polygon(tmp_path, scarab, validator):
    records = _base_records(scarab)
    for leg in ("lf", "lm", "lr"):  # only the right legs down: CoM outside their triangle
        records[1][f"stance_{leg}"] = 0
    for leg in ("lf", "lr"):
        records[0][f"stance_{leg}"] = 0
        records[2][f"stance_{leg}"] = 0
    records[1]["femur_lm"] = -0.2
    issues = _issues(_import(tmp_path, scarab, validator, records))
    assert (1, "com") in issues


def test_collision_with_the_terrain(tmp_path, scarab, validator):
    records = _base_records(scarab)
    records[1]["femur_lm"] = -0.6  # swing foot pushed 4+ cm into the ground
    issues = _issues(_import(tmp_path, scarab, validator, records))
    assert (1, "spheres") in issues


def test_stance_sets_differing_in_two_legs(tmp_path, scarab, validator):
    records = _base_records(scarab)
    records[1]["stance_rm"] = 0
    records[1]["femur_rm"] = 0.35
    issues = _issues(_import(tmp_path, scarab, validator, records))
    assert (1, "stance") in issues and (2, "stance") in issues


def test_unreadable_files_name_the_file(tmp_path, scarab, validator):
    bad = tmp_path / "steps.json"
    bad.write_text("{not json")
    with pytest.raises(SpecError, match="steps.json"):
        import_steps(bad, scarab, validator, urdf_order=urdf_joint_order(scarab), robot_sha256="")
    with pytest.raises(SpecError, match="unknown step-sequence format"):
        import_steps(tmp_path / "steps.txt", scarab, validator, urdf_order=(), robot_sha256="")
