"""legplan.geometry.ordered: numpy's set routines and median, without numpy.ma, give numpy's answers."""

import subprocess
import sys

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from legplan.geometry.ordered import median, sorted_difference, sorted_union, sorted_unique

# finite values with many repeats (a few distinct values), including ±0 and the extremes
FLOATS = st.sampled_from([0.0, -0.0, 1e-300, 0.01, 0.02, 0.1 + 0.2, 0.3, 2.4, -7.5, 1e300, np.inf, -np.inf])
VALUES = st.one_of(arrays(np.float64, st.integers(0, 40), elements=FLOATS),
                   arrays(np.float64, st.integers(0, 40), elements=st.floats(-1e3, 1e3)),
                   arrays(np.int64, st.integers(0, 40), elements=st.integers(-5, 5)))


def same(ours, numpy_answer) -> bool:
    """Equal values and dtypes, bit for bit (a zero's sign aside: ±0 are one entry of a set)."""
    return ours.dtype == numpy_answer.dtype and ours.shape == numpy_answer.shape and bool(np.all(ours == numpy_answer))


@settings(max_examples=300, deadline=None)
@given(a=VALUES, b=VALUES)
def test_set_routines_match_numpy(a, b):
    assert same(sorted_unique(a), np.unique(a))
    assert same(sorted_unique(a.reshape(-1, 1)), np.unique(a.reshape(-1, 1)))
    if a.dtype == b.dtype:
        assert same(sorted_union(a, b), np.union1d(a, b))
        assert same(sorted_difference(a, b), np.setdiff1d(a, b))


@settings(max_examples=300, deadline=None)
@given(a=VALUES.filter(len))
def test_median_matches_numpy_bit_for_bit(a):
    expected = float(np.median(a))
    assert median(a) == expected or (np.isnan(expected) and np.isnan(median(a)))  # inf - inf: NaN both
    assert np.signbit(median(a)) == np.signbit(expected) or median(a) == 0.0


def test_median_of_nan_is_nan_and_of_lists_as_numpy():
    assert np.isnan(median([1.0, np.nan, 3.0]))
    assert median([3, 1, 2]) == 2.0 and median([4, 1, 2, 3]) == 2.5 and median([0.1, 0.2]) == float(np.median([0.1, 0.2]))


def test_sample_times_of_a_plan_merge_as_numpy_does():
    t = np.append(np.arange(0.0, 2.4, 0.05), 2.4)
    swing = np.linspace(0.13, 0.47, 9)
    assert same(sorted_union(sorted_union(t, swing), t[::3]), np.union1d(np.union1d(t, swing), t[::3]))
    assert same(sorted_difference(swing, t), np.setdiff1d(swing, t))
    assert same(sorted_difference(t, np.array([])), np.setdiff1d(t, np.array([])))


def test_importing_and_using_them_leaves_numpy_ma_out():
    code = ("import sys, numpy as np\nfrom legplan.geometry.ordered import *\n"
            "sorted_union(np.arange(3.0), [1.5]); sorted_difference([1.0, 2.0], [2.0]); median([1.0, 2.0])\n"
            "assert 'numpy.ma' not in sys.modules\n"
            "np.unique(np.arange(3.0)); assert 'numpy.ma' in sys.modules  # numpy's own would import it\n")
    subprocess.run([sys.executable, "-c", code], check=True)
