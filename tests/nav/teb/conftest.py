"""Fixtures of the TEB tests: the navigation paper's Table I limits of the Jueying Mini."""

import pytest

from legplan.robots import KinodynamicLimits, read_navigation

PAPER_TABLE_I = KinodynamicLimits(v_x_max=0.75, v_x_min=0.10, v_y_max=0.20, omega_max=0.70, a_x_max=1.00,
                                  a_y_max=0.17, alpha_max=0.52)


@pytest.fixture(scope="session")
def table_i():
    """Table I as robots/jueying_mini/robot.yaml holds it, checked against the paper's numbers."""
    limits = read_navigation("jueying_mini").limits
    assert limits == PAPER_TABLE_I
    return limits
