"""Geometry helpers (layer 1): convex support polygons (`polygon`), Bézier/Bernstein curves (`bezier`)."""

from legplan.geometry.polygon import ConvexPolygon, convex_hull_2d, support_polygon

__all__ = ["ConvexPolygon", "convex_hull_2d", "support_polygon"]
