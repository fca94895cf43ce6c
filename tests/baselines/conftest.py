"""Fixtures of the baseline tests: the NavGrid of a small wall-with-a-gap map.h5 (`wallmap.py`)."""

import sys
from pathlib import Path

import pytest

from legplan.nav import NavGrid

sys.path.insert(0, str(Path(__file__).parent))
from wallmap import build_wall_map  # noqa: E402


@pytest.fixture(scope="session")
def wall_grid(tmp_path_factory):
    """6 m × 4 m at 5 cm, l1 = 0.2 m; the wall blocks the straight line (1, 1) → (5, 1)."""
    return NavGrid.from_map(build_wall_map(tmp_path_factory.mktemp("wallmap")))
