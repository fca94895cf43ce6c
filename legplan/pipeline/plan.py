"""Up-to-date decisions for pipeline stages, from recorded provenance (never from timestamps).

A stage is up to date when its provenance artefact (its output, or the `provenance` file inside a
directory output) exists and records
  * `command[1:]` equal to the argv the pipeline would run now (the stage's command words, its params
    rendered as options, `-o OUTPUT --overwrite`), and
  * `inputs` whose sha256 all equal the current sha256 of those files, and which include every
    input the pipeline file declares for the stage.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from legplan.artefacts import open_artefact, read_provenance, sha256_file
from legplan.errors import LegplanError, SpecError
from legplan.pipeline.spec import _PLACEHOLDER, _STAGE_REF, Pipeline, StageSpec


@dataclass(frozen=True)
class ResolvedStage:
    """A stage with every placeholder replaced by an absolute path or value."""

    name: str
    argv: tuple[str, ...]          # words after `legplan`
    command_words: int             # how many leading argv words are the stage's `command`
    inputs: tuple[Path, ...]
    output: Path
    provenance: Path
    depends_on: tuple[str, ...]


@dataclass(frozen=True)
class StageDecision:
    """Whether a stage would run now, and why: no output yet, input changed, params changed, ..."""

    name: str
    run: bool
    reason: str
    argv: tuple[str, ...]


def stage_outputs(pipeline: Pipeline, out_dir: Path) -> dict[str, Path]:
    """Absolute output path of every stage: relative to `out_dir`, or under the directory of the
    `{var}` it starts with (an output shared with another pipeline, `legplan.pipeline.spec`)."""
    variables = _variables(pipeline, out_dir)
    return {stage.name: _norm(out_dir / _substitute(stage.output, variables, {})) for stage in pipeline.stages}


def _variables(pipeline: Pipeline, out_dir: Path) -> dict[str, str]:
    """`vars` with `{pipeline_dir}` and `{out}` filled in, and those two built-ins."""
    builtins = {"pipeline_dir": str(_norm(pipeline.path.parent)), "out": str(_norm(out_dir))}
    return {**{name: _substitute(value, builtins, {}) for name, value in pipeline.vars.items()}, **builtins}


def resolve_stage(pipeline: Pipeline, stage: StageSpec, out_dir: str | os.PathLike) -> ResolvedStage:
    """Substitute `{var}` and `{stages.X.output}`; render params as options; make paths absolute."""
    out_dir = _norm(Path(out_dir))
    outputs = stage_outputs(pipeline, out_dir)
    variables = _variables(pipeline, out_dir)

    def fill(text: str) -> str:
        filled = _substitute(text, variables, outputs)
        return str(_norm(Path(filled))) if filled.startswith("/") else filled

    command = [fill(word) for word in stage.command]
    options: list[str] = []
    for key, value in stage.params.items():
        flag = key if key.startswith("-") else f"--{key}"
        if value is True:
            options.append(flag)
        elif isinstance(value, list):
            options += [flag, *(fill(str(item)) for item in value)]
        elif isinstance(value, dict):
            for name, item in value.items():
                options += [flag, f"{name}={fill(str(item))}"]
        elif value is not False:
            options += [flag, fill(str(value))]
    output = outputs[stage.name]
    provenance = _norm(out_dir / stage.provenance) if stage.provenance else output
    argv = (*command, *options, "-o", str(output), "--overwrite")
    return ResolvedStage(name=stage.name, argv=argv, command_words=len(command),
                         inputs=tuple(Path(fill(item)) for item in stage.inputs), output=output,
                         provenance=provenance, depends_on=stage.depends_on)


def check_declared_inputs(pipeline: Pipeline, out_dir: str | os.PathLike) -> None:
    """`SpecError` when a declared input that no stage produces does not exist."""
    produced = set(stage_outputs(pipeline, _norm(Path(out_dir))).values())
    for stage in pipeline.stages:
        for path in resolve_stage(pipeline, stage, out_dir).inputs:
            if path not in produced and not path.exists():
                raise SpecError(f"{pipeline.path}: field 'stages.{stage.name}.inputs': {path} does not exist")


def up_to_date_reason(stage: ResolvedStage) -> str | None:
    """None when the stage's recorded provenance matches what would run now, else why not."""
    if not stage.provenance.exists():
        return "no output yet"
    try:
        with open_artefact(stage.provenance) as handle:
            recorded = read_provenance(handle)
    except (LegplanError, KeyError, ValueError) as exc:
        return f"output unreadable ({exc})"
    command = list(recorded["command"])[1:]
    if command != list(stage.argv):
        if command[:stage.command_words] == list(stage.argv[:stage.command_words]):
            return f"params changed (recorded {_options(command, stage.command_words)})"
        return "command changed"
    recorded_paths = set()
    for record in recorded["inputs"]:
        path = _norm(Path(record["path"]))
        recorded_paths.add(path)
        if not path.exists():
            return f"input missing: {path}"
        if sha256_file(path) != record["sha256"]:
            return f"input changed: {path}"
    absent = [path for path in stage.inputs if path not in recorded_paths]
    if absent:
        return f"input not recorded in provenance: {absent[0]}"
    return None


def plan_run(pipeline: Pipeline, out_dir: str | os.PathLike, force: bool = False) -> list[StageDecision]:
    """What `run_pipeline` would do now, stage by stage in dependency order (nothing is run).

    A stage whose dependency will run is marked to run too, since its input will be rewritten.
    """
    decisions: dict[str, StageDecision] = {}
    for spec in pipeline.stages:
        stage = resolve_stage(pipeline, spec, out_dir)
        upstream = next((dep for dep in stage.depends_on if decisions[dep].run), None)
        if force:
            reason = "forced"
        elif upstream is not None:
            reason = f"upstream stage '{upstream}' will run"
        else:
            reason = up_to_date_reason(stage)
        decisions[spec.name] = StageDecision(spec.name, reason is not None, reason or "up to date",
                                             stage.argv)
    return list(decisions.values())


def _options(command: list[str], words: int) -> str:
    options = command[words:]
    if len(options) >= 3 and options[-3] == "-o" and options[-1] == "--overwrite":
        options = options[:-3]
    return json.dumps(" ".join(options)) if options else "no options"


def _substitute(text: str, variables: dict[str, str], outputs: dict[str, Path]) -> str:
    def replace(match) -> str:
        key = match.group(1)
        ref = _STAGE_REF.fullmatch(key)
        if ref:
            return str(outputs[ref.group(1)])
        return variables[key]

    return _PLACEHOLDER.sub(replace, text)


def _norm(path: Path) -> Path:
    return Path(os.path.normpath(os.path.abspath(path)))
