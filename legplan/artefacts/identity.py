"""Which map an artefact was made on, checked wherever two artefacts meet.

Every artefact records its inputs (`provenance.input_record`: path, sha256, kind); a map input also
carries its `terrain` digest (`terrain_digest`: the sha256 of the heights and the grid), which two
builds of one spec share although their files differ (the creation time is in the file). A map's
identities (`map_identities`) are that digest, the sha256 of its file and those of the inputs it was
built from (its spec), so a record made from the spec (a task space's `map_sha256`) matches the map built from it.

`check_same_map(artefact, map)` is the one check of a pair: a trajectory executed on, a motion shown
over, steps planned on, a network initializing a plan on a map other than its own is bad input.
(`legplan.robots.identity.check_same_robot` does the same for the robot an artefact names.)
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from legplan.errors import ArtefactError


def terrain_digest(path: str | os.PathLike) -> str:
    """sha256 of a map artefact's heights (float64, C order), origin and resolution."""
    from legplan.artefacts.reader import open_artefact, read_array

    with open_artefact(path, "map", values=False) as handle:  # the heights checked as they are read
        height = read_array(handle, "terrain/height", ndim=2)
        attrs = handle["terrain/height"].attrs
        grid = np.asarray([*np.ravel(attrs.get("origin", ())), attrs.get("resolution", 0.0)], float)
    digest = hashlib.sha256(np.ascontiguousarray(height, dtype=np.float64).tobytes())
    digest.update(np.asarray(height.shape, np.int64).tobytes())
    digest.update(grid.tobytes())
    return digest.hexdigest()


def map_identities(path: str | os.PathLike) -> set[str]:
    """The identities of a map: its terrain digest, its file's sha256 and the sha256 of every input
    it was built from (a spec); of a map spec, the sha256 of its file."""
    from legplan.artefacts.provenance import sha256_file
    from legplan.artefacts.reader import open_artefact, read_provenance

    if Path(path).suffix.lower() in (".yaml", ".yml"):
        return {sha256_file(path)}
    identities = {terrain_digest(path), sha256_file(path)}  # the digest first: it validates the map
    with open_artefact(path, "map", values=False) as handle:  # attributes only
        identities |= {record["sha256"] for record in read_provenance(handle)["inputs"] if isinstance(record, dict)}
    return identities


def recorded_maps(path: str | os.PathLike) -> list[dict]:
    """The map inputs (`{path, sha256, kind[, terrain]}`) an artefact records."""
    from legplan.artefacts.reader import open_artefact, read_provenance

    with open_artefact(path) as handle:
        try:
            inputs = read_provenance(handle)["inputs"]
        except (ValueError, KeyError, TypeError):
            raise ArtefactError(f"{path}: root attribute 'inputs' is not a list of input records") from None
    return [record for record in inputs if isinstance(record, dict) and record.get("kind") == "map"]


def check_same_map(path: str | os.PathLike, map_path: str | os.PathLike, recorded: Iterable[dict] | None = None,
                   what: str = "made") -> None:
    """An `ArtefactError` when the artefact at `path` was `what` ("planned", "trained") on another map
    than `map_path`: none of its recorded maps (`recorded`, default `recorded_maps(path)`; each a
    `{path, sha256[, terrain]}` record) has an identity of `map_path`. An artefact that records no
    map is not judged."""
    recorded = list(recorded_maps(path) if recorded is None else recorded)
    if not recorded:
        return
    identities = map_identities(map_path)
    if any(record.get("terrain") in identities or record.get("sha256") in identities for record in recorded):
        return
    raise ArtefactError(f"{path}: {what} on the map {Path(str(recorded[0].get('path', '?'))).name}, "
                        f"not on {map_path} (another terrain; give the map it was {what} on)")
