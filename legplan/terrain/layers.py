"""2D layers derived from a heightmap: foothold mask, occupancy, obstacle distance, inflated costmap."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FootholdParams:
    """A cell is a foothold when the height range within `flat_radius` is <= `flat_tolerance` and it
    lies at least `edge_margin` from any non-flat cell (m)."""

    flat_radius: float = 0.02
    flat_tolerance: float = 0.02
    edge_margin: float = 0.02


@dataclass(frozen=True)
class CostmapParams:
    """2D navigation: cells more than `obstacle_height` above or below the ground are obstacles;
    costmap inflation of eqs. (15)-(16) with inscribed radius `l1`, inflation radius `l2` (m), maximum
    (lethal) cost `c_max` and decay rate `lambda_c` (1/m). Defaults: Jueying Mini quadruped."""

    obstacle_height: float = 0.15
    l1: float = 0.2
    l2: float = 0.6
    c_max: float = 100.0
    lambda_c: float = 5.0


def disk(radius_cells: float) -> np.ndarray:
    """Boolean disk footprint of cells whose centres lie within `radius_cells` of the centre cell."""
    n = int(np.floor(radius_cells + 1e-9))
    offsets = np.arange(-n, n + 1)
    return offsets[:, None] ** 2 + offsets[None, :] ** 2 <= radius_cells ** 2 + 1e-9


def foothold_mask(height: np.ndarray, resolution: float, params: FootholdParams,
                  holes: np.ndarray | None = None) -> np.ndarray:
    """Cells where a foot may stand: locally flat, not a hole, eroded by `edge_margin`.

    Flatness: max - min of the height over a disk of radius `flat_radius` (at least one cell, so
    the 4-neighbours always count) <= `flat_tolerance`; the terrain is taken to continue as its
    border cells beyond the grid.
    """
    from scipy.ndimage import binary_erosion, maximum_filter, minimum_filter  # map building only

    footprint = disk(max(params.flat_radius / resolution, 1.0))
    spread = (maximum_filter(height, footprint=footprint, mode="nearest")
              - minimum_filter(height, footprint=footprint, mode="nearest"))
    flat = spread <= params.flat_tolerance + 1e-9
    if holes is not None:
        flat &= ~holes
    margin = params.edge_margin / resolution
    if margin >= 1.0 - 1e-9:
        flat = binary_erosion(flat, structure=disk(margin), border_value=1)
    return flat


def occupancy_grid(height: np.ndarray, ground: float, obstacle_height: float,
                   explicit: np.ndarray | None = None) -> np.ndarray:
    """Obstacle cells: |height - ground| > obstacle_height, or explicitly flagged obstacles."""
    occupied = np.abs(height - ground) > obstacle_height
    if explicit is not None:
        occupied |= explicit
    return occupied


def obstacle_distance(occupancy: np.ndarray, resolution: float) -> np.ndarray:
    """Distance (m) from each cell centre to the nearest obstacle cell centre (0 on obstacles).

    With no obstacle at all every cell gets the grid's diagonal length (a finite "far").
    """
    from scipy.ndimage import distance_transform_edt  # map building only

    if not occupancy.any():
        return np.full(occupancy.shape, resolution * float(np.hypot(*occupancy.shape)))
    return distance_transform_edt(~occupancy) * resolution


def costmap_from_distance(distance, l1: float, l2: float, c_max: float, lambda_c: float) -> np.ndarray:
    """Inflated cost of eqs. (15)-(16): C_max for l < l1 (lethal), C_max exp(-lambda_c (l - l1)) for
    l1 <= l < l2, 0 for l >= l2. `distance` l is in metres (any shape); lethal means cost >= c_max."""
    distance = np.asarray(distance, dtype=float)
    cost = np.where(distance < l2, c_max * np.exp(-lambda_c * (distance - l1)), 0.0)
    return np.where(distance < l1, c_max, cost)
