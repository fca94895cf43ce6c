"""Bad text and image input files (issue 18 classes 1-4), per reader: every YAML/CSV/JSON/map-text
input of every command gets non-UTF-8 bytes, NUL bytes, an empty file, garbage text and arbitrary
bytes; images get truncated and garbage data; files with numbers get NaN/inf/huge/text cells. Each
must give exit 2 and one line naming the file (and the field where there is one), no output."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from bad_input_support import EXAMPLE_STEPS, assert_refused, few, invoke
from hypothesis import assume, given
from hypothesis import strategies as st

ROOT = Path(__file__).parents[2]

# Every reader of a text input, as a valid command line around it: {file} is the bad file (its
# suffix is the key's last part), {map} a valid map.h5, {out} the output that must not appear.
TEXT_READERS = {
    ("map build", ".yaml"): ["map", "build", "{file}", "-o", "{out}"],
    ("map import ros", ".yaml"): ["map", "import", "ros", "{file}", "-o", "{out}"],
    ("map import movingai", ".map"): ["map", "import", "movingai", "{file}", "--resolution", "0.1", "-o", "{out}"],
    ("steps import", ".csv"): ["steps", "import", "{file}", "--robot", "scarab2", "--map", "{map}", "-o", "{out}"],
    ("steps import", ".json"): ["steps", "import", "{file}", "--robot", "scarab2", "--map", "{map}", "-o", "{out}"],
    ("steps import", ".yaml"): ["steps", "import", "{file}", "--robot", "scarab2", "--map", "{map}", "-o", "{out}"],
    ("pipeline run", ".yaml"): ["pipeline", "run", "{file}", "-o", "{out}"],
    ("pipeline show", ".yaml"): ["pipeline", "show", "{file}"],
    ("nav search --queries", ".csv"): ["nav", "search", "{map}", "--queries", "{file}", "-o", "{out}"],
    ("baseline nav --queries", ".csv"): ["baseline", "nav", "{map}", "--queries", "{file}", "-o", "{out}"],
    ("nav simulate --hidden-obstacles", ".yaml"): ["nav", "simulate", "{map}", "--start", "-0.5", "-0.5", "--goal",
                                                   "0.5", "0.5", "--hidden-obstacles", "{file}", "-o", "{out}"],
    ("dyn plan --tasks", ".csv"): ["dyn", "plan", "{map}", "--robot", "anymal", "--tasks", "{file}", "-o", "{out}"],
    ("dyn plan --tasks", ".yaml"): ["dyn", "plan", "{map}", "--robot", "anymal", "--tasks", "{file}", "-o", "{out}"],
    ("dyn plan --costs", ".yaml"): ["dyn", "plan", "{map}", "--robot", "anymal", "--start", "-0.2", "0", "0",
                                    "--goal", "0.2", "0", "0", "--costs", "{file}", "-o", "{out}"],
    ("learn dataset", ".yaml"): ["learn", "dataset", "{file}", "--n", "2", "-o", "{out}"],
    ("learn cycle", ".yaml"): ["learn", "cycle", "{file}", "--n", "2", "-o", "{out}"],
    ("learn train --weights", ".yaml"): ["learn", "train", "{map}", "--weights", "{file}", "-o", "{out}"],
    ("robot show", ".yaml"): ["robot", "show", "{file}", "--json"],
}

TEXT_CASES = {
    "non-UTF-8 bytes": (b"name: \xff\xfe\xfd\n" + bytes(range(128, 256)), "not UTF-8 text"),
    "binary garbage": (bytes(range(256)) * 3, "not UTF-8 text"),
    "NUL bytes": (b"x,y\n\x00\x00\x001,2\n", "NUL byte"),
    "empty": (b"", ""),
    "garbage text": ("}{ ][ ::: ,,, \t\"'\n\u00e9\u6f22\n".encode(), ""),
}


def _refused(inputs, tmp_path, template, bad: Path, *names: str):
    out = tmp_path / "out.h5"
    args = [part.format(file=bad, map=inputs["map"], out=out) for part in template]
    return assert_refused(invoke(args), bad.name, *names, output=out)


@pytest.mark.parametrize("case", sorted(TEXT_CASES))
@pytest.mark.parametrize("reader", sorted(TEXT_READERS), ids=lambda r: f"{r[0]} {r[1]}")
def test_bad_text_file_is_one_line_naming_it(inputs, tmp_path, reader, case):
    content, field = TEXT_CASES[case]
    bad = tmp_path / f"bad{reader[1]}"
    bad.write_bytes(content)
    _refused(inputs, tmp_path, TEXT_READERS[reader], bad, field)


@few(30)
@given(reader=st.sampled_from(sorted(TEXT_READERS)), content=st.binary(max_size=300))
def test_arbitrary_bytes_never_give_a_traceback(inputs, tmp_path_factory, reader, content):
    tmp_path = tmp_path_factory.mktemp("bytes")
    bad = tmp_path / f"bad{reader[1]}"
    bad.write_bytes(content)
    _refused(inputs, tmp_path, TEXT_READERS[reader], bad)


# Images: the ROS map's PGM and the heightmap importer's PGM/PNG/NPY.
IMAGE_CASES = {
    "truncated P5 data": (b"P5\n4 4\n255\n" + bytes(7), "truncated or corrupt image"),
    "truncated header": (b"P5\n4", "truncated or corrupt image"),
    "garbage": (bytes(range(256)) * 2, "not a readable PGM/PNG image"),
    "empty": (b"", "not a readable PGM/PNG image"),
}


@pytest.mark.parametrize("case", sorted(IMAGE_CASES))
def test_bad_ros_image_is_one_line_naming_it(inputs, tmp_path, case):
    content, field = IMAGE_CASES[case]
    (tmp_path / "bad.pgm").write_bytes(content)
    spec = tmp_path / "map.yaml"
    spec.write_text("image: bad.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n")
    out = tmp_path / "out.h5"
    line = assert_refused(invoke(["map", "import", "ros", spec, "-o", out]), "bad.pgm", field, output=out)
    assert "map.yaml" not in line  # the image is named, not the YAML that points to it


@pytest.mark.parametrize("suffix", [".pgm", ".png"])
@pytest.mark.parametrize("case", sorted(IMAGE_CASES))
def test_bad_heightmap_image_is_one_line_naming_it(inputs, tmp_path, case, suffix):
    content, field = IMAGE_CASES[case]
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(content)
    _refused(inputs, tmp_path, ["map", "import", "heightmap", "{file}", "--resolution", "0.05", "-o", "{out}"],
             bad, field)


def test_truncated_png_is_one_line(inputs, tmp_path):
    good = tmp_path / "good.png"
    result = invoke(["map", "show", inputs["map"], "-o", good])
    assert result.exit_code == 0, result.stderr
    bad = tmp_path / "cut.png"
    bad.write_bytes(good.read_bytes()[:len(good.read_bytes()) // 2])
    _refused(inputs, tmp_path, ["map", "import", "heightmap", "{file}", "--resolution", "0.05", "-o", "{out}"],
             bad, "truncated or corrupt image")


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_npy_heightmap_is_refused(inputs, tmp_path, value):
    import numpy as np

    array = np.zeros((20, 20))
    array[3, 4] = value
    bad = tmp_path / "bad.npy"
    np.save(bad, array)
    _refused(inputs, tmp_path, ["map", "import", "heightmap", "{file}", "--resolution", "0.05", "-o", "{out}"],
             bad, "'height'")


def test_truncated_files_name_the_file_and_what_is_missing(inputs, tmp_path):
    cases = [  # (valid source, cut after this many characters, command, what the line names)
        (EXAMPLE_STEPS, len(EXAMPLE_STEPS.read_text()) - 60, TEXT_READERS[("steps import", ".csv")], "row 2: has"),
        (ROOT / "maps" / "movingai" / "rooms.map", 2000, TEXT_READERS[("map import movingai", ".map")],
         "field 'map' must have 128 rows"),
        (ROOT / "maps" / "flat.yaml", 120, TEXT_READERS[("map build", ".yaml")], "invalid YAML at line"),
    ]
    for source, cut, template, field in cases:
        bad = tmp_path / f"cut{source.suffix}"
        bad.write_text(source.read_text()[:cut])
        _refused(inputs, tmp_path, template, bad, field)


# Numbers inside files: every numeric cell of a steps CSV, queries and tasks CSVs, specs.
BAD_CELLS = ["nan", "inf", "-inf", "1e999", "abc", "true"]
STEPS_HEADER = EXAMPLE_STEPS.read_text().splitlines()[1].split(",")
NUMERIC_COLUMNS = [c for c in STEPS_HEADER if not c.startswith("stance_")]


@few(30)
@given(column=st.sampled_from(NUMERIC_COLUMNS), row=st.integers(0, 2), bad=st.sampled_from(BAD_CELLS))
def test_non_finite_cell_of_a_steps_csv_names_row_and_field(inputs, tmp_path_factory, column, row, bad):
    tmp_path = tmp_path_factory.mktemp("cell")
    lines = EXAMPLE_STEPS.read_text().splitlines()
    cells = lines[2 + row].split(",")
    if column.startswith("foothold_"):  # a swing leg's foothold cells are ignored (README), stance legs' read
        assume(cells[STEPS_HEADER.index(f"stance_{column.split('_')[1]}")] == "1")
    cells[STEPS_HEADER.index(column)] = bad
    lines[2 + row] = ",".join(cells)
    csv_path = tmp_path / "steps.csv"
    csv_path.write_text("\n".join(lines) + "\n")
    _refused(inputs, tmp_path, TEXT_READERS[("steps import", ".csv")], csv_path, f"row {row}", f"'{column}'")


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity", "1e999"])
def test_non_finite_number_in_a_steps_json_is_refused(inputs, tmp_path, literal):
    lines = EXAMPLE_STEPS.read_text().splitlines()[1:]
    header = lines[0].split(",")
    record = dict(zip(header, (float(v) for v in lines[1].split(",")), strict=True))
    text = json.dumps({"configurations": [record]}).replace('"z": 0.10194', f'"z": {literal}')
    bad = tmp_path / "steps.json"
    bad.write_text(text)
    _refused(inputs, tmp_path, TEXT_READERS[("steps import", ".json")], bad, "row 0", "'z'")


def test_duplicate_csv_column_is_named_once(inputs, tmp_path):
    lines = EXAMPLE_STEPS.read_text().splitlines()
    lines[1] += ",x"
    lines[2:] = [line + ",0.0" for line in lines[2:]]
    bad = tmp_path / "dup.csv"
    bad.write_text("\n".join(lines) + "\n")
    _refused(inputs, tmp_path, TEXT_READERS[("steps import", ".csv")], bad, "duplicate column 'x'")


QUERY_HEADER = "start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy"
TASK_HEADER = "start_x,start_y,start_yaw,goal_x,goal_y,goal_yaw"


@pytest.mark.parametrize("bad", ["nan", "inf", "1e999"])
@pytest.mark.parametrize("reader, header, column", [
    (("nav search --queries", ".csv"), QUERY_HEADER, "goal_y"),
    (("baseline nav --queries", ".csv"), QUERY_HEADER, "start_vx"),
    (("dyn plan --tasks", ".csv"), TASK_HEADER, "goal_yaw"),
])
def test_non_finite_cell_of_a_table_names_row_and_field(inputs, tmp_path, reader, header, column, bad):
    names = header.split(",")
    cells = ["0.1"] * len(names)
    cells[names.index(column)] = bad
    table = tmp_path / "table.csv"
    table.write_text(f"{header}\n{','.join(['0.2'] * len(names))}\n{','.join(cells)}\n")
    _refused(inputs, tmp_path, TEXT_READERS[reader], table, "row 1", f"'{column}'")


@pytest.mark.parametrize("bad", [".nan", ".inf", "-.inf", "1e999"])
def test_non_finite_number_in_a_map_spec_names_the_field(inputs, tmp_path, bad):
    spec = tmp_path / "spec.yaml"
    spec.write_text(f"name: s\nresolution: {bad}\nextent: {{x: [-1, 1], y: [-1, 1]}}\nprimitives: []\n")
    _refused(inputs, tmp_path, TEXT_READERS[("map build", ".yaml")], spec, "resolution")


@pytest.mark.parametrize("bad", ["nan", "inf", "abc"])
def test_non_finite_param_value_names_the_parameter(inputs, tmp_path, bad):
    out = tmp_path / "out.h5"
    for args, key in [(["nav", "search", inputs["map"], "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5"], "weight"),
                      (["step", "plan", inputs["map"], inputs["steps"]], "epsilon")]:
        result = invoke([*args, "--param", f"{key}={bad}", "-o", out])
        assert_refused(result, "--param", f"'{key}'", output=out)


def test_broken_urdf_is_one_line_without_the_parser_s_own_lines(tmp_path, capfd):
    robot = ROOT / "robots" / "scarab2"
    (tmp_path / "robot.yaml").write_bytes((robot / "robot.yaml").read_bytes())
    (tmp_path / "robot.urdf").write_bytes((robot / "robot.urdf").read_bytes()[:300])  # cut inside the XML
    result = invoke(["robot", "show", tmp_path / "robot.yaml", "--json"])
    native = capfd.readouterr().err  # what urdfdom writes to file descriptor 2 directly
    assert "urdf_parser" not in native and "XML_ERROR" not in native, native
    line = assert_refused(result, "robot.yaml", "field 'urdf' cannot be parsed")
    assert "XML_ERROR" in line  # urdfdom's reason, folded into our line


def test_robot_init_of_a_broken_urdf_is_one_line_without_the_parser_s_own_lines(tmp_path, capfd):
    urdf = tmp_path / "cut.urdf"
    urdf.write_bytes((ROOT / "tests" / "data" / "hexapod.urdf").read_bytes()[:400])
    out = tmp_path / "robot"
    result = invoke(["robot", "init", urdf, "-o", out])
    native = capfd.readouterr().err
    assert "urdf_parser" not in native and "XML_ERROR" not in native, native
    assert_refused(result, "cut.urdf", "cannot be parsed by pinocchio", output=out)


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_value_in_an_hdf5_steps_file_names_row_and_field(inputs, tmp_path, value):
    import h5py

    lines = EXAMPLE_STEPS.read_text().splitlines()[1:]
    header = lines[0].split(",")
    rows = [[float(cell) if cell else float("nan") for cell in line.split(",")] for line in lines[1:]]
    columns = list(zip(*rows, strict=True))  # empty cells (swing legs' footholds) as NaN, as exported
    bad = tmp_path / "steps.h5"
    with h5py.File(bad, "w") as f:
        for name, column in zip(header, columns, strict=True):
            f.create_dataset(f"configurations/{name}", data=[value if name == "femur_lf" and i == 2 else v
                                                             for i, v in enumerate(column)])
    _refused(inputs, tmp_path, TEXT_READERS[("steps import", ".csv")], bad, "row 2", "'femur_lf'")
