"""Reading input files (map specs, robot specs, pipeline files, task tables) with one-line errors:
`read_text` (bytes -> UTF-8 text, the one decoding reader of every text input), `read_yaml` /
`read_yaml_mapping` for a YAML file, `read_csv_table` for a CSV table, `parse_number` for a number
given as text, `apply_overrides` for `--param key=value` strings on a parameter dataclass,
`FieldReader` for typed fields that name the file and field."""

from __future__ import annotations

import dataclasses
import os
import types
import typing
from pathlib import Path

import numpy as np
import yaml

from legplan.errors import LegplanError, SpecError
from legplan.parameters import Interval, RangeError, check_value, magnitude_problem

# libyaml's parser when PyYAML was built with it: the same documents, several times faster
SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def read_text(path: str | os.PathLike, what: str = "file") -> str:
    """The UTF-8 text of `path` (universal newlines), or a one-line `SpecError` naming the file:
    missing or unreadable, not UTF-8 (binary garbage), or holding NUL bytes. Every reader of a
    YAML, CSV, JSON or text-map input goes through here."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SpecError(f"{path}: cannot read {what} ({exc.strerror or exc})") from exc
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SpecError(f"{path}: not UTF-8 text (byte {exc.start}); expected a {what}") from None
    if "\0" in text:
        raise SpecError(f"{path}: not a text file (NUL byte at {text.index(chr(0))}); expected a {what}")
    text = text.removeprefix("\ufeff")  # a byte-order mark (spreadsheet exports) is no part of the text
    return text.replace("\r\n", "\n").replace("\r", "\n")


def parse_number(text: str, where: str) -> float:
    """A finite float from command-line or file text, or a `SpecError` "WHERE: expected a finite
    number, got 'TEXT'" (NaN and inf are refused like malformed text), or "WHERE is too large ..."
    outside `legplan.parameters.MAGNITUDE`."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value):
        raise SpecError(f"{where}: expected a finite number, got {text!r}")
    if magnitude_problem(value):
        raise SpecError(f"{where} {magnitude_problem(value)}, got {text!r}")
    return value


BOOLEAN_WORDS = {"1": True, "true": True, "yes": True, "on": True,
                 "0": False, "false": False, "no": False, "off": False}


def apply_overrides(base, overrides: dict[str, str] | None, source: str, what: str):
    """An instance of a parameter dataclass with `key=value` strings applied: `base` is the class
    (start from its defaults) or an instance (start from its values); `override` with the error
    lines naming `source` (e.g. "--param") and the `what` parameters."""
    params = base() if isinstance(base, type) else base
    return override(params, overrides or {}, FieldReader(source, f"{what} parameters"))


def override(params, values: dict, reader: FieldReader, prefix: str = ""):
    """A copy of the parameter dataclass `params` with `values` (field name, dotted for the fields of a
    nested parameter dataclass → value) set: the one route by which a file or `--param` sets any
    stage's parameters. A value is a typed value (a YAML file's) or text (the command line's),
    converted to the field's declared type (`_from_text`); each is checked against its declared type
    and range (the `legplan.parameters.param` declaration) and a failure is `reader`'s one-line error
    naming the field."""
    cls = type(params)
    declared = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    nested: dict[str, dict] = {}
    changes = {}
    for key, value in values.items():
        head, _, rest = key.partition(".")
        shown = f"{prefix}{key}"
        if head not in declared:
            reader.fail(f"{prefix}{head}", f"is unknown (known: {', '.join(declared)})")
        if dataclasses.is_dataclass(hints[head]):
            if not rest:
                reader.fail(shown, "is a group of parameters: set its fields (NAME.FIELD)")
            nested.setdefault(head, {})[rest] = value
        elif rest:
            reader.fail(f"{prefix}{head}", "has no fields")
        else:
            changes[head] = _leaf(declared[head], hints[head], value, params, reader, shown)
    for head, inner in nested.items():
        changes[head] = override(getattr(params, head), inner, reader, f"{prefix}{head}.")
    try:
        return dataclasses.replace(params, **changes)
    except LegplanError as exc:  # a range that names another field (checked on the whole object)
        where = f" {reader.where}:" if reader.where else ""
        raise SpecError(f"{reader.path}:{where} {exc}") from None


