"""Pipeline file validation: one-line SpecErrors naming the file and the field."""

import pytest

from legplan.errors import SpecError
from legplan.pipeline import load_pipeline, resolve_stage


def stage(name, command=("fake", "make"), **extra):
    return {"name": name, "command": list(command), "output": f"{name}.h5", **extra}


@pytest.mark.parametrize("stages, message", [
    ([stage("a", command=["fake", "make", "{stages.nope.output}"])],
     "field 'stages.a.command' references unknown stage 'nope'"),
    ([stage("a", inputs=["{stages.b.output}"]), stage("b", inputs=["{stages.a.output}"])],
     "dependency cycle: a -> b -> a"),
    ([{"name": "a", "output": "a.h5"}], "missing field 'stages.a.command'"),
    ([{"name": "a", "command": ["x"]}], "missing field 'stages.a.output'"),
    ([stage("a"), stage("a")], "names stage 'a' twice"),
    ([stage("a", command=["fake", "{undefined}"])], "undefined placeholder '{undefined}'"),
    ([stage("a", inputs=["{stages.a.output}"])], "references its own output"),
    ([stage("a", colour="red")], "unknown field 'stages.a.colour'"),
    ([{"name": "r", "command": ["report"], "output": "report/"}], "field 'stages.r.provenance' is required"),
    ([stage("a", params={"x": {"nested": [1]}})], "field 'stages.a.params.x' must be a scalar"),
    ([{"name": "a", "command": ["x"], "output": "../escape.h5"}], "must stay inside the output directory"),
])
def test_spec_errors_name_file_and_field(write_pipeline, stages, message):
    path = write_pipeline({"stages": stages})
    with pytest.raises(SpecError) as info:
        load_pipeline(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ") and message in text and "\n" not in text


def test_bad_yaml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("stages: [\n")
    with pytest.raises(SpecError, match=r"bad.yaml: invalid YAML"):
        load_pipeline(bad)
    with pytest.raises(SpecError, match=r"missing.yaml: cannot read pipeline file"):
        load_pipeline(tmp_path / "missing.yaml")


def test_order_dependencies_and_resolution(tmp_path, write_pipeline):
    path = write_pipeline({"vars": {"data": "{pipeline_dir}/../data"}, "stages": [
        stage("report", command=["report", "{stages.a.output}", "{stages.b.output}"], output="rep/",
              provenance="rep/report.h5"),
        stage("b", command=["fake", "make", "{stages.a.output}"], params={"flag": True, "off": False,
                                                                        "param": {"x": 1, "y": 2},
                                                                        "start": [-0.6, 0, 0]}),
        stage("a", command=["fake", "make", "{data}/in.yaml"], inputs=["{data}/in.yaml"]),
    ]})
    pipeline = load_pipeline(path)
    assert [s.name for s in pipeline.stages] == ["a", "b", "report"]
    assert pipeline.stage("report").depends_on == ("a", "b")
    assert pipeline.dependants("a") == {"b", "report"}
    out = tmp_path / "out"
    a = resolve_stage(pipeline, pipeline.stage("a"), out)
    data = tmp_path.parent / "data" / "in.yaml"
    assert a.argv == ("fake", "make", str(data), "-o", str(out / "a.h5"), "--overwrite")
    assert a.inputs == (data,)
    b = resolve_stage(pipeline, pipeline.stage("b"), out)
    assert b.argv[3:13] == ("--flag", "--param", "x=1", "--param", "y=2", "--start", "-0.6", "0", "0", "-o")
    report = resolve_stage(pipeline, pipeline.stage("report"), out)
    assert report.output == out / "rep" and report.provenance == out / "rep" / "report.h5"


def test_a_pipeline_file_that_is_not_a_mapping_is_one_line(tmp_path):
    path = tmp_path / "list.yaml"
    path.write_text("- name: a\n")
    with pytest.raises(SpecError, match=f"^{path}: pipeline file must be a YAML mapping$"):
        load_pipeline(path)
