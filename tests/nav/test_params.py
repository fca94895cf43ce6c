"""NavParams overrides go through specio.apply_overrides from an instance (robot limits kept)."""

import pytest

from legplan.errors import SpecError
from legplan.nav.params import NavParams


def test_overrides_start_from_the_instance_and_convert_bools_and_ints():
    base = NavParams(v_max=0.5, a_max=0.8)
    changed = base.with_overrides({"geodesic_bound": "off", "restarts": "Yes", "mu": "3", "weight": "2.5"})
    assert (changed.v_max, changed.a_max) == (0.5, 0.8)  # kept from the instance, not the defaults
    assert changed.geodesic_bound is False and changed.restarts is True
    assert changed.mu == 3 and isinstance(changed.mu, int) and changed.weight == 2.5


@pytest.mark.parametrize("overrides, message", [
    ({"geodesic_bound": "maybe"}, "field 'geodesic_bound' must be true or false"),
    ({"mu": "2.5"}, "field 'mu' must be a whole number"),
    ({"weight": "nan"}, "'weight'"),
    ({"bogus": "1"}, "nav parameters: field 'bogus' is unknown"),
])
def test_bad_overrides_name_the_key(overrides, message):
    with pytest.raises(SpecError, match=message):
        NavParams().with_overrides(overrides)
