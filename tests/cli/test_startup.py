"""Start-up (issues 19, 38): `legplan --help`, `--version`, a navigation search and a centroidal plan
do not import the libraries that only other commands need (measured times: BENCHMARKS.md, nav_search
and cli sections)."""

import subprocess
import sys

HEAVY = ("pinocchio", "matplotlib", "mujoco", "dask", "sklearn", "ompl", "fcl", "proxsuite")


def imported_after(code: str, packages: bool = True) -> set[str]:
    """Top-level packages (or, `packages` False, every module) in sys.modules after running `code` in
    a fresh interpreter."""
    names = "{m.split('.')[0] for m in sys.modules}" if packages else "set(sys.modules)"
    probe = f"{code}\nimport sys\nprint(' '.join(sorted({names})))"
    out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True, text=True)
    return set(out.stdout.split())


def test_help_imports_neither_numpy_nor_heavy_libraries():
    loaded = imported_after("import legplan.cli.main")
    assert not loaded & {"numpy", "scipy", "rich", "h5py", *HEAVY}, loaded


def test_nav_search_imports_no_heavy_library(tmp_path):
    code = f"""
import numpy as np
from click.testing import CliRunner
from legplan.cli.main import cli
from legplan.terrain import CostmapParams, Grid2D, save_map, terrain_from_heightmap
height = np.zeros((40, 40)); height[10:20, 18:22] = 0.5
save_map(terrain_from_heightmap(height, Grid2D((0.05, 0.05), 0.1, height.shape), name="m",
                                nav=CostmapParams()), {str(tmp_path / 'map.h5')!r})
result = CliRunner().invoke(cli, ["nav", "search", {str(tmp_path / 'map.h5')!r}, "--start", "0.5", "0.5",
                                  "--goal", "3.5", "3.5", "-o", {str(tmp_path / 'nav.h5')!r}, "-q"])
assert result.exit_code == 0, result.output
"""
    loaded = imported_after(code)
    assert "h5py" in loaded and not loaded & set(HEAVY), loaded & set(HEAVY)


def test_version_imports_no_command_module():
    code = """
from click.testing import CliRunner
from legplan.cli.main import cli
assert CliRunner().invoke(cli, ["--version"]).exit_code == 0
"""
    loaded = imported_after(code, packages=False)
    assert not {m for m in loaded if m.startswith("legplan.cli.") and m.endswith("_cmd")}, loaded


# What `dyn plan` has no use for: other commands' libraries, scipy subpackages it does not call
# (rotations come from pinocchio), the numpy submodules scipy's numpy namespace would import
# (legplan._lazy_numpy_clone), numpy.ma (numpy's own `np.unique`, `np.union1d`, `np.setdiff1d` and
# `np.median` import it: legplan.geometry.ordered stands in for them), a
# process pool with `--jobs 1`, FCL (the trajectory check measures terrain distance without it), the
# step-sequence and learned-initializer packages, Cython (scipy's test utilities look for it),
# importlib.resources with zipfile (the shipped robots are a folder of the package), the solvers'
# Jacobian checker, numpy.strings and the numpy.core shim (scipy's numpy namespace), fractions and decimal
# (the Hermite Gram matrices are plain divisions), the map specs' parser and primitives (a map.h5 is read),
# the URDF links' geometry and its XML parser (`robot init|check` and the report read them) and csv (no
# tasks table given).
NOT_FOR_DYN_PLAN = ("matplotlib", "mujoco", "dask", "distributed", "sklearn", "ompl", "proxsuite", "scipy.spatial", "scipy.linalg",
                    "scipy.optimize", "numpy.f2py", "numpy.testing", "unittest", "multiprocessing",
                    "concurrent.futures.process", "fcl", "legplan.stepseq", "legplan.learn.network", "Cython", "cython",
                    "importlib.resources", "zipfile", "legplan.solve.jaccheck", "numpy.strings", "numpy.core",
                    "fractions", "decimal", "legplan.terrain.spec", "legplan.terrain.primitives", "numpy.ma",
                    "legplan.robots.urdf", "xml.etree.ElementTree", "pyexpat", "csv")
