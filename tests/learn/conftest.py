"""Fixtures of the learned-initializer tests: ANYmal's centroidal model and the shipped flat map."""

from pathlib import Path

import pytest

from legplan.dyn.terrain import TerrainModel
from legplan.robots import load_robot
from legplan.terrain import build_map

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def anymal():
    return load_robot("anymal").centroidal


@pytest.fixture(scope="session")
def flat():
    return TerrainModel(build_map(ROOT / "maps" / "flat.yaml"))
