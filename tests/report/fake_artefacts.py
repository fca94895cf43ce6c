"""Small fake artefacts written with legplan.artefacts (no planner involved)."""

import numpy as np

from legplan.artefacts import write_artefact, write_dataset, write_summary


def write_map(path, bump=1.0):
    height = np.zeros((20, 30))
    height[5:10, 10:20] = 0.2 * bump
    with write_artefact(path, "map", params={"bump": bump}) as f:
        write_dataset(f, "terrain/height", height, units="m", origin=[-1.0, -0.5], resolution=0.05)
        write_dataset(f, "nav/costmap", 100 * (height > 0.1), units="", origin=[-1.0, -0.5], resolution=0.05)
        write_summary(f, {"cells_x": 30, "height_max": (height.max(), "m")})
    return path


def write_motion(path, times=(0.5, 1.5, 12.0), slips=(1e-7, 2e-7, 3e-3), success=(True, True, False),
                 shift=0.0, inputs=()):
    with write_artefact(path, "motion", params={"samples": 30}, inputs=inputs) as f:
        steps = f.create_group("steps")
        for i, (t, slip, ok) in enumerate(zip(times, slips, success)):
            g = steps.create_group(f"{i:04d}")
            g.attrs["success"] = ok
            g.attrs["reason"] = "" if ok else "slip too large"
            g.attrs["seconds"] = t
            write_dataset(g, "control_points", np.arange(12.0).reshape(4, 3) + shift, units="m|rad")
            write_dataset(g.create_group("dense"), "foot_slip", slip, units="m")
        write_summary(f, {"steps_planned": len(times), "steps_succeeded": sum(success),
                          "worst_violation": (max(slips), "m"), "mean_time": (float(np.mean(times)), "s")})
    return path
