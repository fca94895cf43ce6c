"""A plain (non-editable) install works: the wheel carries the shipped robots and scenarios (maps,
pipelines, task spaces) as package data.

The wheel is built from a copy of the package sources, installed with --no-deps into a throwaway
venv that sees the project venv's dependencies (a .pth file) but neither the repository nor the
editable install, and run from a folder outside the repository.
"""

import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from legplan.artefacts import open_artefact, read_summary

ROOT = Path(__file__).resolve().parents[1]
SHIPPED_INITIALIZERS = sorted((ROOT / "tasks" / "initializers").glob("*.h5"))
FLAT_MAP = """name: flat
resolution: 0.02
extent: {x: [-0.6, 0.6], y: [-0.5, 0.5]}
ground: 0.0
primitives: []
"""


def _copy_sources(dest: Path) -> None:
    """pyproject, README and the package with the folders its robot_models and scenarios links point to."""
    dest.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, dest / name)
    ignore = shutil.ignore_patterns("__pycache__")
    shutil.copytree(ROOT / "legplan", dest / "legplan", symlinks=True, ignore=ignore)
    for folder in ("robots", "maps", "pipelines", "tasks"):
        shutil.copytree(ROOT / folder, dest / folder, ignore=ignore)


def _throwaway_venv(path: Path) -> Path:
    """A venv without the project on its path; the project venv's site-packages (and cmeel's prefix,
    which pinocchio needs) through a .pth file, whose other .pth files (the editable install) it
    does not run."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(path)], check=True)
    site = Path(subprocess.run([str(path / "bin" / "python"), "-c",
                                "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    (site / "project_deps.pth").write_text(f"{sysconfig.get_paths()['purelib']}\nimport cmeel_pth\n")
    return path / "bin"


def test_built_wheel_lists_robots_and_plans_outside_the_repository(tmp_path):
    _copy_sources(tmp_path / "src")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path / "dist"), str(tmp_path / "src")], check=True)
    wheel, = (tmp_path / "dist").glob("legplan-*.whl")
    bin_dir = _throwaway_venv(tmp_path / "venv")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(bin_dir / "python"), "install", "-q",
                    "--no-deps", "--no-index", str(wheel)], check=True)
    shutil.rmtree(tmp_path / "src")                     # nothing may come from the copied sources
    work = tmp_path / "work"
    work.mkdir()
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(tmp_path), "MPLBACKEND": "Agg"}

    def legplan(*args):
        result = subprocess.run([str(bin_dir / "legplan"), *args], cwd=work, env=env,
                                capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        return result.stdout

    where = subprocess.run([str(bin_dir / "python"), "-c", "import legplan; print(legplan.__file__)"],
                           cwd=work, env=env, capture_output=True, text=True, check=True).stdout
    assert where.startswith(str(tmp_path / "venv"))
    listing = legplan("robot", "list")
    assert f"robots in {(tmp_path / 'venv').resolve()}" in listing and "robot_models" in listing
    assert {"scarab2", "jueying_mini", "anymal"} <= {line.split()[0] for line in listing.splitlines()[1:]}
    assert "broken" not in listing
    shown = legplan("pipeline", "show", "pallet_climb")  # a shipped pipeline by name, its map beside it
    assert f"map build {(tmp_path / 'venv').resolve()}" in shown and "single_pallet.yaml" in shown
    shipped = legplan("learn", "shipped")  # every trained initializer of tasks/initializers/ is in the wheel
    assert {line.split(":")[0] for line in shipped.splitlines()} == {p.stem for p in SHIPPED_INITIALIZERS}
    (work / "flat.yaml").write_text(FLAT_MAP)
    legplan("map", "build", "flat.yaml", "-o", "map.h5", "-q")
    legplan("steps", "generate", "map.h5", "--robot", "scarab2", "--start", "-0.05", "0", "0",
            "--goal", "0.05", "0", "0", "-o", "steps.h5", "-q")
    legplan("step", "plan", "map.h5", "steps.h5", "-o", "motion.h5", "-q")
    with open_artefact(work / "motion.h5") as handle:
        summary = read_summary(handle)
    assert summary["steps_planned"][0] >= 4
    assert summary["steps_succeeded"][0] == summary["steps_planned"][0]
