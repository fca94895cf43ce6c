"""Bézier + Levenberg-Marquardt single-step motion planning (Valouch & Faigl, Sec. III).

    params = StepPlanParams()
    plan = plan_step(robot, terrain_distance(robot, terrain, params), q_start, q_end, stance, footholds, params)
    plan.success, plan.degree, plan.control_points   # x-space control points, x = [p, ω, joints]
    records = plan_sequence(read_steps("steps.h5"), "map.h5", params, range(n))   # in-process; the CLI uses legplan.batch
    write_motion("motion.h5", records, robot_name, params)
"""

from legplan.stepplan.batch import motion_stance, plan_sequence, read_motion, table2, write_motion
from legplan.stepplan.block import BezierConstraintBlock, SampleConstraints
from legplan.stepplan.measure import DenseCheck, dense_check
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import StepPlan, plan_step, terrain_distance, unwrap_rotation_vector

__all__ = ["BezierConstraintBlock", "DenseCheck", "SampleConstraints", "StepPlan", "StepPlanParams",
           "dense_check", "motion_stance", "plan_sequence", "plan_step", "read_motion", "table2",
           "terrain_distance", "unwrap_rotation_vector", "write_motion"]
