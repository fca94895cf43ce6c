"""Pipelines: declarative chains of legplan stages with provenance-based up-to-date checks.

    pipeline = load_pipeline("pipelines/gap_crossing.yaml")
    for decision in plan_run(pipeline, "outputs/gap_crossing"):
        print(decision.name, decision.run, decision.reason)
    result = run_pipeline(pipeline, "outputs/gap_crossing", jobs=2)
"""

from legplan.pipeline.plan import ResolvedStage, StageDecision, plan_run, resolve_stage, up_to_date_reason
from legplan.pipeline.runner import PipelineResult, StageResult, run_pipeline, stage_command
from legplan.pipeline.spec import Pipeline, StageSpec, load_pipeline

__all__ = ["Pipeline", "PipelineResult", "ResolvedStage", "StageDecision", "StageResult", "StageSpec",
           "load_pipeline", "plan_run", "resolve_stage", "run_pipeline", "stage_command",
           "up_to_date_reason"]
