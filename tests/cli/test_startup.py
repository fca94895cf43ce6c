"""Start-up (issue 19): `legplan --help` and a navigation search do not import the heavy libraries
that only other commands need (measured times: BENCHMARKS.md, nav_search section)."""

import subprocess
import sys

HEAVY = ("pinocchio", "matplotlib", "mujoco", "dask", "sklearn", "ompl", "fcl", "proxsuite")


def imported_after(code: str) -> set[str]:
    """Top-level packages in sys.modules after running `code` in a fresh interpreter."""
    probe = f"{code}\nimport sys\nprint(' '.join(sorted({{m.split('.')[0] for m in sys.modules}})))"
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
