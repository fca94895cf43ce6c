"""map.h5 of a 6 m × 4 m field with a wall x ∈ [2.9, 3.1], y < 2.8 (the nav baseline tests' map)."""

from pathlib import Path

from legplan.terrain.spec import build_map
from legplan.terrain.terrain_map import save_map

WALL_SPEC = """name: wall_gap
resolution: 0.05
extent: {x: [0.0, 6.0], y: [0.0, 4.0]}
ground: 0.0
nav: {obstacle_height: 0.15, l1: 0.2, l2: 0.6, c_max: 100.0, lambda_c: 5.0}
sdf: {clearance: 0.2}
primitives:
  - {type: box, center: [3.0, 1.4], size: [0.2, 2.8], top: 0.5, obstacle: true}
"""


def build_wall_map(folder: Path) -> Path:
    spec = Path(folder) / "wall.yaml"
    spec.write_text(WALL_SPEC)
    path = Path(folder) / "map.h5"
    save_map(build_map(spec), path)
    return path
