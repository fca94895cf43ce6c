"""Where a URDF's resource URI points: `resolve_uri(uri, urdf_path, package_paths)`.

ROS URDFs name their meshes `package://PKG/rest`, a path relative to the ROS package PKG, or
`file:///abs/path`, or a path relative to the URDF's own folder. A ROS package is found as ROS does
it, without a ROS installation, in these folders in order: `package_paths` (the command line's
`--package-path`), the URDF's folder and each folder above it (a package's URDF usually lies inside
the package, e.g. `PKG/urdf/robot.urdf`), then the `ROS_PACKAGE_PATH` environment variable's
(`os.pathsep`-separated) — the order `robot init` uses. A folder is the package when its name is
PKG or its `package.xml` names PKG; else its child folder PKG is tried. The first existing file
wins. `UnresolvedUri` says which folders were searched.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

_PACKAGE_NAME = re.compile(r"<name>\s*([^<\s]+)\s*</name>")


class UnresolvedUri(LookupError):
    """A resource URI names no existing file; the message says where it was looked for."""


def _package_name(folder: Path) -> str | None:
    """The name in `folder/package.xml`, or None."""
    manifest = folder / "package.xml"
    try:
        match = _PACKAGE_NAME.search(manifest.read_text(errors="replace"))
    except OSError:
        return None
    return match.group(1) if match else None


def _candidates(package: str, root: Path):
    """Folders under or at `root` that may be the package `package`."""
    if root.name == package or _package_name(root) == package:
        yield root
    yield root / package


def search_roots(urdf_path: Path, package_paths=()) -> list[Path]:
    """The folders searched for a package, in order (module docstring)."""
    ros = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    here = Path(urdf_path).resolve().parent
    return [*map(Path, package_paths), here, *here.parents, *ros]


def resolve_uri(uri: str, urdf_path, package_paths=(), roots=None) -> Path:
    """The file a URDF's `filename` attribute names (module docstring); `UnresolvedUri` if none
    exists. `roots` replaces the folders `search_roots` would search."""
    urdf_path = Path(urdf_path)
    if uri.startswith("package://"):
        package, _, rest = uri[len("package://"):].partition("/")
        if not package or not rest:
            raise UnresolvedUri(f"{uri!r} does not name a package and a path in it")
        roots = search_roots(urdf_path, package_paths) if roots is None else list(roots)
        for root in roots:
            for folder in _candidates(package, root):
                if (folder / rest).is_file():
                    return (folder / rest).resolve()
        raise UnresolvedUri(f"{uri!r}: package '{package}' not found holding {rest!r} (looked in the --package-path "
                            f"folders, next to the URDF, in its parent folders and on ROS_PACKAGE_PATH)")
    path = Path(uri[len("file://"):]) if uri.startswith("file://") else Path(uri)
    if not path.is_absolute():
        path = urdf_path.resolve().parent / path
    if not path.is_file():
        raise UnresolvedUri(f"{uri!r}: no such file ({path})")
    return path.resolve()
