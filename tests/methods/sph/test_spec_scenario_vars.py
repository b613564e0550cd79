"""``--set density=...`` reaches the forest generator through the spec's scenario_vars."""

import pytest

from swarmnav.errors import ConfigError
from swarmnav.experiments.spec import from_dict, load_experiment


def test_density_sweep_fills_the_scene_and_seed_stays_per_run():
    exp = load_experiment("sph-forest", overrides={"density": "0.15|0.45"}, seeds="1-20")
    assert [v.name for v in exp.variants] == ["default[density=0.15]", "default[density=0.45]"]
    assert exp.variants[1].scenario.startswith("random_forest:density=0.45,seed={seed}")
    assert exp.variants[0].params == {} and len(exp.seeds) == 20
    default = load_experiment("sph-forest", seeds="1")
    assert "density=0.25" in default.variants[0].scenario


def test_undeclared_placeholder_and_reserved_names_fail():
    base = {"method": "sph", "steps": 10, "scenario": "random_forest:density={dens},seed={seed}"}
    with pytest.raises(ConfigError, match="dens"):
        from_dict(base, "x.toml", {}, "1")
    with pytest.raises(ConfigError, match="scenario_vars"):
        from_dict({**base, "scenario_vars": {"n": 3}}, "x.toml", {}, "1")


def test_unknown_set_key_fails_at_load_with_its_name():
    # the spec gives a horizon in seconds, so loading builds the method's parameters (for its
    # dt) and a typo fails there, before any run
    with pytest.raises(ConfigError, match="densty"):
        load_experiment("sph-forest", overrides={"densty": "0.3"}, seeds="1")


def test_horizon_gives_equal_time_to_every_method():
    sph = load_experiment("sph-forest", seeds="1").variants[0]
    apf = load_experiment("sph-forest", overrides={"method": "apf"}, seeds="1").variants[0]
    assert sph.horizon == apf.horizon == 90.0
    assert sph.steps == 9000 and apf.steps == 900  # dt 0.01 s and 0.1 s