NULL_WORDS = ("null", "none", "~")
"""Text that switches an optional parameter off (`key=null`)."""


def _from_text(kind, text: str, reader: FieldReader, shown: str):
    """Command-line text as a value of the declared `kind`: None for a null word, a
    boolean word, a finite number; other kinds keep the text (a choice, a name)."""
    word = text.strip().lower()
    if word in NULL_WORDS:
        return None  # refused by the caller unless the field is optional
    if kind is bool:
        if word not in BOOLEAN_WORDS:
            reader.fail(shown, f"must be true or false (1/0, yes/no, on/off), got {text!r}")
        return BOOLEAN_WORDS[word]
    if kind in (int, float):
        try:
            return float(text)
        except ValueError:
            reader.fail(shown, f"must be a finite number, got {text!r}")
    if typing.get_origin(kind) in (tuple, list):
        reader.fail(shown, "cannot be set with KEY=VALUE (it holds several values)")
    return text


def _leaf(declared, kind, value, params, reader: FieldReader, shown: str):
    """One field's value converted from text where given as text, checked against its type and
    declared range."""
    optional = isinstance(kind, types.UnionType) and type(None) in typing.get_args(kind)
    if optional:
        kind = next(arg for arg in typing.get_args(kind) if arg is not type(None))
    given = value
    if isinstance(value, str) and kind is not str:
        value = _from_text(kind, value, reader, shown)
    if value is None:
        if not optional:
            reader.fail(shown, "must not be null")
        return None
    allowed = declared.metadata.get("range")
    if kind is bool:
        if not isinstance(value, bool):
            reader.fail(shown, f"must be true or false, got {given!r}")
    elif kind in (int, float):
        number = reader.number(value, shown)
        if kind is int and not number.is_integer():
            reader.fail(shown, f"must be a whole number, got {given!r}")
        value = kind(number)
        if magnitude_problem(value):
            reader.fail(shown, f"{magnitude_problem(value)}, got {given!r}")
    elif isinstance(allowed, tuple):
        reader.choice(value, shown, allowed)
    elif not isinstance(value, typing.get_origin(kind) or kind):
        reader.fail(shown, f"must be {getattr(kind, '__name__', kind)}, got {given!r}")
    if isinstance(allowed, Interval) and not allowed.contains(value, params):
        reader.fail(shown, f"must be {_condition(allowed, params)}, got {given!r}")
    return value


def _condition(interval: Interval, params) -> str:
    """The declared interval as a condition: ">= 0", "> 0", "in (0, 1]"."""
    if interval.high == float("inf") and not isinstance(interval.low, str):
        return f"{'>' if interval.low_open else '>='} {interval.low:g}"
    return f"in {interval.describe(params)}"


def read_yaml(path: str | os.PathLike, what: str = "spec"):
    """The YAML document in `path` (any type), or a `SpecError` naming the file (and line)."""
    text = read_text(path, what)
    try:
        return yaml.load(text, Loader=SAFE_LOADER)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise SpecError(f"{path}: invalid YAML{where}") from None
    except (ValueError, RecursionError) as exc:  # e.g. an out-of-range timestamp, absurd nesting
        raise SpecError(f"{path}: invalid YAML ({type(exc).__name__})") from None


def read_yaml_mapping(path: str | os.PathLike, what: str = "spec") -> dict:
    """The YAML mapping in `path`, or a `SpecError` naming the file (and line, for syntax errors)."""
    data = read_yaml(path, what)
    if not isinstance(data, dict):
        raise SpecError(f"{path}: {what} must be a YAML mapping")
    return data


