"""Small fake artefacts written with legplan.artefacts (no planner involved)."""

import numpy as np

from legplan.artefacts import write_artefact, write_dataset, write_summary


def write_map(path, bump=1.0):
    height = np.zeros((20, 30))
    height[5:10, 10:20] = 0.2 * bump
    with write_artefact(path, "map", params={"bump": bump}) as f:
        write_dataset(f, "terrain/height", height, units="m", origin=[-1.0, -0.5], resolution=0.05)
        write_dataset(f, "nav/costmap", 100 * (height > 0.1), units="", origin=[-1.0, -0.5], resolution=0.05)
        write_summary(f, {"cells_x": 30, "height_max": (height.max(), "m")})
    return path


def write_motion(path, times=(0.5, 1.5, 12.0), slips=(1e-7, 2e-7, 3e-3), success=(True, True, False),
                 shift=0.0, inputs=()):
    with write_artefact(path, "motion", params={"samples": 30}, inputs=inputs) as f:
        steps = f.create_group("steps")
        for i, (t, slip, ok) in enumerate(zip(times, slips, success)):
            g = steps.create_group(f"{i:04d}")
            g.attrs["index"] = i
            g.attrs["success"] = ok
            g.attrs["reason"] = "" if ok else "slip too large"
            g.attrs["seconds"] = t
            write_dataset(g, "control_points", np.arange(12.0).reshape(4, 3) + shift, units="m|rad")
            for name, value in (("q_start", np.zeros(3)), ("q_end", np.zeros(3)), ("footholds", np.zeros((1, 3))),
                                ("stance", np.ones(1, bool))):
                write_dataset(g, name, value)
            write_dataset(g.create_group("dense"), "foot_slip", slip, units="m")
        write_summary(f, {"steps_planned": len(times), "steps_succeeded": sum(success),
                          "worst_violation": (max(slips), "m"), "mean_time": (float(np.mean(times)), "s")})
    return path


def write_robot_motion(path, map_path, steps=3):
    """A motion of scarab2 on `map_path` (a real map): the nominal stance shifted 4 cm forward per
    step along cubic Bézier control points, the last step failed."""
    from legplan.robots import load_robot

    robot = load_robot("scarab2")
    x0 = robot.to_vector(robot.q_nominal)[0]
    feet = robot.foot_positions(robot.q_nominal)[0]
    with write_artefact(path, "motion", inputs=[map_path]) as f:
        f.attrs["robot"] = robot.name
        for i in range(steps):
            g = f.create_group(f"steps/{i:04d}")
            g.attrs.update(index=i, success=i < steps - 1, reason="" if i < steps - 1 else "clearance", seconds=0.1)
            points = np.repeat(x0[None], 4, axis=0)
            points[:, 0] += 0.04 * (i + np.linspace(0.0, 1.0, 4))
            write_dataset(g, "control_points", points)
            write_dataset(g, "q_start", robot.from_vector(points[:1])[0])
            write_dataset(g, "q_end", robot.from_vector(points[-1:])[0])
            write_dataset(g, "stance", np.ones(len(feet), bool))
            write_dataset(g, "footholds", feet)
        write_summary(f, {"steps_planned": steps, "steps_succeeded": steps - 1, "worst_violation": (4e-4, "m"),
                          "median_time": (0.1, "s")})
    return path


