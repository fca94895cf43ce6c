"""Fixtures of the step-sequence tests (`flat_map` is in tests/conftest.py)."""

import pytest

from legplan.validate import Validator


@pytest.fixture(scope="session")
def validator(scarab, flat_map):
    return Validator(scarab, flat_map[0])
