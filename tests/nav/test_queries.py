"""Query files: MovingAI `.scen` rows land on the `.map` cells they name (row y from the top), in
the orientation of `legplan map import movingai`; bad rows fail naming the file, row and field."""

import numpy as np
import pytest

from legplan.errors import SpecError
from legplan.nav.queries import read_queries, read_scen
from legplan.terrain.importers import import_movingai

# 5 columns × 3 rows; the only free cells are (x=0, y=0) top-left and (x=4, y=2) bottom-right.
MAP = "type octile\nheight 3\nwidth 5\nmap\n.@@@@\n@@@@@\n@@@@.\n"


def write(tmp_path, scen_rows, map_text=MAP):
    (tmp_path / "m.map").write_text(map_text)
    scen = tmp_path / "m.map.scen"
    scen.write_text("version 1\n" + "".join(row + "\n" for row in scen_rows))
    return tmp_path / "m.map", scen


def test_scen_cells_are_the_free_cells_of_the_imported_map(tmp_path):
    map_path, scen = write(tmp_path, ["0\tm.map\t5\t3\t0\t0\t4\t2\t4.5"])
    terrain = import_movingai(map_path, 0.5, origin=(10.0, 20.0))
    queries = read_queries(scen, terrain.grid)
    # top-left cell: column 0, row 0 from the top = the largest y; bottom-right: the smallest y.
    np.testing.assert_allclose(queries, [[10.25, 21.25, 0, 0, 12.25, 20.25, 0, 0]])
    iy, ix, inside = terrain.grid.cell_of(queries[0, [0, 1, 4, 5]].reshape(2, 2))
    assert inside.all()
    assert not terrain.occupancy[iy, ix].any()
    assert terrain.occupancy.sum() == 13


@pytest.mark.parametrize("row, message", [
    ("0\tm.map\t6\t3\t0\t0\t4\t2\t1", "row 1, field 'width'/'height' 6x3 differs"),
    ("0\tm.map\t5\t3\t0\t3\t4\t2\t1", "row 1, field 'start_y' = 3 is outside"),
    ("0\tm.map\t5\t3\t0\tx\t4\t2\t1", "row 1, field 'start_y' must be an integer"),
    ("0\tm.map\t5\t3\t0\t0", "row 1, field 'goal_x' missing"),
])
def test_bad_scen_rows_name_the_file_row_and_field(tmp_path, row, message):
    map_path, scen = write(tmp_path, ["0\tm.map\t5\t3\t0\t0\t4\t2\t1", row])
    grid = import_movingai(map_path, 0.5).grid
    with pytest.raises(SpecError, match=f"m.map.scen: {message}".replace(".", r"\.").replace("(", r"\(")):
        read_scen(scen, grid)


def test_scen_without_version_line_is_refused(tmp_path):
    map_path, scen = write(tmp_path, [])
    scen.write_text("0\tm.map\t5\t3\t0\t0\t4\t2\t1\n")
    with pytest.raises(SpecError, match="field 'version' missing"):
        read_queries(scen, import_movingai(map_path, 0.5).grid)