def read_csv_table(path: str | os.PathLike, what: str = "CSV file") -> tuple[list[str], list[list[str]]]:
    """The header (stripped names) and data rows of a CSV file; blank lines and lines starting with
    '#' are skipped. One-line `SpecError`s: not text, no header, a duplicate column, a row whose
    field count differs from the header's (rows are 0-based, after the header)."""
    import csv  # here only: most commands read no table

    lines = [line for line in read_text(path, what).split("\n")
             if line.strip() and not line.lstrip().startswith("#")]
    try:
        table = list(csv.reader(lines))
    except csv.Error as exc:
        raise SpecError(f"{path}: not a valid {what} ({exc})") from None
    if not table:
        raise SpecError(f"{path}: empty {what} (a header row is required)")
    header = [name.strip() for name in table[0]]
    repeated = [name for i, name in enumerate(header) if name in header[:i]]
    if repeated:
        raise SpecError(f"{path}: duplicate column '{repeated[0]}'")
    for i, row in enumerate(table[1:]):
        if len(row) != len(header):
            raise SpecError(f"{path}: row {i}: has {len(row)} fields, the header has {len(header)}")
    return header, table[1:]


class FieldReader:
    """Typed access to the fields of an input file (a YAML mapping, a table row); every failure is a
    one-line `SpecError` naming the file, the entry (`where`, e.g. "row 3", optional) and the field.

        reader = FieldReader(path)
        mass = reader.positive(reader.get(data, "mass", "centroidal.mass"), "centroidal.mass")
    """

    def __init__(self, path: str | os.PathLike, where: str = ""):
        self.path = path
        self.where = where

    def fail(self, field: str, message: str):
        where = f" {self.where}:" if self.where else ""
        raise SpecError(f"{self.path}:{where} field '{field}' {message}")

    def get(self, mapping: dict, key: str, field: str, kind=None, default=...):
        if not isinstance(mapping, dict):
            self.fail(field.rsplit(".", 1)[0] if "." in field else field, "must be a mapping")
        if key not in mapping:
            if default is ...:
                self.fail(field, "is missing")
            return default
        value = mapping[key]
        if kind is not None and not isinstance(value, kind):
            self.fail(field, f"must be {_kind_name(kind)}, got {value!r}")
        return value

    def number(self, value, field: str, allowed: str | None = None) -> float:
        """A finite number within `legplan.parameters.MAGNITUDE` and, when given, the range `allowed`
        (interval text, e.g. `legplan.parameters.DURATION`)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(field, f"must be a finite number, got {value!r}")
        try:
            number = float(value)
        except OverflowError:  # an int beyond any float
            number = float("inf")
        if not np.isfinite(number):
            self.fail(field, f"must be a finite number, got {value!r}")
        try:
            check_value(number, allowed or "(-inf, inf)", "")
        except RangeError as exc:
            self.fail(field, str(exc).strip())
        return number

    def vector(self, value, field: str, length: int | None = None, allowed: str | None = None) -> np.ndarray:
        if not isinstance(value, (list, tuple)) or (length is not None and len(value) != length):
            self.fail(field, f"must be a list of {length or 'some'} numbers, got {value!r}")
        return np.array([self.number(v, f"{field}[{i}]", allowed) for i, v in enumerate(value)])

    def positive(self, value, field: str, allowed: str | None = None) -> float:
        number = self.number(value, field)
        if number <= 0:
            self.fail(field, f"must be > 0, got {value!r}")
        return self.number(value, field, allowed)

    def nonnegative(self, value, field: str, allowed: str | None = None) -> float:
        number = self.number(value, field)
        if number < 0:
            self.fail(field, f"must be >= 0, got {value!r}")
        return self.number(value, field, allowed)

    def count(self, value, field: str, maximum: int | None = None) -> int:
        """A whole number >= 1 (and <= `maximum` when given)."""
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            self.fail(field, f"must be a whole number >= 1, got {value!r}")
        if maximum is not None and value > maximum:
            self.fail(field, f"must be a whole number <= {maximum}, got {value!r}")
        return int(value)

    def choice(self, value, field: str, choices) -> str:
        if value not in choices:
            self.fail(field, f"must be one of {', '.join(choices)}, got {value!r}")
        return value

    def unknown(self, mapping: dict, known, prefix: str = "") -> None:
        """Fail on the first key of `mapping` that is not in `known`."""
        extra = sorted(str(key) for key in set(mapping) - set(known))
        if extra:
            self.fail(f"{prefix}{extra[0]}", f"is unknown (expected {', '.join(known)})")


def _kind_name(kind) -> str:
    names = {str: "a string", list: "a list", dict: "a mapping", bool: "true or false"}
    return names.get(kind, getattr(kind, "__name__", str(kind)))
