"""pinocchio's kinematic model of a URDF: `build_free_flyer_model`, the one place a URDF is parsed by
pinocchio. urdfdom prints its parse errors straight to file descriptor 2, so they are captured and
folded into `UrdfParseError`. (The links' inertials and geometry, which pinocchio's model does not
keep, are read from the XML by `legplan.robots.urdf`.)
"""

from __future__ import annotations

import logging
from pathlib import Path

import pinocchio as pin

from legplan.native_stderr import captured_stderr

log = logging.getLogger("legplan.robots")


class UrdfParseError(ValueError):
    """pinocchio cannot build a model from a URDF; the message holds its reason and urdfdom's."""


def build_free_flyer_model(path: str | Path) -> pin.Model:
    """pinocchio's model of the URDF at `path` on a free-flyer root. urdfdom's own stderr lines
    never reach the terminal: on failure the first is part of the `UrdfParseError`, otherwise they
    go to the debug log."""
    try:
        with captured_stderr() as parser_output:
            model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    except (RuntimeError, ValueError) as exc:
        detail = "; ".join([str(exc).splitlines()[0], *parser_output.lines[:1]])
        raise UrdfParseError(" ".join(detail.split())) from None
    for line in parser_output.lines:
        log.debug("urdfdom: %s", line)
    return model
