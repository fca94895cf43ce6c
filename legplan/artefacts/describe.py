"""A plain-data description of any artefact, for `legplan inspect`."""

from __future__ import annotations

import os

import h5py

from legplan.artefacts.reader import open_artefact, read_provenance, read_summary


def describe_artefact(path: str | os.PathLike) -> dict:
    """Kind, schema, provenance, every dataset (shape, dtype, units) and the `/summary` table."""
    with open_artefact(path) as handle:
        datasets = []

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name != "summary":
                datasets.append({"name": "/" + name, "shape": list(obj.shape),
                                 "dtype": str(obj.dtype), "units": _attr(obj, "units")})

        handle.visititems(visit)
        return {"path": str(path), **read_provenance(handle), "datasets": datasets,
                "summary": {name: {"value": value, "units": units}
                            for name, (value, units) in read_summary(handle).items()}}


def _attr(obj, name: str) -> str:
    value = obj.attrs.get(name, "")
    return value.decode() if isinstance(value, bytes) else str(value)
