"""What pinocchio's kinematic model does not keep from a URDF: each link's own inertial and its
geometry (box, cylinder, sphere, mesh), read from the XML.

Used to draft a robot.yaml (`legplan.robots.draft`) and to check one (`legplan.robots.check`).
Mesh files are found by `resolve_mesh` (`package://NAME/rest` the ROS way: a folder NAME among
the URDF's ancestors or under a package path, then `ROS_PACKAGE_PATH`) and read with coal's mesh
loader (assimp: STL, Collada, OBJ), which pinocchio brings; their vertices are read on first use.

pinocchio's own model of a URDF comes from `legplan.robots.urdf_model.build_free_flyer_model`
(importable without this module's XML reader and geometry classes, which only `robot init|check` and
the report's links need).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin

from legplan.robots.packages import UnresolvedUri, resolve_uri, search_roots
from legplan.errors import SpecError
from legplan.native_stderr import captured_stderr
from legplan.specio import read_text


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
class MeshShape:
    """A mesh file `path` (resolved), scaled by `scale` (3,), placed at `placement` in its link
    frame; `source` is the filename as the URDF writes it."""

    path: Path
    scale: tuple[float, float, float]
    placement: pin.SE3
    source: str
    urdf: Path = field(default=None, compare=False)

    @cached_property
    def vertices(self) -> np.ndarray:
        """(k, 3) vertices in the link frame (one-line `SpecError` naming the URDF and the mesh when
        the file is not a mesh coal can read)."""
        import coal

        try:
            with captured_stderr():
                mesh = coal.MeshLoader().load(str(self.path), np.array(self.scale, float))
            local = np.array(mesh.vertices(), float).reshape(-1, 3)
        except (RuntimeError, ValueError) as exc:
            reason = " ".join(str(exc).split("message:")[-1].split())[:120]
            raise SpecError(f"{self.urdf}: mesh '{self.source}' ({self.path}) cannot be read: {reason}") from None
        if not len(local):
            raise SpecError(f"{self.urdf}: mesh '{self.source}' ({self.path}) has no vertices")
        return local @ self.placement.rotation.T + self.placement.translation

    def extreme_points(self) -> np.ndarray:
        """The vertices (k, 3) in the link frame (they bound the shape)."""
        return self.vertices

    def bounding_box(self) -> Primitive:
        """The box around the vertices, axis-aligned in the link frame."""
        low, high = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return Primitive("box", tuple(float(v) for v in np.maximum(high - low, 1e-6)),
                         pin.SE3(np.eye(3), (low + high) / 2))


@dataclass(frozen=True)
class LinkInertial:
    """A link's mass (kg), centre of mass in the link frame and rotational inertia about it (3, 3)."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class UrdfLinks:
    """Per link name: its primitives and meshes (collision geometry, or the visual one when it has
    none) and its inertial (None when the URDF gives none)."""

    primitives: dict[str, tuple[Primitive, ...]]
    inertials: dict[str, LinkInertial | None]
    meshes: dict[str, tuple[MeshShape, ...]]

    def shapes(self, link: str) -> tuple:
        """Every shape of `link`: primitives, then meshes."""
        return self.primitives.get(link, ()) + self.meshes.get(link, ())


def _origin(element) -> pin.SE3:
    origin = element.find("origin") if element is not None else None
    xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()] if origin is not None else [0, 0, 0]
    rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()] if origin is not None else [0, 0, 0]
    return pin.SE3(pin.rpy.rpyToMatrix(np.array(rpy)), np.array(xyz))


def package_roots(urdf: Path, package_paths=()) -> list[Path]:
    """Where `package://` names are looked up, in order (`legplan.robots.packages.search_roots`)."""
    return search_roots(Path(urdf), package_paths)


def resolve_mesh(filename: str, urdf: Path, roots, link: str) -> Path:
    """The file a URDF mesh `filename` names (`legplan.robots.packages.resolve_uri` over `roots`,
    see `package_roots`); one-line `SpecError` naming the URDF, the link and the filename when there
    is no such file."""
    try:
        return resolve_uri(filename, urdf, roots=roots)
    except UnresolvedUri as exc:
        reason = str(exc).removeprefix(f"{filename!r}: ")
        raise SpecError(f"{urdf}: link '{link}' mesh '{filename}': {reason}; give --package-path") from None


def _shapes(link, tag: str, urdf: Path, roots) -> tuple[list[Primitive], list[MeshShape]]:
    shapes, meshes = [], []
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
                source = shape.get("filename", "")
                scale = [float(v) for v in shape.get("scale", "1 1 1").split()]
                scale = scale * 3 if len(scale) == 1 else scale
                path = resolve_mesh(source, urdf, roots, link.get("name"))
                meshes.append(MeshShape(path, tuple(scale), placement, source, urdf))
    return shapes, meshes


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


def read_urdf_links(path: str | Path, package_paths=()) -> UrdfLinks:
    """Inertials and geometry of every link of the URDF at `path` (one-line `SpecError` naming the
    file when it is not a readable URDF, or naming the link when a mesh file cannot be found;
    `package_paths` are searched first for `package://` names)."""
    path = Path(path)
    roots = package_roots(path, package_paths)
    try:
        root = ET.fromstring(read_text(path, "URDF"))
        primitives, inertials, meshes = {}, {}, {}
        for link in root.iter("link"):
            name = link.get("name")
            shapes, mesh = _shapes(link, "collision", path, roots)
            if not shapes and not mesh:
                shapes, mesh = _shapes(link, "visual", path, roots)
            primitives[name] = tuple(shapes)
            meshes[name] = tuple(mesh)
            inertials[name] = _inertial(link)
    except (ET.ParseError, TypeError, ValueError, AttributeError) as exc:
        raise SpecError(f"{path}: not a readable URDF ({exc})") from None
    return UrdfLinks(primitives=primitives, inertials=inertials, meshes=meshes)
