"""What pinocchio's kinematic model does not keep from a URDF: each link's own inertial and its
primitive geometry (box, cylinder, sphere), read from the XML.

Used to draft a robot.yaml (`legplan.robots.draft`) and to check one (`legplan.robots.check`).
Meshes are listed by link but not read (their extent would need the mesh files).

`build_free_flyer_model` is the one place a URDF is parsed by pinocchio: urdfdom prints its parse
errors straight to file descriptor 2, so they are captured and folded into `UrdfParseError`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import logging

import numpy as np
import pinocchio as pin

from legplan.errors import SpecError
from legplan.native_stderr import captured_stderr
from legplan.specio import read_text

log = logging.getLogger("legplan.robots")


class UrdfParseError(ValueError):
    """pinocchio cannot build a model from a URDF; the message holds its reason and urdfdom's."""


def build_free_flyer_model(path: str | Path) -> pin.Model:
    """pinocchio's model of the URDF at `path` on a free-flyer root. urdfdom's own stderr lines
    never reach the terminal: on failure the first is part of the `UrdfParseError`, otherwise they
    go to the debug log."""
    try:
        with captured_stderr() as parser_output:
            model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    except (RuntimeError, ValueError) as exc:
        detail = "; ".join([str(exc).splitlines()[0], *parser_output.lines[:1]])
        raise UrdfParseError(" ".join(detail.split())) from None
    for line in parser_output.lines:
        log.debug("urdfdom: %s", line)
    return model


@dataclass(frozen=True)
class Primitive:
    """A box (size: 3 edge lengths), cylinder (radius, length along its z) or sphere (radius), placed
    at `placement` in its link frame."""

    kind: str
    size: tuple[float, ...]
    placement: pin.SE3

    def extreme_points(self) -> np.ndarray:
        """(k, 3) points in the link frame that bound the shape (corners, cap rims, axis poles)."""
        if self.kind == "box":
            half = np.array(self.size) / 2
            local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
        elif self.kind == "cylinder":
            radius, length = self.size
            angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
            rim = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(8)], axis=1)
            local = np.vstack([rim + [0, 0, length / 2], rim - [0, 0, length / 2],
                               [[0, 0, length / 2], [0, 0, -length / 2]]])
        else:
            radius = self.size[0]
            local = np.vstack([np.eye(3), -np.eye(3)]) * radius
        return local @ self.placement.rotation.T + self.placement.translation


@dataclass(frozen=True)
class LinkInertial:
    """A link's mass (kg), centre of mass in the link frame and rotational inertia about it (3, 3)."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class UrdfLinks:
    """Per link name: its primitives (collision geometry, or the visual one when it has none), its
    inertial (None when the URDF gives none) and whether it has mesh geometry."""

    primitives: dict[str, tuple[Primitive, ...]]
    inertials: dict[str, LinkInertial | None]
    meshes: frozenset[str]


def _origin(element) -> pin.SE3:
    origin = element.find("origin") if element is not None else None
    xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()] if origin is not None else [0, 0, 0]
    rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()] if origin is not None else [0, 0, 0]
    return pin.SE3(pin.rpy.rpyToMatrix(np.array(rpy)), np.array(xyz))


def _primitives(link, tag: str) -> tuple[list[Primitive], bool]:
    shapes, mesh = [], False
    for element in link.findall(tag):
        geometry = element.find("geometry")
        if geometry is None:
            continue
        placement = _origin(element)
        for shape in geometry:
            if shape.tag == "box":
                shapes.append(Primitive("box", tuple(float(v) for v in shape.get("size").split()), placement))
            elif shape.tag == "cylinder":
                shapes.append(Primitive("cylinder", (float(shape.get("radius")), float(shape.get("length"))),
                                        placement))
            elif shape.tag == "sphere":
                shapes.append(Primitive("sphere", (float(shape.get("radius")),), placement))
            elif shape.tag == "mesh":
                mesh = True
    return shapes, mesh


def _inertial(link) -> LinkInertial | None:
    inertial = link.find("inertial")
    if inertial is None or inertial.find("mass") is None:
        return None
    values = inertial.find("inertia")
    get = (lambda key: float(values.get(key, 0.0))) if values is not None else (lambda key: 0.0)
    inertia = np.array([[get("ixx"), get("ixy"), get("ixz")],
                        [get("ixy"), get("iyy"), get("iyz")],
                        [get("ixz"), get("iyz"), get("izz")]])
    origin = _origin(inertial)
    return LinkInertial(mass=float(inertial.find("mass").get("value")), com=origin.translation,
                        inertia=origin.rotation @ inertia @ origin.rotation.T)


def read_urdf_links(path: str | Path) -> UrdfLinks:
    """Inertials and primitive geometry of every link of the URDF at `path` (one-line `SpecError`
    naming the file when it is not a readable URDF)."""
    try:
        root = ET.fromstring(read_text(path, "URDF"))
        primitives, inertials, meshes = {}, {}, set()
        for link in root.iter("link"):
            name = link.get("name")
            shapes, mesh = _primitives(link, "collision")
            if not shapes:
                shapes, mesh_visual = _primitives(link, "visual")
                mesh = mesh or mesh_visual
            primitives[name] = tuple(shapes)
            inertials[name] = _inertial(link)
            if mesh and not shapes:
                meshes.add(name)
    except (ET.ParseError, TypeError, ValueError, AttributeError) as exc:
        raise SpecError(f"{path}: not a readable URDF ({exc})") from None
    return UrdfLinks(primitives=primitives, inertials=inertials, meshes=frozenset(meshes))
