"""The OMPL runtime shared by the baselines: import, seeding, log level, exit-time noise.

OMPL 2.0.1's PyPI wheel binds the C++ library with nanobind (`from ompl import base, geometric,
control, util`). Three process-wide quirks are handled here, once:

* Seeding. `ompl.util.RNG.setSeed(s)` reseeds the generator that gives every new `RNG` instance
  (samplers, planners) its seed, so calling it before each query and building fresh planner
  objects makes a query reproducible up to the time budget (a planner stopped by a clock may draw
  a different number of samples). OMPL ignores seed 0 and logs an error on every reseed after the
  first ("random number generation already started"), which is expected here: `seed_ompl` maps a
  legplan seed s >= 0 to s + 1 and mutes the log around the call.
* Log output. OMPL writes its own messages to stderr (the wheel's `OutputHandler` cannot be
  subclassed from Python); `set_ompl_log_level` maps the `legplan.baselines` logger level onto
  OMPL's (DEBUG -> OMPL info, INFO -> warnings, otherwise silent).
* nanobind prints "leaked function/type/instance" reports at interpreter shutdown for Python
  subclasses of bound classes (`ob.Constraint`, callbacks). They are not errors of the run; the
  wheel does not expose `nanobind.set_leak_warnings`, so an `atexit` hook (which runs before
  nanobind's own shutdown handler) points file descriptor 2 at /dev/null once ompl is loaded.
"""

from __future__ import annotations

import atexit
import logging
import os
import sys
from types import SimpleNamespace

_STATE = {"modules": None}
log = logging.getLogger("legplan.baselines")


def _silence_stderr_at_exit() -> None:
    try:
        sys.stderr.flush()
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
    except (OSError, ValueError):  # stderr already closed: nothing left to silence
        pass


def ompl_modules() -> SimpleNamespace:
    """`ob`, `og`, `oc`, `ou` (OMPL base, geometric, control, util), imported once per process."""
    if _STATE["modules"] is None:
        from ompl import base as ob
        from ompl import control as oc
        from ompl import geometric as og
        from ompl import util as ou

        atexit.register(_silence_stderr_at_exit)
        _STATE["modules"] = SimpleNamespace(ob=ob, og=og, oc=oc, ou=ou)
        set_ompl_log_level()
    return _STATE["modules"]


def set_ompl_log_level() -> None:
    """OMPL's own stderr messages follow the `legplan.baselines` logger (see module docstring)."""
    ou = ompl_modules().ou
    level = log.getEffectiveLevel()
    ou.setLogLevel(ou.LOG_INFO if level <= logging.DEBUG else ou.LOG_WARN if level <= logging.INFO
                   else ou.LOG_NONE)


def seed_ompl(seed: int) -> None:
    """Reseed OMPL's generator of RNG seeds with `seed + 1` (OMPL ignores 0); call before building planners."""
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    ou = ompl_modules().ou
    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(int(seed) + 1)
    set_ompl_log_level()


def state_values(state, dim: int) -> list[float]:
    """The `dim` coordinates of an OMPL real-vector (or constrained wrapper) state."""
    return [state[i] for i in range(dim)]


def real_vector_bounds(low, high):
    """`ob.RealVectorBounds` with per-dimension `low`/`high` sequences."""
    ob = ompl_modules().ob
    bounds = ob.RealVectorBounds(len(low))
    for i, (lo, hi) in enumerate(zip(low, high)):
        bounds.setLow(i, float(lo))
        bounds.setHigh(i, float(hi))
    return bounds
