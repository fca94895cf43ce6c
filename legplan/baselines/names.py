"""Names the baseline CLI offers, importable without loading OMPL (keeps `legplan --help` fast)."""

GEOMETRIC_PLANNERS = ("rrtconnect", "rrtstar", "prmstar")
CONTROL_PLANNERS = ("kpiece-control", "rrt-control")
NAV_PLANNERS = GEOMETRIC_PLANNERS + CONTROL_PLANNERS
CONSTRAINED_SPACES = ("projected", "atlas", "tangent")
