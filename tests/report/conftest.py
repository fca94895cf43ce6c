"""Fixtures of fake artefacts (writers in fake_artefacts.py)."""

import pytest
from fake_artefacts import write_map, write_motion


@pytest.fixture
def artefacts(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    return map_path, write_motion(tmp_path / "motion.h5", inputs=[map_path])
