"""Run a pipeline: stages in dependency order, independent ones in parallel, up-to-date ones skipped.

Each stage runs as a subprocess `python -c "<legplan cli>" ARGV...` (so a crashing stage cannot take
the pipeline down) with stdout and stderr captured to `OUT/logs/<stage>.log`, in its own process
group and dying with the pipeline (`legplan.pipeline.processes`). Whether a stage is up
to date is decided when its dependencies have finished, from their actual new outputs, so a
byte-identical upstream rewrite does not force downstream work.

Stage outcomes: `ran` (exit 0, fresh output), `items_failed` (exit 1 with a fresh output: some items
failed and are recorded in the artefact; dependants still run), `up_to_date`, `failed` (any other
exit, or no fresh output afterwards; dependants are skipped) and `skipped`.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from legplan.interrupts import note_published
from legplan.pipeline.plan import ResolvedStage, check_declared_inputs, resolve_stage, up_to_date_reason
from legplan.pipeline.processes import DIE_WITH_PARENT, StageProcesses
from legplan.pipeline.spec import Pipeline

log = logging.getLogger(__name__)

CLI_ENTRY = "from legplan.cli.main import cli; cli(prog_name='legplan')"
DONE = ("ran", "items_failed", "up_to_date")


@dataclass(frozen=True)
class StageResult:
    name: str
    status: str            # ran | items_failed | up_to_date | failed | skipped
    reason: str
    argv: tuple[str, ...] = ()
    returncode: int | None = None
    seconds: float = 0.0
    log: Path | None = None

    def line(self) -> str:
        """One log line after the status word: a stage that ran says why in parentheses, so the
        reason does not read as an error ("map (no output yet) 2.6 s"); others "name: reason"."""
        if self.status in ("ran", "items_failed"):
            return f"{self.name} ({self.reason}) {self.seconds:.1f} s"
        timing = f" ({self.seconds:.1f} s)" if self.returncode is not None else ""
        return f"{self.name}: {self.reason}{timing}"


@dataclass
class PipelineResult:
    pipeline: Pipeline
    out_dir: Path
    results: list[StageResult] = field(default_factory=list)

    @property
    def failed(self) -> list[StageResult]:
        return [r for r in self.results if r.status == "failed"]

    @property
    def ok(self) -> bool:
        return not self.failed


def stage_command(stage: ResolvedStage, entry: str = CLI_ENTRY) -> list[str]:
    """The subprocess argv that runs `legplan ARGV...` with the current interpreter (dying with
    the pipeline, `processes.DIE_WITH_PARENT`)."""
    return [sys.executable, "-c", f"{DIE_WITH_PARENT}; {entry}", *stage.argv]


def run_pipeline(pipeline: Pipeline, out_dir: str | os.PathLike, *, force: bool = False, jobs: int = 1,
                 progress=None, on_result=None, entry: str = CLI_ENTRY,
                 environment: dict[str, str] | None = None) -> PipelineResult:
    """Run every stage that is not up to date; `on_result(StageResult)` is called as each settles.

    `environment` is added to every stage's process environment (`legplan pipeline run --scheduler`
    hands the stages a dask scheduler this way, `legplan.cli.options.SCHEDULER_VARIABLE`); it is
    not part of a stage's argv, so it changes no up-to-date decision.

    `progress(done, total, message)` reports settled stages. `entry` is the Python snippet that runs
    the click group on `sys.argv` (tests substitute a fake one). Raises `SpecError` before running
    anything when a declared input that no stage produces is missing. On SIGINT / SIGTERM (the
    exception reaching this thread) the running stages are stopped (`StageProcesses.stop`) before
    the exception goes on, so no stage publishes after it.
    """
    out_dir = Path(out_dir)
    check_declared_inputs(pipeline, out_dir)
    stages = {spec.name: resolve_stage(pipeline, spec, out_dir) for spec in pipeline.stages}
    result = PipelineResult(pipeline, out_dir)
    settled: dict[str, StageResult] = {}
    pending = [spec.name for spec in pipeline.stages]
    running: dict[Future, str] = {}
    processes = StageProcesses()

    def settle(stage_result: StageResult) -> None:
        settled[stage_result.name] = stage_result
        result.results.append(stage_result)
        if stage_result.status in ("ran", "items_failed"):  # an interrupt later cannot take it back
            note_published(stages[stage_result.name].output)
        if on_result:
            on_result(stage_result)
        if progress:
            progress(len(settled), len(stages), f"{stage_result.name}: {stage_result.status}")

    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool, _stopping_on_exit(processes):
        while pending or running:
            for name in list(pending):
                stage = stages[name]
                failed_dep = next((d for d in stage.depends_on
                                   if d in settled and settled[d].status not in DONE), None)
                if failed_dep:
                    pending.remove(name)
                    settle(StageResult(name, "skipped", f"upstream stage '{failed_dep}' "
                                       f"{settled[failed_dep].status}", stage.argv))
                    continue
                if not all(d in settled for d in stage.depends_on) or len(running) >= max(1, jobs):
                    continue
                pending.remove(name)
                reason = "forced" if force else up_to_date_reason(stage)
                if reason is None:
                    settle(StageResult(name, "up_to_date", "up to date", stage.argv))
                    continue
                log.info("running stage %s (%s)", name, reason)
                running[pool.submit(_execute, stage, out_dir, reason, entry, processes, environment or {})] = name
            if not running:
                continue
            finished, _ = wait(list(running), return_when=FIRST_COMPLETED)
            for future in finished:
                running.pop(future)
                settle(future.result())
    return result


@contextmanager
def _stopping_on_exit(processes: StageProcesses):
    """Stop the running stages when the block ends with an exception (an interrupt)."""
    try:
        yield
    except BaseException:
        processes.stop()
        raise


def _execute(stage: ResolvedStage, out_dir: Path, why: str, entry: str,
             processes: StageProcesses, environment: dict[str, str]) -> StageResult:
    log_path = out_dir / "logs" / f"{stage.name}.log"
    log_path.parent.mkdir(parents=True, exist_ok=True)
    stage.output.parent.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "MPLBACKEND": "Agg", **environment}
    start = time.perf_counter()
    with open(log_path, "w") as stream:
        stream.write("$ legplan " + " ".join(stage.argv) + "\n")
        stream.flush()
        code = processes.run(stage_command(stage, entry), stdout=stream, env=env)
    if code is None:
        return StageResult(stage.name, "skipped", "pipeline interrupted", stage.argv)
    seconds = time.perf_counter() - start
    stale = up_to_date_reason(stage)
    if code in (0, 1) and stale is None:
        status = "ran" if code == 0 else "items_failed"
        reason = why if code == 0 else f"{why}; exit 1: some items failed (see the artefact)"
        return StageResult(stage.name, status, reason, stage.argv, code, seconds, log_path)
    if code not in (0, 1):
        reason = f"exit {code}: {_last_line(log_path)}"
    else:
        reason = f"exit {code} but output not up to date afterwards ({stale})"
    return StageResult(stage.name, "failed", reason, stage.argv, code, seconds, log_path)


def _last_line(path: Path) -> str:
    lines = [line.strip() for line in path.read_text(errors="replace").splitlines() if line.strip()]
    return lines[-1] if len(lines) > 1 else "no output"