# ... and, once a run on the same map has stored the filtered terrain grids (legplan.cache), the
# filters' library.
NOT_FOR_DYN_PLAN_AGAIN = ("scipy.ndimage", "scipy.special")


def test_dyn_plan_imports_only_what_it_uses(tmp_path):
    import numpy as np

    from legplan.terrain import Grid2D, save_map, terrain_from_heightmap

    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    height = np.zeros(grid.shape)
    height[40:60, 100:] = 0.1  # a step: the edge distance grid is computed too
    save_map(terrain_from_heightmap(height, grid, name="step"), tmp_path / "map.h5")
    code = f"""
import os
os.environ["LEGPLAN_CACHE_DIR"] = {str(tmp_path / 'store')!r}
from click.testing import CliRunner
from legplan.cli.main import cli
result = CliRunner().invoke(cli, ["dyn", "plan", {str(tmp_path / 'map.h5')!r}, "--start", "0", "0", "0",
                                  "--goal", "0.6", "0", "0", "-o", {str(tmp_path / 'traj.h5')!r}, "--overwrite", "-q"])
assert result.exit_code in (0, 1), result.output
"""
    first = imported_after(code, packages=False)
    assert {"pinocchio", "h5py", "sksparse.cholmod", "legplan.validate.trajectory"} <= first  # it did plan and check
    assert "scipy.ndimage" in first  # nothing stored yet: the filters ran
    assert not first & set(NOT_FOR_DYN_PLAN), first & set(NOT_FOR_DYN_PLAN)
    again = imported_after(code, packages=False)
    assert {"pinocchio", "h5py", "sksparse.cholmod", "legplan.validate.trajectory"} <= again
    assert not again & {*NOT_FOR_DYN_PLAN, *NOT_FOR_DYN_PLAN_AGAIN}, again & {*NOT_FOR_DYN_PLAN, *NOT_FOR_DYN_PLAN_AGAIN}


def test_scipy_numpy_namespace_stays_complete():
    """legplan._lazy_numpy_clone defers numpy's submodules in scipy's numpy namespace without
    removing them: they come on first access, and numpy itself is left as it was."""
    code = """
import numpy
before = (list(numpy.__all__), sorted(dir(numpy)))
import legplan, scipy.sparse, sys
assert "numpy.f2py" not in sys.modules and "numpy.testing" not in sys.modules
from scipy._lib.array_api_compat import numpy as xp
assert xp.testing is numpy.testing and xp.f2py is numpy.f2py and xp.sum is numpy.sum
assert (list(numpy.__all__), sorted(dir(numpy))) == before
"""
    imported_after(code)


def test_loading_a_robot_captures_urdfdom_without_tempfile():
    """urdfdom's stderr is captured in an anonymous memory file where the system has one (`dyn plan`
    on a known map then starts without tempfile; click's test runner imports it, hence this test)."""
    code = """
import os, sys
from legplan.native_stderr import captured_stderr
from legplan.robots import load_robot
load_robot("anymal")
with captured_stderr() as captured:
    os.write(2, b"urdfdom says\\n\\n  twice \\n")
assert captured.lines == ["urdfdom says", "twice"], captured.lines
assert hasattr(os, "memfd_create") == ("tempfile" not in sys.modules)
"""
    imported_after(code)


def test_capture_falls_back_to_a_temporary_file(monkeypatch):
    import os

    from legplan.native_stderr import captured_stderr

    monkeypatch.delattr(os, "memfd_create", raising=False)
    with captured_stderr() as captured:
        os.write(2, b"no memfd here\n")
    assert captured.lines == ["no memfd here"]


def test_version_imports_neither_ctypes_nor_numpy():
    code = """
from legplan.cli.main import cli
try:
    cli(["--version"])
except SystemExit as exit:
    assert exit.code == 0
"""
    loaded = imported_after(code)
    assert not loaded & {"ctypes", "numpy"}, loaded & {"ctypes", "numpy"}
