"""Test modules have unique file names: the test folders are not packages, so pytest imports each
module by its base name, and a second module of the same name fails to collect."""

from collections import Counter
from pathlib import Path


def test_no_two_test_modules_share_a_name():
    names = Counter(path.name for path in Path(__file__).parent.rglob("test_*.py"))
    assert [name for name, count in names.items() if count > 1] == []
