"""Reading YAML input files (map specs, robot specs, pipeline files) with one-line errors."""

from __future__ import annotations

import os
from pathlib import Path

import yaml

from legplan.errors import SpecError


def read_yaml_mapping(path: str | os.PathLike, what: str = "spec") -> dict:
    """The YAML mapping in `path`, or a `SpecError` naming the file (and line, for syntax errors)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SpecError(f"{path}: cannot read {what} ({exc.strerror or exc})") from exc
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise SpecError(f"{path}: invalid YAML{where}") from exc
    if not isinstance(data, dict):
        raise SpecError(f"{path}: {what} must be a YAML mapping")
    return data
