"""Pipeline files: a declarative chain of legplan stages (`pipelines/*.yaml`).

    name: gap_crossing
    vars: {maps: ../maps}                 # paths relative to the pipeline file's directory
    stages:
      - name: map
        command: [map, build, "{maps}/gap_crossing.yaml"]
        inputs: ["{maps}/gap_crossing.yaml"]
        output: map.h5                    # relative to -o/--output; a directory when it ends in "/"
        params:                           # extra CLI options:
          seed: 3                         #   --seed 3
          start: [-0.6, 0.0, 0.0]         #   --start -0.6 0.0 0.0 (one option, several values)
          param: {samples: 30}            #   --param samples=30 (repeated KEY=VALUE options)
          json: true                      #   --json (false: omitted)
      - name: report
        command: [report, "{stages.map.output}"]
        inputs: ["{stages.map.output}"]
        output: report/
        provenance: report/report.h5      # for directory outputs: the artefact holding provenance

Placeholders: `{VAR}` for an entry of `vars` (or the built-ins `pipeline_dir`, `out`) and
`{stages.NAME.output}` for another stage's output, which also makes that stage a dependency.

An `output` may start with a `{VAR}` naming a directory shared with another pipeline, e.g.
`vars: {gap: "{out}/../gap_crossing"}` and `output: "{gap}/steps.h5"`: a stage written exactly as
that pipeline's (same command, params, inputs) is then up to date after either pipeline ran it, so
pipelines run side by side (`make run`) compute it once.
Every path is made absolute, so recorded provenance and argv do not depend on the working directory.
"""

from __future__ import annotations

import graphlib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from legplan.errors import SpecError
from legplan.specio import read_yaml_mapping

_PLACEHOLDER = re.compile(r"\{([^{}]+)\}")
_STAGE_REF = re.compile(r"stages\.([^.{}]+)\.output")
_STAGE_KEYS = {"name", "command", "inputs", "output", "params", "provenance"}
_TOP_KEYS = {"name", "vars", "stages", "description"}
BUILTIN_VARS = ("pipeline_dir", "out")


@dataclass(frozen=True)
class StageSpec:
    """One stage as written in the file (placeholders unresolved)."""

    name: str
    command: tuple[str, ...]
    inputs: tuple[str, ...]
    output: str
    params: dict = field(default_factory=dict)
    provenance: str | None = None

    @property
    def depends_on(self) -> tuple[str, ...]:
        """Names of the stages whose outputs this stage references, in order of first use."""
        texts = [*self.command, *self.inputs, *(_param_texts(self.params))]
        seen: dict[str, None] = {}
        for text in texts:
            for match in _PLACEHOLDER.finditer(text):
                ref = _STAGE_REF.fullmatch(match.group(1))
                if ref:
                    seen.setdefault(ref.group(1))
        return tuple(seen)


@dataclass(frozen=True)
class Pipeline:
    """A validated pipeline: stages in a dependency-respecting (topological) order."""

    path: Path
    name: str
    vars: dict[str, str]
    stages: tuple[StageSpec, ...]

    def stage(self, name: str) -> StageSpec:
        return next(stage for stage in self.stages if stage.name == name)

    def dependants(self, name: str) -> set[str]:
        """Every stage that (transitively) needs `name`'s output."""
        found: set[str] = set()
        frontier = [name]
        while frontier:
            current = frontier.pop()
            for stage in self.stages:
                if current in stage.depends_on and stage.name not in found:
                    found.add(stage.name)
                    frontier.append(stage.name)
        return found


def load_pipeline(path: str | os.PathLike) -> Pipeline:
    """Read and validate a pipeline file; `SpecError` naming the file and field on any problem."""
    path = Path(path)
    data = read_yaml_mapping(path, "pipeline file")
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise SpecError(f"{path}: unknown field '{unknown[0]}' (expected {', '.join(sorted(_TOP_KEYS))})")
    variables = data.get("vars") or {}
    if not isinstance(variables, dict) or not all(isinstance(v, (str, int, float)) for v in variables.values()):
        raise SpecError(f"{path}: field 'vars' must map names to strings")
    clash = sorted(set(variables) & set(BUILTIN_VARS))
    if clash:
        raise SpecError(f"{path}: field 'vars.{clash[0]}' is built in and cannot be redefined")
    for name, value in variables.items():
        used = [key for key in _PLACEHOLDER.findall(str(value)) if key not in BUILTIN_VARS]
        if used:
            raise SpecError(f"{path}: field 'vars.{name}' may only use {{pipeline_dir}} or {{out}}, "
                            f"got '{{{used[0]}}}'")
    raw_stages = data.get("stages")
    if not isinstance(raw_stages, list) or not raw_stages:
        raise SpecError(f"{path}: field 'stages' must be a non-empty list")
    stages = [_parse_stage(path, index, raw) for index, raw in enumerate(raw_stages)]
    names = [stage.name for stage in stages]
    duplicate = next((name for name in names if names.count(name) > 1), None)
    if duplicate:
        raise SpecError(f"{path}: field 'stages' names stage '{duplicate}' twice")
    known = set(variables) | set(BUILTIN_VARS)
    for stage in stages:
        _check_placeholders(path, stage, known, set(names))
    outputs = [stage.output.rstrip("/") for stage in stages]
    clash = next((stage.name for stage, out in zip(stages, outputs) if outputs.count(out) > 1), None)
    if clash:
        raise SpecError(f"{path}: stages.{clash}.output: another stage writes the same output")
    ordered = _topological(path, stages)
    return Pipeline(path=path, name=str(data.get("name") or path.stem),
                    vars={k: str(v) for k, v in variables.items()}, stages=tuple(ordered))


