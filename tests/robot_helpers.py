"""Test helpers: a generated 4-legged toy robot with 2-joint legs, random configurations."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml


TOY_HIP, TOY_KNEE, TOY_LINK = 0.5, -1.0, 0.15


def _toy_urdf() -> str:
    """Box body, 4 legs x (hip pitch, knee pitch) about y, links 0.15 m along -z, foot frames."""
    parts = ['<?xml version="1.0"?>\n<robot name="toy">\n<link name="trunk"><inertial><mass value="3.0"/>'
             '<origin xyz="0 0 0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/>'
             '</inertial></link>\n']
    for name, x, y in [("a", 0.2, 0.1), ("b", 0.2, -0.1), ("c", -0.2, 0.1), ("d", -0.2, -0.1)]:
        for joint, parent, child, xyz in [(f"hip_{name}", "trunk", f"thigh_{name}", f"{x} {y} 0"),
                                          (f"knee_{name}", f"thigh_{name}", f"shank_{name}",
                                           f"0 0 {-TOY_LINK}")]:
            parts.append(f'<joint name="{joint}" type="revolute"><parent link="{parent}"/>'
                         f'<child link="{child}"/><origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="0 1 0"/>'
                         f'<limit lower="-2.5" upper="2.5" effort="10" velocity="10"/></joint>\n')
            parts.append(f'<link name="{child}"><inertial><mass value="0.2"/>'
                         f'<origin xyz="0.01 0 {-TOY_LINK / 2}"/><inertia ixx="4e-4" ixy="0" ixz="0" '
                         f'iyy="4e-4" iyz="0" izz="1e-5"/></inertial></link>\n')
        parts.append(f'<joint name="toe_{name}" type="fixed"><parent link="shank_{name}"/>'
                     f'<child link="toe_{name}"/><origin xyz="0 0 {-TOY_LINK}"/></joint>\n'
                     f'<link name="toe_{name}"/>\n')
    parts.append("</robot>\n")
    return "".join(parts)


def toy_spec() -> dict:
    """robot.yaml content of the toy robot (a dict, so tests can break one field)."""
    return {
        "name": "toy",
        "legs": [{"name": n, "joints": [f"hip_{n}", f"knee_{n}"], "foot_frame": f"toe_{n}"}
                 for n in "abcd"],
        "joint_limits": {"knee_{leg}": [-2.0, -0.2]},
        "collision_spheres": [
            {"link": "trunk", "offset": [0.1, 0.0, 0.0], "radius": 0.08},
            {"link": "trunk", "offset": [-0.1, 0.0, 0.0], "radius": 0.08},
            {"link": "shank_{leg}", "offset": [0.0, 0.0, -0.07], "radius": 0.02},
            {"link": "toe_{leg}", "radius": 0.01},
        ],
        "nominal": {"base_height": 2 * TOY_LINK * math.cos(TOY_HIP), "joints": [TOY_HIP, TOY_KNEE]},
    }


def toy_centroidal() -> dict:
    """A valid `centroidal` section for the toy robot (mass = its URDF's 4.6 kg; foot c 1 cm higher)."""
    return {"mass": 3.0 + 8 * 0.2,
            "inertia": {"ixx": 0.05, "iyy": 0.12, "izz": 0.13, "ixy": 0.001, "ixz": -0.002, "iyz": 0.003},
            "nominal_feet": {"d": [-0.2, -0.1, -0.26], "a": [0.2, 0.1, -0.26], "b": [0.2, -0.1, -0.26],
                             "c": [-0.2, 0.1, -0.25]},
            "range_of_motion": [0.05, 0.04, 0.03], "max_normal_force": 100, "friction": 0.6}


def write_toy_robot(folder: Path, spec: dict | None = None) -> Path:
    """Write robot.urdf + robot.yaml of the toy robot into `folder`; returns the yaml path."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "robot.urdf").write_text(_toy_urdf())
    path = folder / "robot.yaml"
    path.write_text(yaml.safe_dump(toy_spec() if spec is None else spec))
    return path


def random_configurations(robot, rng: np.random.Generator, n: int) -> np.ndarray:
    """n configurations: random base pose (any orientation) and joints inside the limits."""
    X = np.empty((n, robot.nx))
    X[:, :3] = rng.uniform(-0.5, 0.5, (n, 3))
    axis = rng.normal(size=(n, 3))
    X[:, 3:6] = axis / np.linalg.norm(axis, axis=1, keepdims=True) * rng.uniform(0, 3.0, (n, 1))
    X[:, 6:] = rng.uniform(robot.lower, robot.upper, (n, robot.n_joints))
    return robot.from_vector(X)
