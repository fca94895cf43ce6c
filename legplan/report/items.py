"""Per-item results of an artefact (one planned step, one query): groups carrying a `success` attr.

Shared by the report (per-item figures) and `compare` (item-by-item regression checks).
"""

from __future__ import annotations

import h5py
import numpy as np

from legplan.artefacts.memo import by_file


@by_file
def read_items(handle: h5py.File) -> dict[str, dict]:
    """`{group path: {"success", "reason", numeric attrs..., "dense/foot_slip": scalar datasets...}}`.

    Array datasets of an item go to `item["arrays"]` as `{relative name: ndarray}`; the `units`
    attribute of every dataset to `item["units"]` as `{relative name: units}`. Read once per file
    version (`legplan.artefacts.memo.by_file`): a report asks for them several times.
    """
    items: dict[str, dict] = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Group) and "success" in obj.attrs:
            items[name] = _item(obj)

    handle.visititems(visit)
    return items


def _item(group: h5py.Group) -> dict:
    item = {"success": bool(group.attrs["success"]), "reason": _text(group.attrs.get("reason", "")),
            "arrays": {}, "units": {}}
    for key, value in group.attrs.items():
        if key not in ("success", "reason") and _is_number(value):
            item[key] = float(value)

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiub":
            item["units"][name] = _text(obj.attrs.get("units", ""))
            if obj.shape == ():
                item[name] = float(obj[()])
            else:
                item["arrays"][name] = obj[()]

    group.visititems(visit)
    return item


def _is_number(value) -> bool:
    return np.ndim(value) == 0 and isinstance(value, (int, float, np.integer, np.floating)) \
        and not isinstance(value, (bool, np.bool_))


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)