def _parse_stage(path: Path, index: int, raw) -> StageSpec:
    where = f"stages[{index}]"
    if not isinstance(raw, dict):
        raise SpecError(f"{path}: field '{where}' must be a mapping")
    name = raw.get("name")
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_-]+", name or ""):
        raise SpecError(f"{path}: field '{where}.name' must be a word (letters, digits, _ or -), got {name!r}")
    where = f"stages.{name}"
    unknown = sorted(set(raw) - _STAGE_KEYS)
    if unknown:
        raise SpecError(f"{path}: unknown field '{where}.{unknown[0]}'")
    command = raw.get("command")
    if command is None:
        raise SpecError(f"{path}: missing field '{where}.command'")
    if (not isinstance(command, list) or not command
            or not all(isinstance(token, (str, int, float)) for token in command)):
        raise SpecError(f"{path}: field '{where}.command' must be a non-empty list of words after 'legplan'")
    inputs = raw.get("inputs") or []
    if not isinstance(inputs, list) or not all(isinstance(item, str) for item in inputs):
        raise SpecError(f"{path}: field '{where}.inputs' must be a list of paths")
    output = raw.get("output")
    if not isinstance(output, str) or not output.strip("/"):
        raise SpecError(f"{path}: missing field '{where}.output' (a path relative to the output directory -o)")
    if Path(output).is_absolute() or ".." in Path(output).parts:
        raise SpecError(f"{path}: field '{where}.output' must stay inside the output directory (-o), got {output!r}")
    params = raw.get("params") or {}
    if not isinstance(params, dict):
        raise SpecError(f"{path}: field '{where}.params' must map option names to values")
    for key, value in params.items():
        values = list(value.values()) if isinstance(value, dict) else value if isinstance(value, list) else [value]
        if value is None or not all(isinstance(v, (str, int, float, bool)) for v in values):
            raise SpecError(f"{path}: field '{where}.params.{key}' must be a scalar, a list of scalars "
                            "(one option, several values) or a mapping (repeated KEY=VALUE options)")
    provenance = raw.get("provenance")
    if output.endswith("/") and not isinstance(provenance, str):
        raise SpecError(f"{path}: field '{where}.provenance' is required for a directory output "
                        f"(the artefact inside it that records provenance, e.g. {output}report.h5)")
    if provenance is not None and not output.endswith("/"):
        raise SpecError(f"{path}: field '{where}.provenance' only applies to a directory output (ending in '/')")
    if provenance is not None and not provenance.startswith(output):
        raise SpecError(f"{path}: field '{where}.provenance' must lie inside '{output}', got {provenance!r}")
    return StageSpec(name=name, command=tuple(str(token) for token in command), inputs=tuple(inputs),
                     output=output, params=dict(params), provenance=provenance)


def _param_texts(params: dict):
    for value in params.values():
        values = value.values() if isinstance(value, dict) else value if isinstance(value, list) else [value]
        for item in values:
            if isinstance(item, str):
                yield item


def _check_placeholders(path: Path, stage: StageSpec, variables: set[str], stages: set[str]) -> None:
    fields = [("command", t) for t in stage.command] + [("inputs", t) for t in stage.inputs]
    fields += [("params", t) for t in _param_texts(stage.params)]
    shared = _PLACEHOLDER.match(stage.output)
    if shared is not None and _STAGE_REF.fullmatch(shared.group(1)):
        raise SpecError(f"{path}: field 'stages.{stage.name}.output' may start with a variable, not a stage's output")
    if [m.start() for m in _PLACEHOLDER.finditer(stage.output)] not in ([], [0]):
        raise SpecError(f"{path}: field 'stages.{stage.name}.output' may use a variable only at its start")
    fields += [("output", stage.output)] if shared is not None else []
    for field_name, text in fields:
        for match in _PLACEHOLDER.finditer(text):
            key = match.group(1)
            ref = _STAGE_REF.fullmatch(key)
            if ref and ref.group(1) not in stages:
                raise SpecError(f"{path}: field 'stages.{stage.name}.{field_name}' references unknown "
                                f"stage '{ref.group(1)}'")
            if ref and ref.group(1) == stage.name:
                raise SpecError(f"{path}: field 'stages.{stage.name}.{field_name}' references its own output")
            if not ref and key not in variables:
                raise SpecError(f"{path}: field 'stages.{stage.name}.{field_name}' uses undefined "
                                f"placeholder '{{{key}}}' (define it under 'vars')")


def _topological(path: Path, stages: list[StageSpec]) -> list[StageSpec]:
    """Stages ordered so each comes after its dependencies (file order among the stages that
    become ready together), by `graphlib`; a cycle is a `SpecError` naming it."""
    by_name = {stage.name: stage for stage in stages}
    sorter = graphlib.TopologicalSorter({stage.name: stage.depends_on for stage in stages})
    try:
        sorter.prepare()
    except graphlib.CycleError as exc:
        cycle = list(reversed(exc.args[1]))  # graphlib lists it against the dependency direction
        raise SpecError(f"{path}: field 'stages' has a dependency cycle: {' -> '.join(cycle)}") from None
    order = list(by_name)
    ordered: list[StageSpec] = []
    while sorter.is_active():
        ready = sorted(sorter.get_ready(), key=order.index)
        ordered += [by_name[name] for name in ready]
        sorter.done(*ready)
    return ordered