def write_traj(path, map_path, samples=120, duration=1.2):
    """A traj of anymal on `map_path`: the base moving forward at 0.25 m/s over `duration` s (0.3 m
    by default), all four feet in contact carrying its weight."""
    legs = 4
    t = np.linspace(0.0, duration, samples)
    base = np.stack([0.25 * t, np.zeros_like(t), np.full_like(t, 0.45)], axis=1)
    corners = np.array([[0.34, 0.19], [0.34, -0.19], [-0.34, 0.19], [-0.34, -0.19]])
    feet = np.zeros((samples, legs, 3))
    feet[:, :, :2] = corners[None] + base[:, None, :2]
    forces = np.zeros((samples, legs, 3))
    forces[:, :, 2] = 29.5 * 9.81 / legs
    with write_artefact(path, "traj", inputs=[map_path]) as f:
        f.attrs.update(robot="anymal", legs="lf,rf,lh,rh")
        g = f.create_group("tasks/0000")
        g.attrs.update(index=0, success=True, reason="converged", duration=duration, max_violation=2e-4)
        write_dataset(g, "start", [0.0, 0.0, 0.0])
        write_dataset(g, "goal", [0.25 * duration, 0.0, 0.0])
        still = np.zeros_like(base)   # velocities, accelerations, Euler angles and rates
        for name, value in {"t": t, "base_pos": base, "base_vel": still, "base_acc": still, "base_euler": still,
                            "base_euler_rate": still, "base_ang_vel": still, "base_ang_acc": still, "feet_pos": feet,
                            "feet_vel": np.zeros_like(feet), "forces": forces,
                            "contact": np.ones((samples, legs), bool)}.items():
            write_dataset(g, f"samples/{name}", value)
        ends = [0, -1]   # nodes at the start and the end: values with zero derivatives
        for block, values, legs in (("base_lin", base[ends], None), ("base_ang", still[ends], None),
                                    ("feet", feet[ends].reshape(-1, 3), np.tile(np.arange(legs), 2)),
                                    ("forces", forces[ends].reshape(-1, 3), np.tile(np.arange(legs), 2))):
            nodes = np.stack([values, np.zeros_like(values)], axis=1).reshape(-1)
            write_dataset(g, f"nodes/{block}/value", nodes)
            write_dataset(g, f"nodes/{block}/fixed", np.zeros(nodes.shape, bool))
            write_dataset(g, f"nodes/{block}/span", np.repeat(t[ends], len(values) // 2)[:, None].repeat(2, axis=1))
            if legs is not None:
                write_dataset(g, f"nodes/{block}/leg", legs)
        write_summary(f, {"tasks": 1, "succeeded": 1, "max_violation": 2e-4})
    return path


def write_sim_run(path, traj_path, map_path, fall_time=None):
    """A sim of anymal executing task 0 of `traj_path` (written by `write_traj`): the planned base and
    the joints by leg IK, sampled every 20 ms; with `fall_time`, the base drops 0.25 m after it and
    the feet lose their forces."""
    from legplan.dyn.artefact import read_tasks
    from legplan.export import traj_configurations
    from legplan.robots import load_robot
    from legplan.sim.artefact import SCALARS, write_sim

    robot = load_robot("anymal")
    samples = read_tasks(traj_path)[1][0]["samples"]
    t = np.arange(0.0, float(samples["t"][-1]) + 1e-9, 0.02)
    base_pos, base_quat, joints, _ = traj_configurations(robot, samples, t)
    forces = np.zeros((len(t), robot.n_legs, 3))
    forces[:, :, 2] = 29.5 * 9.81 / robot.n_legs
    fell = fall_time is not None
    if fell:
        after = t >= fall_time
        base_pos[after, 2] -= 0.25
        forces[after] = 0.0
    zeros = np.zeros((len(t), 3))
    series = {"t": t, "base_pos": base_pos, "base_quat": base_quat, "base_vel": zeros, "base_ang_vel": zeros,
              "joint_pos": joints, "joint_vel": np.zeros_like(joints), "torque": np.zeros_like(joints),
              "foot_forces": forces, "position_error": np.zeros(len(t)), "orientation_error": np.zeros(len(t))}
    scalars = dict.fromkeys(SCALARS, 0.0)
    scalars["fall_time"] = float(fall_time) if fell else float("nan")
    record = {"index": 0, "planned": True, "skipped": False, "success": not fell,
              "reason": "fell" if fell else "reached the goal", "fell": fell, "unplanned_contacts": "",
              **scalars, "series": series}
    write_sim(path, [record], {"fake": True}, robot, inputs=[traj_path, map_path])
    return path
