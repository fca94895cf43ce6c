"""Angles: the one wrap used by every planner that compares or interpolates headings."""

from __future__ import annotations

import numpy as np


def wrap_angle(angle):
    """Angle(s) wrapped to (−π, π] (a float for a scalar, an array otherwise)."""
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle, float), 2.0 * np.pi)
    return wrapped if np.ndim(wrapped) else float(wrapped)
