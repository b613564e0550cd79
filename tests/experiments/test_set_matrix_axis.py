"""``--set`` on an axis of a spec's ``[matrix]`` replaces the axis: ``--set n=60`` on Fig. 6's
``n = [15, 30, 60, 100]`` flies 60 robots once, as variant ``60``, not four variants of 60 robots
under the other sizes' names."""

import pytest

from swarmnav.errors import ConfigError
from swarmnav.experiments.spec import from_dict

SPEC = {"name": "sizes", "method": "apf", "scenario": "random_forest:density={density},seed={seed}",
        "scenario_vars": {"density": 0.25}, "steps": 3, "matrix": {"n": [15, 30, 60, 100]}}


def _variants(overrides):
    return [(v.name, v.n, v.scenario) for v in from_dict(SPEC, "sizes.toml", overrides, "1").variants]


def test_set_replaces_the_matrix_axis():
    assert [v[:2] for v in _variants({})] == [("15", 15), ("30", 30), ("60", 60), ("100", 100)]
    assert [v[:2] for v in _variants({"n": "60"})] == [("60", 60)]
    assert [v[:2] for v in _variants({"n": "30|100"})] == [("30", 30), ("100", 100)]
    two = _variants({"n": "60", "density": "0.35|0.45"})
    assert [v[:2] for v in two] == [("60[density=0.35]", 60), ("60[density=0.45]", 60)]
    assert "density=0.45," in two[1][2]


def test_set_on_a_matrix_axis_keeps_the_given_overrides_on_record():
    exp = from_dict(SPEC, "sizes.toml", {"n": "60"}, "1")
    assert exp.overrides == {"n": "60"}


def test_bad_value_for_a_matrix_axis_is_one_line():
    with pytest.raises(ConfigError, match="--set n"):
        _variants({"n": "sixty"})
