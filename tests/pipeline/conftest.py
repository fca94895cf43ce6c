import pytest
import yaml



@pytest.fixture
def write_pipeline(tmp_path):
    """Write a pipeline file `tmp_path/pipe.yaml` from a dict and return its path."""

    def write(data, name="pipe.yaml"):
        path = tmp_path / name
        path.write_text(yaml.safe_dump(data, sort_keys=False))
        return path

    return write


@pytest.fixture
def chain(tmp_path, write_pipeline):
    """a (from src.txt) -> b (from a) -> report-like c (from a, b); plus independent d."""
    (tmp_path / "src.txt").write_text("source v1\n")
    return write_pipeline({
        "name": "chain",
        "vars": {"data": "{pipeline_dir}"},
        "stages": [
            {"name": "a", "command": ["fake", "make", "{data}/src.txt"], "inputs": ["{data}/src.txt"],
             "output": "a.h5", "params": {"value": 2.0}},
            {"name": "b", "command": ["fake", "make", "{stages.a.output}"],
             "inputs": ["{stages.a.output}"], "output": "sub/b.h5"},
            {"name": "c", "command": ["fake", "make", "{stages.a.output}", "{stages.b.output}"],
             "inputs": ["{stages.a.output}", "{stages.b.output}"], "output": "c.h5"},
            {"name": "d", "command": ["fake", "make"], "output": "d.h5"},
        ]})
