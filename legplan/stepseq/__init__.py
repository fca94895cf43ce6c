"""Step sequences (eq. (2) of the Bézier paper): import with validation, generation, export, plots.

    result = import_steps("steps.csv", robot, Validator(robot, terrain), urdf_order=..., robot_sha256=...)
    seq, generated, checks = generate_steps(robot, terrain, start, goal, seed=0, validator=validator)
    write_steps("steps.h5", seq, checks)
"""

from legplan.stepseq.generate import (GeneratedSequence, GenerateParams, GenerationError, StepGenerator,
                                     generate_steps)
from legplan.stepseq.importer import ImportLimits, ImportResult, Issue, import_steps
from legplan.stepseq.records import read_records, sequence_records, write_records
from legplan.stepseq.sequence import StepSequence, read_steps, summary_metrics, write_steps

__all__ = ["GenerateParams", "GeneratedSequence", "GenerationError", "ImportLimits", "ImportResult", "Issue", "StepGenerator",
           "StepSequence", "generate_steps", "import_steps", "read_records", "read_steps",
           "sequence_records", "summary_metrics", "write_records", "write_steps"]
