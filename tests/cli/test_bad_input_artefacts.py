"""Bad artefacts given to every command that reads them (issue 18 classes 1-4): every command with a
MAP argument gets the map cases, step plan / baseline step / steps show / export the steps.h5
cases, nav refine the nav.h5 cases, dyn simulate the traj.h5 cases. Each must be refused before
any work with exit 2 and one line naming the file and the dataset (`bad_input_support`)."""

from __future__ import annotations

import pytest
from bad_input_support import (SENTINEL, assert_refused, few, invoke, leaf_commands, mutated,
                               with_value)
from hypothesis import given
from hypothesis import strategies as st

# Every command that reads a map.h5, as a valid invocation; {map} is replaced by the bad map.
MAP_COMMANDS = {
    ("map", "show"): ["{map}", "-o", "{out}.png"],
    ("steps", "generate"): ["{map}", "--robot", "scarab2", "--start", "-0.05", "0", "0",
                            "--goal", "0.05", "0", "0", "-o", "{out}.h5"],
    ("steps", "import"): ["{csv}", "--robot", "scarab2", "--map", "{map}", "-o", "{out}.h5"],
    ("steps", "show"): ["{steps}", "--map", "{map}", "-o", "{out}.png"],
    ("step", "plan"): ["{map}", "{steps}", "--steps", "0", "-o", "{out}.h5"],
    ("step", "show"): ["{motion}", "--map", "{map}", "-o", "{out}.png"],
    ("baseline", "step"): ["{map}", "{steps}", "--steps", "0", "-o", "{out}.h5"],
    ("nav", "search"): ["{map}", "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5", "-o", "{out}.h5"],
    ("nav", "refine"): ["{map}", "{nav}", "-o", "{out}.h5"],
    ("nav", "simulate"): ["{map}", "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5", "-o", "{out}.h5"],
    ("nav", "show"): ["{nav}", "--map", "{map}", "-o", "{out}.png"],
    ("baseline", "nav"): ["{map}", "--start", "-0.5", "-0.5", "--goal", "0.5", "0.5", "-o", "{out}.h5"],
    ("dyn", "plan"): ["{map}", "--robot", "anymal", "--start", "-0.2", "0", "0", "--goal", "0.2", "0", "0",
                      "-o", "{out}.h5"],
    ("dyn", "simulate"): ["{traj}", "{map}", "-o", "{out}.h5"],
    ("dyn", "replan"): ["{traj}", "{state}", "--map", "{map}", "-o", "{out}.h5"],
}

