"""Fixtures of the CLI tests: `inputs`, one small valid input of each kind, built once per session
for the bad-input suite (`bad_input_support.valid_inputs`; each case breaks a copy of one)."""

import pytest
from bad_input_support import valid_inputs


@pytest.fixture(scope="session")
def inputs(tmp_path_factory):
    return valid_inputs(tmp_path_factory.mktemp("valid"))
