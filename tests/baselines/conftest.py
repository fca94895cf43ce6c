"""Fixtures of the baseline tests: the NavGrid of the wall-with-a-gap map (`wall_map`, tests/conftest.py)."""

import pytest

from legplan.nav import NavGrid


@pytest.fixture(scope="session")
def wall_grid(wall_map):
    """6 m × 4 m at 5 cm, l1 = 0.2 m; the wall blocks the straight line (1, 1) → (5, 1)."""
    return NavGrid.from_map(wall_map)