# (case, how the map file is broken, what the error line must name besides the file)
MAP_CASES = {
    "garbage bytes": (lambda ok, bad: bad.write_bytes(bytes(range(256)) * 4), "not an HDF5 file"),
    "HDF5 signature, then garbage": (lambda ok, bad: bad.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 4),
                                     "corrupt"),
    "empty": (lambda ok, bad: bad.write_bytes(b""), "not an HDF5 file"),
    "truncated": (lambda ok, bad: bad.write_bytes(ok.read_bytes()[:len(ok.read_bytes()) // 2]), "corrupt"),
    "wrong kind": (lambda ok, bad: bad.write_bytes(ok.with_name("steps.h5").read_bytes()), "'steps' artefact"),
    "missing sdf": (lambda ok, bad: mutated(ok, bad, "terrain/sdf", lambda a: None), "'/terrain/sdf'"),
    "NaN height cell": (lambda ok, bad: mutated(ok, bad, "terrain/height", with_value(4321, float("nan"))),
                        "'/terrain/height' holds NaN"),
    "inf costmap cell": (lambda ok, bad: mutated(ok, bad, "nav/costmap", with_value(77, float("inf"))),
                         "'/nav/costmap' holds NaN or inf"),
    "NaN SDF voxel": (lambda ok, bad: mutated(ok, bad, "terrain/sdf", with_value(999, float("nan"))),
                      "'/terrain/sdf' holds NaN"),
}


def _refuses(inputs, tmp_path, kind, cases, case, path, template):
    """Break the valid `kind` input as `cases[case]` says, run `path` + `template` on it with an
    existing output and --overwrite, and assert the contract (the older output stays)."""
    breaks, field = cases[case]
    bad = tmp_path / f"bad_{kind}.h5"
    breaks(inputs[kind], bad)
    values = {**{key: str(value) for key, value in inputs.items()}, kind: str(bad), "out": str(tmp_path / "out")}
    out = tmp_path / f"out{template[-1].removeprefix('{out}')}"
    out.write_bytes(SENTINEL)  # an older output: left byte-identical even with --overwrite
    result = invoke([*path, *(part.format(**values) for part in template), "--overwrite"])
    assert_refused(result, bad.name, field, output=out, before=SENTINEL)


def test_every_command_with_a_map_argument_has_map_cases():
    with_map = {path for path, command in leaf_commands()
                if any(p.name == "map_path" for p in command.params) or path == ("map", "show")}
    assert with_map == set(MAP_COMMANDS)


@pytest.mark.parametrize("case", sorted(MAP_CASES))
@pytest.mark.parametrize("path", sorted(MAP_COMMANDS), ids=" ".join)
def test_bad_map_is_refused_by_every_map_command(inputs, tmp_path, path, case):
    _refuses(inputs, tmp_path, "map", MAP_CASES, case, path, MAP_COMMANDS[path])


@few(20)
@given(layer=st.sampled_from(["terrain/height", "terrain/sdf", "nav/distance", "nav/costmap"]),
       index=st.integers(min_value=0), value=st.sampled_from([float("nan"), float("inf"), float("-inf")]))
def test_any_non_finite_map_value_is_refused(inputs, tmp_path, layer, index, value):
    bad = mutated(inputs["map"], tmp_path / "map_x.h5", layer, with_value(index, value))
    out = tmp_path / "steps_x.h5"
    result = invoke(["steps", "generate", bad, "--robot", "scarab2", "--start", "-0.05", "0", "0",
                     "--goal", "0.05", "0", "0", "-o", out])
    assert_refused(result, "map_x.h5", f"'/{layer}' holds NaN or inf", output=out)


STEPS_COMMANDS = {
    ("step", "plan"): ["{map}", "{steps}", "-o", "{out}.h5"],
    ("baseline", "step"): ["{map}", "{steps}", "-o", "{out}.h5"],
    ("steps", "show"): ["{steps}", "--map", "{map}", "-o", "{out}.png"],
    ("steps", "export"): ["{steps}", "-o", "{out}.csv"],
    ("steps", "import"): ["{steps}", "--robot", "scarab2", "--map", "{map}", "-o", "{out}.h5"],
}

STEPS_CASES = {
    "NaN quaternion": (lambda ok, bad: mutated(ok, bad, "q", with_value(25 + 6, float("nan"))), "'/q' holds NaN"),
    "non-unit quaternion": (lambda ok, bad: mutated(ok, bad, "q", with_value(25 + 6, 0.5)), "'/q' row 1"),
    "inf joint": (lambda ok, bad: mutated(ok, bad, "q", with_value(25 + 10, float("inf"))), "'/q' holds NaN or inf"),
    "missing stance": (lambda ok, bad: mutated(ok, bad, "stance", lambda a: None), "'/stance'"),
    "stance of the wrong shape": (lambda ok, bad: mutated(ok, bad, "stance", lambda a: a[:, :4]), "'/stance' has shape"),
    "NaN stance foothold": (lambda ok, bad: mutated(ok, bad, "footholds", with_value(0, float("nan"))),
                            "'/footholds' (stance legs) holds NaN"),
    "wrong kind": (lambda ok, bad: bad.write_bytes(ok.with_name("map.h5").read_bytes()), "'map' artefact"),
    "truncated": (lambda ok, bad: bad.write_bytes(ok.read_bytes()[:len(ok.read_bytes()) // 2]), "corrupt"),
}


@pytest.mark.parametrize("case", sorted(STEPS_CASES))
@pytest.mark.parametrize("path", sorted(STEPS_COMMANDS), ids=" ".join)
def test_bad_steps_file_is_refused_before_any_step_is_planned(inputs, tmp_path, path, case):
    _refuses(inputs, tmp_path, "steps", STEPS_CASES, case, path, STEPS_COMMANDS[path])


def _refined(ok, bad):
    result = invoke(["nav", "refine", ok.with_name("map.h5"), ok, "-o", bad, "-q"])
    assert result.exit_code == 0, result.stderr


NAV_CASES = {
    "already refined": (_refined, "already refined"),
    "NaN segment": (lambda ok, bad: mutated(ok, bad, "queries/0000/segments", with_value(3, float("nan"))),
                    "'/queries/0000/segments' holds NaN"),
    "segments of the wrong width": (lambda ok, bad: mutated(ok, bad, "queries/0000/segments", lambda a: a[:, :5]),
                                    "must have 9 columns"),
    "no segments": (lambda ok, bad: mutated(ok, bad, "queries/0000/segments", lambda a: None),
                    "has no dataset 'segments'"),
    "wrong kind": (lambda ok, bad: bad.write_bytes(ok.with_name("steps.h5").read_bytes()), "'steps' artefact"),
}


@pytest.mark.parametrize("case", sorted(NAV_CASES))
def test_bad_nav_file_is_refused_by_nav_refine(inputs, tmp_path, case):
    breaks, field = NAV_CASES[case]
    bad = tmp_path / "bad_nav.h5"
    breaks(inputs["nav"], bad)
    out = tmp_path / "refined.h5"
    assert_refused(invoke(["nav", "refine", inputs["map"], bad, "-o", out]), "bad_nav.h5", field, output=out)


@pytest.mark.parametrize("dataset", ["samples/base_pos", "samples/feet_pos", "goal"])
def test_non_finite_trajectory_is_refused_by_dyn_simulate(inputs, tmp_path, dataset):
    bad = mutated(inputs["traj"], tmp_path / "bad_traj.h5", f"tasks/0000/{dataset}", with_value(1, float("nan")))
    out = tmp_path / "sim.h5"
    result = invoke(["dyn", "simulate", bad, inputs["map"], "-o", out])
    assert_refused(result, "bad_traj.h5", f"dataset '/tasks/0000/{dataset}' holds NaN", output=out)


# Every other artefact argument (the map and steps ones are above): garbage, empty, truncated.
OTHER_ARTEFACT_ARGUMENTS = {  # (command, parameter): (valid kind to truncate, command line around {bad})
    (("compare",), "path_a"): ("steps", ["{bad}", "{steps}"]),
    (("compare",), "path_b"): ("steps", ["{steps}", "{bad}"]),
    (("dyn", "show"), "paths"): ("traj", ["{bad}", "-o", "{out}.png"]),
    (("dyn", "show"), "sims"): ("traj", ["{traj}", "{traj}", "--sim", "{bad}", "--sim", "{bad}", "-o", "{out}.png"]),
    (("learn", "ship"), "init_path"): ("traj", ["{bad}", "{traj}", "-o", "{out}"]),
    (("learn", "ship"), "held_out_path"): ("traj", ["{traj}", "{bad}", "-o", "{out}"]),
    (("dyn", "simulate"), "traj_path"): ("traj", ["{bad}", "{map}", "-o", "{out}.h5"]),
    (("dyn", "replan"), "traj_path"): ("traj", ["{bad}", "{state}", "--map", "{map}", "-o", "{out}.h5"]),
    (("export",), "path"): ("traj", ["{bad}", "-o", "{out}.csv"]),
    (("inspect",), "path"): ("nav", ["{bad}"]),
    (("learn", "train"), "dataset_paths"): ("map", ["{bad}", "-o", "{out}.h5"]),
    (("nav", "refine"), "nav_path"): ("nav", ["{map}", "{bad}", "-o", "{out}.h5"]),
    (("nav", "show"), "nav_path"): ("nav", ["{bad}", "--map", "{map}", "-o", "{out}.png"]),
    (("report",), "artefacts"): ("motion", ["{bad}", "-o", "{out}"]),
    (("step", "show"), "motion_path"): ("motion", ["{bad}", "--map", "{map}", "-o", "{out}.png"]),
}
ANY_ARTEFACT_CASES = {
    "garbage bytes": (lambda ok, bad: bad.write_bytes(bytes(range(256)) * 4), "not an HDF5 file"),
    "empty": (lambda ok, bad: bad.write_bytes(b""), "not an HDF5 file"),
    "truncated": (lambda ok, bad: bad.write_bytes(ok.read_bytes()[:len(ok.read_bytes()) // 2]), "corrupt"),
    "a directory": (lambda ok, bad: bad.mkdir(), "is a directory"),
}


def test_every_artefact_argument_has_cases():
    from legplan.cli.options import input_artefact

    covered = ({(path, "map_path") for path in MAP_COMMANDS} | {(("map", "show"), "path")}
               | {(path, "steps_path") for path in STEPS_COMMANDS} | set(OTHER_ARTEFACT_ARGUMENTS))
    arguments = {(path, param.name) for path, command in leaf_commands() for param in command.params
                 if param.type is input_artefact}
    assert arguments <= covered, arguments - covered


@pytest.mark.parametrize("case", sorted(ANY_ARTEFACT_CASES))
@pytest.mark.parametrize("key", sorted(OTHER_ARTEFACT_ARGUMENTS), ids=lambda k: f"{' '.join(k[0])} {k[1]}")
def test_unreadable_artefact_is_one_line_naming_it(inputs, tmp_path, key, case):
    kind, template = OTHER_ARTEFACT_ARGUMENTS[key]
    breaks, field = ANY_ARTEFACT_CASES[case]
    bad = tmp_path / "bad.h5"
    breaks(inputs[kind], bad)
    values = {**{name: str(path) for name, path in inputs.items()}, "bad": str(bad), "out": str(tmp_path / "out")}
    out = tmp_path / f"out{template[-1].removeprefix('{out}')}" if template[-1].startswith("{out}") else None
    result = invoke([*key[0], *(part.format(**values) for part in template)])
    assert_refused(result, "bad.h5", field, output=out)


DELETION_READERS = {  # artefact kind: the command that reads all of it
    "steps": ["steps", "export", "{bad}", "-o", "{out}.csv"],
    "nav": ["nav", "show", "{bad}", "--map", "{map}", "-o", "{out}.png"],
    "motion": ["step", "show", "{bad}", "--map", "{map}", "-o", "{out}.png"],
    "traj": ["dyn", "show", "{bad}", "-o", "{out}.png"],
}


def _items(path) -> list[tuple[str, str]]:
    """Every dataset, group and attribute of an HDF5 file as (kind, name) ("attr" names are
    "group@attribute")."""
    import h5py

    items = []
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            items.append(("item", name))
            items.extend(("attr", f"{name}@{key}") for key in obj.attrs)
        f.visititems(visit)
        items.extend(("attr", f"/@{key}") for key in f.attrs)
    return items


@few(25)
@given(data=st.data())
def test_a_deleted_dataset_or_attribute_is_never_a_traceback(inputs, tmp_path_factory, data):
    import h5py

    kind = data.draw(st.sampled_from(sorted(DELETION_READERS)))
    what = data.draw(st.sampled_from(["attr", "item"]))
    name = data.draw(st.sampled_from([name for other, name in _items(inputs[kind]) if other == what]))
    tmp_path = tmp_path_factory.mktemp("deleted")
    bad = tmp_path / "bad.h5"
    bad.write_bytes(inputs[kind].read_bytes())
    with h5py.File(bad, "r+") as f:
        if what == "item":
            del f[name]
        else:
            group, key = name.split("@")
            del f[group].attrs[key]
    values = {"bad": str(bad), "map": str(inputs["map"]), "out": str(tmp_path / "out")}
    result = invoke([part.format(**values) for part in DELETION_READERS[kind]])
    assert result.exit_code in (0, 2), f"{kind} without {name}: exit {result.exit_code} {result.exception!r}"
    if result.exit_code == 2:  # refused: by the contract; otherwise the item was not needed
        assert_refused(result, "bad.h5")


# Class 3: a start or goal off the map is bad input (exit 2 before any work), not a failed item.
OFF_MAP = [  # (command line on {map}, what the line names)
    (["steps", "generate", "{map}", "--robot", "scarab2", "--start", "-0.05", "0", "0", "--goal", "5", "0", "0"],
     "goal pose (5, 0, 0): base at (5.000, 0.000) is outside the map"),
    (["steps", "generate", "{map}", "--robot", "scarab2", "--start", "-0.95", "0", "0", "--goal", "0.05", "0", "0"],
     "start pose (-0.95, 0, 0): nominal foot"),
    (["nav", "search", "{map}", "--start", "-5", "0", "--goal", "0.5", "0.5"], "--start at (-5.000, 0.000)"),
    (["baseline", "nav", "{map}", "--start", "-0.5", "0", "--goal", "0.5", "9"], "--goal at (0.500, 9.000)"),
    (["nav", "simulate", "{map}", "--start", "-0.5", "-0.5", "--goal", "3", "0.5"], "--goal at (3.000, 0.500)"),
    (["nav", "simulate", "{map}", "--start", "-0.5", "-0.5", "--via", "0", "-4", "--goal", "0.5", "0.5"],
     "--via at (0.000, -4.000)"),
    (["dyn", "plan", "{map}", "--start", "0", "0", "0", "--goal", "4", "0", "0"], "off the map"),
]


@pytest.mark.parametrize("args, field", OFF_MAP, ids=lambda v: " ".join(v[:2]) if isinstance(v, list) else None)
def test_start_or_goal_off_the_map_is_refused_before_any_work(inputs, tmp_path, args, field):
    out = tmp_path / "out.h5"
    result = invoke([*(part.format(map=inputs["map"]) for part in args), "-o", out])
    assert_refused(result, "outside the map" if "outside" in field else "", field, output=out)


def test_an_off_map_query_row_names_the_file_and_row(inputs, tmp_path):
    queries = tmp_path / "queries.csv"
    queries.write_text("start_x,start_y,start_vx,start_vy,goal_x,goal_y,goal_vx,goal_vy\n"
                       "-0.5,-0.5,0,0,0.5,0.5,0,0\n-0.5,-0.5,0,0,0.5,7,0,0\n")
    out = tmp_path / "out.h5"
    for command in (["nav", "search"], ["baseline", "nav"]):
        result = invoke([*command, inputs["map"], "--queries", queries, "-o", out])
        assert_refused(result, "queries.csv: row 1: goal at (0.500, 7.000) is outside the map", output=out)
