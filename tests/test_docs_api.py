"""docs/api.md's examples run as written, in order in one namespace, from a temporary directory
outside the repository; what they show (a planned step, a planned and executed dyn task) holds."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def python_blocks(path: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), re.S | re.M)


def test_api_examples_run_from_outside_the_repository(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    blocks = python_blocks(ROOT / "docs" / "api.md")
    assert len(blocks) == 3
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "docs/api.md", "exec"), namespace)  # noqa: S102 - the documented examples
    assert (tmp_path / "flat.h5").is_file()
    assert namespace["feet"].shape == (1, 6, 3)
    step = namespace["step"]
    assert step.success and step.control_points.shape[1] == namespace["robot"].nx
    assert namespace["check"].shortfall_foot_slip <= 0
    assert namespace["result"].success and not namespace["executed"].fell
