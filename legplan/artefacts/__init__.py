"""HDF5 artefacts: atomic writers with provenance, validating readers (ARCHITECTURE.md).

    with write_artefact("map.h5", "map", params=p, inputs=[spec], overwrite=False) as f:
        write_dataset(f, "terrain/height", h, units="m")
        write_summary(f, {"cells": n, "max_height": (h.max(), "m")})

    with open_artefact("map.h5", kind="map") as f:
        h = require(f, "terrain/height")[()]
"""

from legplan.artefacts.describe import describe_artefact
from legplan.artefacts.provenance import input_record, sha256_file
from legplan.artefacts.reader import (check_finite, open_artefact, read_array, read_provenance, read_summary,
                                      require, require_attrs)
from legplan.artefacts.schema import SCHEMA_VERSIONS
from legplan.artefacts.writer import check_output, write_artefact, write_dataset, write_summary

__all__ = ["SCHEMA_VERSIONS", "check_finite", "check_output", "describe_artefact", "input_record",
           "open_artefact", "read_array", "read_provenance", "read_summary", "require", "require_attrs",
           "sha256_file", "write_artefact", "write_dataset", "write_summary"]
