"""SDF build time and value+gradient lookup throughput on the gap_crossing map.

  build:  legplan.terrain.heightmap_sdf on maps/gap_crossing.yaml (per-layer 2D EDTs + vertical
          combination) vs reference: scipy.ndimage.distance_transform_edt in 3D on the same voxel
          grid (two transforms, occupied and free, combined as a voxel signed distance).
  lookup: SignedDistanceField.value_and_gradient on batches of 10k random points in the SDF box vs
          reference: scipy.ndimage.map_coordinates (order 1, value only, no gradient).
  exact:  ColumnDistance.value_and_gradient (exact distance to the columns, what the planners use;
          reach: scarab2's collision reach at the step planner's sample clearance) side by side
          with the trilinear lookup, on the same batches and on batches near the surface
          (z = height + U(-1, 8) cm), with the largest amount by which the trilinear lookup reads
          farther than the exact distance there.
Median of several runs; writes bench/results/terrain.json and updates its section of BENCHMARKS.md.
    .venv/bin/python bench/terrain.py [--repeats 5] [--batches 20] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import json
import statistics
import time

import numpy as np
from scipy.ndimage import distance_transform_edt, map_coordinates

from common import ROOT, load_average, machine, update_benchmarks, write_result

from legplan.contact.terms import collision_reach
from legplan.robots import load_robot
from legplan.stepplan.params import StepPlanParams
from legplan.terrain import ColumnDistance, build_map, heightmap_sdf
from legplan.terrain.sdf import sdf_layers

SPEC = ROOT / "maps" / "gap_crossing.yaml"


def median_time(func, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def reference_build(height, zs, r):
    occupied = height[None, :, :] > zs[:, None, None]
    outside = distance_transform_edt(~occupied, sampling=r)
    inside = distance_transform_edt(occupied, sampling=r)
    return (outside - inside).astype(np.float32)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--batches", type=int, default=20)
    parser.add_argument("--no-append", action="store_true")
    args = parser.parse_args()

    terrain = build_map(SPEC)
    grid, sdf = terrain.grid, terrain.sdf
    z_min, z_max = float(sdf.z_levels[0]), float(sdf.z_levels[-1])
    zs = sdf_layers(z_min, z_max, grid.resolution)
    build = median_time(lambda: heightmap_sdf(terrain.height, grid.origin, grid.resolution, z_min,
                                              z_max), args.repeats)
    reference = median_time(lambda: reference_build(terrain.height, zs, grid.resolution),
                            args.repeats)

    rng = np.random.default_rng(0)
    low = np.array([grid.extent[0], grid.extent[2], z_min])
    high = np.array([grid.extent[1], grid.extent[3], z_max])
    batches = [rng.uniform(low, high, (10_000, 3)) for _ in range(args.batches)]
    scaled = [((b - sdf.origin) / sdf.resolution)[:, ::-1].T for b in batches]

    def lookup():
        for points in batches:
            sdf.value_and_gradient(points)

    def lookup_reference():
        for coords in scaled:
            map_coordinates(sdf.data, coords, order=1, mode="nearest")

    points = 10_000 * args.batches
    ours_rate = points / median_time(lookup, args.repeats)
    reference_rate = points / median_time(lookup_reference, args.repeats)

    reach = collision_reach(load_robot("scarab2"), StepPlanParams().sample_clearance)
    columns = ColumnDistance.of(terrain, reach)
    xy = [rng.uniform(low[:2], high[:2], (10_000, 2)) for _ in range(args.batches)]
    near = [np.column_stack([b, terrain.height_at(b, method="nearest") + rng.uniform(-0.01, 0.08, len(b))])
            for b in xy]
    rates = {}
    for name, sets in (("box", batches), ("near", near)):
        for kind, field in (("trilinear", sdf), ("exact", columns)):
            rates[f"{kind}_{name}"] = points / median_time(lambda: [field.value_and_gradient(b) for b in sets],
                                                           args.repeats)
    stacked = np.concatenate(near)
    exact = columns.values(stacked)
    within = exact < reach
    overestimate = float((sdf.values(stacked[within]) - exact[within]).max())

    result = {
        "date": datetime.date.today().isoformat(), "machine": machine(), "load_average": load_average(),
        "map": "gap_crossing", "sdf_shape": list(sdf.shape), "repeats": args.repeats,
        "sdf_build_s": build, "reference_edt3d_build_s": reference,
        "build_ratio_vs_reference": reference / build,
        "lookup_points_per_s": ours_rate, "reference_map_coordinates_points_per_s": reference_rate,
        "lookup_ratio_vs_reference": ours_rate / reference_rate, "batch_size": 10_000,
        "batches": args.batches, "column_distance_reach_m": reach,
        "points_per_s": rates, "trilinear_overestimate_near_m": overestimate,
    }
    write_result("terrain", result)
    print(json.dumps(result, indent=2))
    if not args.no_append:
        shape = "x".join(map(str, sdf.shape))
        update_benchmarks(
                "terrain",
                f"## terrain SDF ({result['date']}, {result['machine']}, load {result['load_average']:.1f})\n\n"
                f"gap_crossing SDF build ({shape} voxels at 1 cm), median of {args.repeats} runs: "
                f"{build:.2f} s (legplan.terrain.heightmap_sdf) vs {reference:.2f} s (reference: "
                f"scipy 3D distance_transform_edt, occupied + free), ratio {reference / build:.2f}x.\n"
                f"SDF value+gradient lookup, batches of 10k points, median of {args.repeats} runs: "
                f"{ours_rate / 1e6:.2f} M points/s vs {reference_rate / 1e6:.2f} M points/s "
                f"(reference: scipy map_coordinates order 1, value only), ratio "
                f"{ours_rate / reference_rate:.2f}x.\n"
                f"Exact column distance (legplan.terrain.ColumnDistance, reach {reach * 100:.2f} cm, what the step "
                f"planner and generator use) vs the trilinear lookup, same run, M points/s: uniform in the SDF box "
                f"{rates['exact_box'] / 1e6:.2f} vs {rates['trilinear_box'] / 1e6:.2f}; near the surface (z = height "
                f"+ U(-1, 8) cm) {rates['exact_near'] / 1e6:.2f} vs {rates['trilinear_near'] / 1e6:.2f}. There the "
                f"trilinear lookup reads up to {overestimate * 1e3:.2f} mm farther than the exact distance.\n")


if __name__ == "__main__":
    main()
