"""Geometry helpers (layer 1): convex support polygons (`polygon`), Bézier/Bernstein curves (`bezier`)."""

from legplan.geometry.polygon import ConvexPolygon, convex_hull_2d, support_polygon

__all__ = ["ConvexPolygon", "convex_hull_2d", "support_polygon"]

from legplan.geometry.bezier import (bernstein_matrix, derivative_norm_integrals, elevate, elevation_matrix,  # noqa: E402
                                     evaluate, uniform_parameters)

__all__ += ["bernstein_matrix", "derivative_norm_integrals", "elevate", "elevation_matrix", "evaluate",
            "uniform_parameters"]
