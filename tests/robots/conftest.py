"""Fixtures: the repository robots and the generated toy robot (tests/robots/robot_helpers.py)."""

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
