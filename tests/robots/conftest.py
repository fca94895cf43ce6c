"""Fixtures: the repository robots and the generated toy robot (tests/robots/robot_helpers.py)."""

import importlib.metadata
from pathlib import Path

import pytest
from robot_helpers import write_toy_robot

from legplan.robots import load_robot


@pytest.fixture(scope="session")
def scarab2():
    return load_robot("scarab2")


@pytest.fixture(scope="session")
def jueying():
    return load_robot("jueying_mini")


@pytest.fixture(scope="session")
def anymal():
    return load_robot("anymal")


@pytest.fixture(scope="session")
def toy(tmp_path_factory):
    return load_robot(write_toy_robot(tmp_path_factory.mktemp("toy") / "toy"))


@pytest.fixture(params=["scarab2", "jueying", "anymal", "toy"])
def any_robot(request):
    return request.getfixturevalue(request.param)


@pytest.fixture(scope="session")
def published_robots() -> Path:
    """example-robot-data's robots/ folder (one sub-folder per ROS package)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.fail("example-robot-data, a test dependency, is not installed (pip install -e '.[test]')")
    marker = next(f for f in dist.files if str(f).endswith("go1_description/urdf/go1.urdf"))
    return Path(dist.locate_file(marker)).resolve().parents[2]


@pytest.fixture(scope="session")
def published_anymal_b(published_robots, tmp_path_factory) -> Path:
    """ANYmal B's robot.yaml as `robot init` drafts it from example-robot-data."""
    from legplan.robots.draft import write_draft

    path, _ = write_draft(published_robots / "anymal_b_simple_description/robots/anymal.urdf",
                          tmp_path_factory.mktemp("published") / "anymal_b")
    return path
