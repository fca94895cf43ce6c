"""OMPL baselines: the sampling-based planners users would otherwise run, on the same problems.

    records = plan_sequence_baseline(read_steps("steps.h5"), "map.h5", StepBaselineParams(), range(n))
    write_motion("motion_ompl.h5", records, robot, params, attrs={"planner": params.planner})

Step baseline (`legplan.baselines.step`): constrained RRT-Connect (Kingston, Moll & Kavraki) on the
stance-foot manifold, judged by the step planner's dense check. Navigation baseline
(`legplan.baselines.nav`): geometric RRT-Connect / RRT* / PRM* in R² and control-based KPIECE1 /
RRT on the 2D double integrator, written as nav.h5 with the nav search's metrics.
Importing a module that touches OMPL sets up the process-wide runtime (`runtime.py`).
"""
