"""The robot's links in the report's 3D views: skeleton and link placements by forward kinematics."""

import numpy as np
import pinocchio as pin

from legplan.report.links import links_frames, links_static, _shape
from legplan.robots import load_robot
from legplan.robots.urdf import Primitive


def test_skeleton_ends_at_the_feet_and_starts_at_the_hips():
    robot = load_robot("anymal")
    q = np.array(robot.q_nominal, float)
    q[0] += 0.3
    q[7:] += np.linspace(-0.2, 0.2, robot.nq - 7)
    frame = links_frames(robot, q[None])[0]
    static = links_static(robot)
    skeleton = np.array(frame["k"]).reshape(-1, 3) / 1000
    ends = np.cumsum(static["legs"]) - 1
    assert np.allclose(skeleton[ends], robot.foot_positions(q[None])[0], atol=1e-3)
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    hips = [robot.model.getJointId(leg.joint_names[0]) for leg in robot.legs]
    assert np.allclose(skeleton[ends - np.array(static["legs"]) + 1], [data.oMi[j].translation for j in hips], atol=1e-3)


def test_shapes_are_placed_in_their_link_frame():
    placement = pin.SE3(pin.rpy.rpyToMatrix(np.array([0.0, 0.0, np.pi / 2])), np.array([0.1, 0.0, -0.2]))
    box = _shape(Primitive("box", (0.4, 0.2, 0.1), placement))
    assert np.allclose(np.ptp(box["v"], axis=0), [0.2, 0.4, 0.1]) and len(box["f"]) == 6
    assert np.allclose(box["v"].mean(axis=0), [0.1, 0.0, -0.2])
    cylinder = _shape(Primitive("cylinder", (0.05, 0.3), pin.SE3.Identity()))
    assert np.allclose(np.ptp(cylinder["v"], axis=0), [0.1, 0.1, 0.3])
    assert all(max(face) < len(cylinder["v"]) for face in cylinder["f"])
    sphere = _shape(Primitive("sphere", (0.02,), placement))
    assert sphere["r"] == 0.02 and np.allclose(sphere["v"], [0.1, 0.0, -0.2])


def test_dyn_scene_legs_reach_the_planned_feet(tmp_path, flat_terrain):
    """The dyn plan holds no joints: the drawn legs come from leg IK and must end at the planned feet
    (lifted by the foot sphere's radius, the foot frame's place)."""
    from fake_artefacts import write_traj

    from legplan.export import foot_radii
    from legplan.report.scene import traj_scene
    from legplan.terrain.terrain_map import save_map

    flat = tmp_path / "flat.h5"
    save_map(flat_terrain, flat)
    scene = traj_scene(write_traj(tmp_path / "traj.h5", flat, samples=20))
    robot = load_robot("anymal")
    ends = np.cumsum(scene["links"]["legs"]) - 1
    for frame in scene["frames"]:
        feet = np.array(frame["s"]).reshape(-1, 3) / 1000
        drawn = (np.array(frame["k"]).reshape(-1, 3) / 1000)[ends]
        assert np.abs(drawn - feet - foot_radii(robot)[:, None] * [0, 0, 1]).max() < 3e-3


def test_published_robot_links_carry_their_urdf_shapes(tmp_path):
    """anymal_b (example-robot-data) has collision geometry: every link with a shape is sent once
    with its polyhedra, and each frame places it where pinocchio's FK puts its link frame."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location("published_robots", Path(__file__).parents[1] / "sim" / "published_robots.py")
    published = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(published)
    robot = load_robot(published.draft("anymal_b", tmp_path / "anymal_b"), strict=False)
    static = links_static(robot)
    assert len(static["shapes"]) >= 8 and all(("f" in s) != ("r" in s) for s in static["shapes"])
    assert len(set(static["colours"])) == 5                   # the base's grey and one colour per leg
    q = np.array(robot.q_nominal, float)
    q[7:] += 0.2
    placements = np.array(links_frames(robot, q[None])[0]["l"]).reshape(-1, 7)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    shank = robot.model.getFrameId("LF_SHANK")
    from legplan.report.links import _link_shapes

    index = list(_link_shapes(robot)[0]).index(shank)
    assert np.allclose(placements[index, :3] / 1000, data.oMf[shank].translation, atol=1e-3)
    quat = placements[index, 3:] / 1e4
    assert np.allclose(pin.Quaternion(quat[3], *quat[:3]).normalized().matrix(), data.oMf[shank].rotation, atol=1e-3)
