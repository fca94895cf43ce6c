"""legplan.cache: stored scipy.ndimage results are the filter's own bytes, keyed by content, never stale,
and a store that cannot be read or written only costs the computation."""

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import ndimage

from legplan.cache import cache_dir, filtered, key


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("LEGPLAN_CACHE_DIR", str(tmp_path / "store"))
    return tmp_path / "store"


def _height(seed=0):
    rng = np.random.default_rng(seed)
    return np.round(rng.uniform(0.0, 0.2, (40, 50)), 2)


@pytest.mark.parametrize("function, args, kwargs", [
    ("gaussian_filter", (2.0,), {"mode": "nearest"}),
    ("maximum_filter", (), {"footprint": np.ones((3, 3), bool), "mode": "nearest"}),
    ("maximum_filter", (), {"size": 5, "mode": "nearest"}),
])
def test_stored_result_is_the_filters_result(store, function, args, kwargs):
    h = _height()
    expected = getattr(ndimage, function)(h, *args, **kwargs)
    first = filtered(function, h, *args, **kwargs)
    assert len(list(store.glob(f"{function}-*.npy"))) == 1
    second = filtered(function, h, *args, **kwargs)
    for got in (first, second):
        assert got.dtype == expected.dtype and got.shape == expected.shape
        assert np.array_equal(got, expected)


def test_distance_transform_of_a_mask(store):
    edge = _height() > 0.15
    expected = ndimage.distance_transform_edt(~edge)
    assert np.array_equal(filtered("distance_transform_edt", ~edge), expected)
    assert np.array_equal(filtered("distance_transform_edt", ~edge), expected)


def test_every_input_is_in_the_key():
    h = _height()
    base = key("maximum_filter", (h,), {"size": 3, "mode": "nearest"})
    changed = h.copy()
    changed[7, 9] += 0.01
    others = [key("maximum_filter", (changed,), {"size": 3, "mode": "nearest"}),      # content
              key("maximum_filter", (h.reshape(50, 40),), {"size": 3, "mode": "nearest"}),  # shape
              key("maximum_filter", (h.astype(np.float32),), {"size": 3, "mode": "nearest"}),  # dtype
              key("maximum_filter", (h,), {"size": 5, "mode": "nearest"}),          # an option
              key("maximum_filter", (h,), {"size": 3, "mode": "reflect"}),
              key("minimum_filter", (h,), {"size": 3, "mode": "nearest"})]          # the filter
    assert base == key("maximum_filter", (h.copy(),), {"mode": "nearest", "size": 3})
    assert len({base, *others}) == len(others) + 1


def test_changed_map_is_computed_not_read(store):
    h = _height()
    filtered("gaussian_filter", h, 2.0, mode="nearest")
    h2 = h.copy()
    h2[10:20, 10:20] = 0.5
    assert np.array_equal(filtered("gaussian_filter", h2, 2.0, mode="nearest"),
                          ndimage.gaussian_filter(h2, 2.0, mode="nearest"))
    assert len(list(store.glob("*.npy"))) == 2


def test_damaged_file_is_recomputed_and_replaced(store):
    h = _height()
    filtered("maximum_filter", h, size=3, mode="nearest")
    (path,) = store.glob("*.npy")
    path.write_bytes(path.read_bytes()[:60])  # cut short
    expected = ndimage.maximum_filter(h, size=3, mode="nearest")
    assert np.array_equal(filtered("maximum_filter", h, size=3, mode="nearest"), expected)
    assert np.array_equal(np.load(path), expected)  # replaced by a whole one


def test_unwritable_store_still_computes(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("LEGPLAN_CACHE_DIR", str(blocker / "store"))
    h = _height()
    assert np.array_equal(filtered("maximum_filter", h, size=3, mode="nearest"),
                          ndimage.maximum_filter(h, size=3, mode="nearest"))


def test_empty_setting_turns_the_store_off(tmp_path, monkeypatch):
    monkeypatch.setenv("LEGPLAN_CACHE_DIR", "")
    monkeypatch.chdir(tmp_path)
    assert cache_dir() is None
    filtered("maximum_filter", _height(), size=3, mode="nearest")
    assert not list(tmp_path.rglob("*.npy"))


def test_default_folder_follows_xdg(tmp_path, monkeypatch):
    monkeypatch.delenv("LEGPLAN_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_dir() == tmp_path / "legplan"


def test_stored_result_needs_no_scipy_ndimage(store):
    """A process that finds the result stored reads it without importing scipy.ndimage."""
    code = """
import sys
import numpy as np
from legplan.cache import filtered
h = np.round(np.random.default_rng(0).uniform(0.0, 0.2, (40, 50)), 2)
out = filtered("gaussian_filter", h, 2.0, mode="nearest")
print(int("scipy.ndimage" in sys.modules), float(out.sum()))
"""
    def run():
        return subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True,
                              env={**os.environ, "LEGPLAN_CACHE_DIR": str(store)}).stdout.split()

    first, second = run(), run()
    assert first[0] == "1" and second[0] == "0"
    assert first[1] == second[1]
