"""The URDF text MuJoCo's URDF parser is given: `prepare_urdf(path, urdf_collision, package_paths)`.

A typical ROS URDF (example-robot-data's ANYmal, HyQ, Go1, Solo) does not compile in MuJoCo as it
is: meshes named `package://…`, massless or dummy links whose inertia MuJoCo calls invalid, collision
geometry that would touch the terrain where robot.yaml's spheres already do. The URDF on disk is
never edited; the text handed to `mujoco.MjSpec.from_string` is, by these rules:

- Contact policy: robot.yaml's collision spheres are the robot's contacts (`legplan.sim.model`).
  The URDF's `<visual>` geometry is dropped; its `<collision>` geometry too unless `urdf_collision`
  (then its meshes are resolved by `legplan.robots.packages.resolve_uri` and must exist).
- Inertia: MuJoCo needs each massive body's principal moments positive and satisfying the triangle
  inequality (A + B ≥ C). A link whose `<inertial>` breaks that gets the nearest such moments on the
  same principal axes: the smaller two raised to half the largest, a zero tensor replaced by a solid
  sphere's of radius `INERTIA_RADIUS` with the link's mass. The links changed are listed in one
  warning. A negative or non-finite mass or inertia cannot be repaired: `LegplanError`.
- Armature: URDF has no field for it; Drake's extension (`<transmission><actuator>` with
  `drake:rotor_inertia` and `drake:gear_ratio`) gives the reflected rotor inertia
  rotor_inertia × gear_ratio² of the transmission's joint.
- `<gazebo>` and `<transmission>` elements (simulator plug-ins, ignored by MuJoCo) are dropped.
- The compiler element: `fusestatic` off (fixed-joint foot links stay bodies for robot.yaml's
  spheres), `inertiafromgeom` off (the URDF's inertials are the masses, as in pinocchio's model),
  `strippath` off (mesh paths are absolute after resolution), `balanceinertia` off (repaired here,
  with the warning).
Joint `<dynamics damping friction>` are read by MuJoCo's parser itself (joint damping and
friction loss).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from legplan.errors import LegplanError
from legplan.robots.packages import UnresolvedUri, resolve_uri
from legplan.specio import read_text

INERTIA_RADIUS = 0.01   # m, the sphere whose inertia replaces a zero tensor of a massive link
COMPILER = {"fusestatic": "false", "discardvisual": "true", "balanceinertia": "false",
            "inertiafromgeom": "false", "strippath": "false"}
_INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")


@dataclass(frozen=True)
class PreparedUrdf:
    """The text for MuJoCo, the warnings of the repairs, and the armature (kg m²) by joint name."""

    text: str
    warnings: tuple[str, ...] = ()
    armature: dict = field(default_factory=dict)


def physical_moments(moments: np.ndarray, mass: float) -> np.ndarray:
    """Principal moments (ascending) MuJoCo accepts, as close to `moments` as the rule of the module
    docstring allows; unchanged when they are already physical."""
    if moments[2] <= 0:
        return np.full(3, 0.4 * mass * INERTIA_RADIUS ** 2)
    return np.maximum(moments, moments[2] / 2) if moments[0] <= 0 or moments[0] + moments[1] < moments[2] \
        else moments


def _repair_inertial(path: Path, link: str, inertial) -> bool:
    """Make one `<inertial>` physical in place; whether it changed."""
    mass_element, tensor = inertial.find("mass"), inertial.find("inertia")
    try:
        mass = float(mass_element.get("value")) if mass_element is not None else 0.0
        values = {k: float(tensor.get(k, 0.0)) for k in _INERTIA_KEYS} if tensor is not None else \
            dict.fromkeys(_INERTIA_KEYS, 0.0)
    except (TypeError, ValueError):
        raise LegplanError(f"{path}: link {link!r}: <inertial> mass or inertia is not a number") from None
    if not (math.isfinite(mass) and all(map(math.isfinite, values.values()))) or mass < 0:
        raise LegplanError(f"{path}: link {link!r}: <inertial> mass {mass} or inertia is negative or not finite; "
                           "MuJoCo cannot simulate it and there is nothing to repair it from")
    if mass == 0:
        return False
    matrix = np.array([[values["ixx"], values["ixy"], values["ixz"]],
                       [values["ixy"], values["iyy"], values["iyz"]],
                       [values["ixz"], values["iyz"], values["izz"]]])
    moments, axes = np.linalg.eigh(matrix)
    fixed = physical_moments(moments, mass)
    if np.array_equal(fixed, moments):
        return False
    repaired = axes @ np.diag(fixed) @ axes.T
    if tensor is None:
        tensor = ET.SubElement(inertial, "inertia")
    for key, (i, j) in zip(_INERTIA_KEYS, ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))):
        tensor.set(key, repr(float(repaired[i, j])))
    return True


def _armature(root) -> dict:
    """Drake's rotor inertia × gear ratio² per transmission joint (module docstring)."""
    def number(element, default):
        if element is None:
            return default
        return float(element.get("value", element.text or default))

    out = {}
    for transmission in root.iter("transmission"):
        joint = transmission.find("joint")
        for actuator in transmission.findall("actuator"):
            rotor = next((e for e in actuator if e.tag.endswith("rotor_inertia")), None)
            gear = next((e for e in actuator if e.tag.endswith("gear_ratio")), None)
            if rotor is not None and joint is not None:
                out[joint.get("name")] = number(rotor, 0.0) * number(gear, 1.0) ** 2
    return out


def prepare_urdf(path, urdf_collision: bool = False, package_paths=()) -> PreparedUrdf:
    """The URDF at `path` as MuJoCo's parser gets it (module docstring)."""
    path = Path(path)
    try:
        root = ET.fromstring(read_text(path, "URDF"))
    except ET.ParseError as exc:
        raise LegplanError(f"{path}: not a readable URDF ({exc})") from None
    if root.tag != "robot":
        raise LegplanError(f"{path}: not a URDF (root element <{root.tag}>, expected <robot>)")
    try:
        armature = _armature(root)
    except ValueError:
        raise LegplanError(f"{path}: <transmission>: drake:rotor_inertia or drake:gear_ratio is not a number") \
            from None
    repaired = []
    for link in root.iter("link"):
        name = link.get("name")
        for element in list(link):
            if element.tag == "visual" or (element.tag == "collision" and not urdf_collision):
                link.remove(element)
        for mesh in link.iterfind("collision/geometry/mesh"):
            try:
                mesh.set("filename", str(resolve_uri(mesh.get("filename", ""), path, package_paths)))
            except UnresolvedUri as exc:
                raise LegplanError(f"{path}: link {name!r}: collision mesh {exc}; give the package's folder with "
                                   "--package-path or ROS_PACKAGE_PATH") from None
        inertial = link.find("inertial")
        if inertial is not None and _repair_inertial(path, name, inertial):
            repaired.append(name)
    for element in list(root):
        if element.tag in ("gazebo", "transmission", "mujoco"):
            root.remove(element)
    mujoco_element = ET.Element("mujoco")
    ET.SubElement(mujoco_element, "compiler", COMPILER)
    root.insert(0, mujoco_element)
    warnings = ()
    if repaired:
        warnings = (f"{path}: inertia of link(s) {', '.join(repaired)} not physical for MuJoCo (principal moments "
                    f"must be positive with A + B >= C): the smaller moments raised to half the largest, a zero "
                    f"tensor replaced by a {INERTIA_RADIUS * 100:g} cm sphere's; the controller keeps the URDF's",)
    return PreparedUrdf(ET.tostring(root, encoding="unicode"), warnings, armature)
