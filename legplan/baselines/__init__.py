"""OMPL baselines: the sampling-based planners users would otherwise run, on the same problems,
written as the same artefacts with the same metrics as ours.

Step planning (`legplan.baselines.step`, `constrained`): constrained RRT-Connect (Kingston, Moll &
Kavraki) on the stance-foot manifold in the x-parametrization, validity = the Bézier planner's own
inequality rows; judged by `legplan.stepplan.measure.check_path`, written by `write_motion`:

    records = plan_sequence_baseline(read_steps("steps.h5"), "map.h5", StepBaselineParams(), range(n))
    write_motion("motion_ompl.h5", records, robot, params, attrs={"planner": params.planner})

Navigation (`legplan.baselines.nav`): RRT-Connect / RRT* / PRM* in R² and KPIECE1 / RRT on the 2D
double integrator, returning the nav layer's `SearchResult`; written by the nav writer:

    outcomes = plan_queries(grid := NavGrid.from_map("map.h5", l1), queries, NavBaselineParams("rrtstar"))
    write_nav_baseline("nav_ompl.h5", [outcome_record(o, grid) for o in outcomes], params, "jueying_mini")

Importing a module that touches OMPL sets up the process-wide runtime (`runtime.py`: seeding,
log level, exit-time nanobind leak reports silenced). `names.py` needs no OMPL.
"""
