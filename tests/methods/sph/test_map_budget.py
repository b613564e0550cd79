"""SPH sizes its maps by the world: a world too large for them at its resolutions is refused before
anything is allocated (ConfigError, one line giving the size it would need and the limit,
``max_map_bytes``), and the size counted is the size the maps take."""

import contextlib
import copy
import io

import numpy as np
import pytest
from _helpers.cli import run_cli

from swarmnav.cli import main
from swarmnav.errors import ConfigError
from swarmnav.methods import registry
from swarmnav.methods.sph.method import map_bytes
from swarmnav.world import from_dict
from swarmnav.world.catalog import load_scenario

HUGE = {"name": "huge", "world": {"bounds": [-1e6, -1e6, 1e6, 1e6]}, "swarm": {"n": 5, "spawn": [0.0, 0.0, 4.0, 4.0]},
        "goal": {"position": [20.0, 2.0]}}
HUGE_LINE = ("sph: a 2000000 m x 2000000 m world at 0.1 m resolution needs 10.7 PiB of maps (limit 2 GiB: "
             "max_map_bytes); use a coarser resolution or a smaller world")


def _reset(method, scn):
    x = scn.spawn_positions(np.random.default_rng(0))
    method.reset(scn, x, np.zeros_like(x), np.random.default_rng(0))


def test_a_2000_km_world_is_refused_in_one_line_before_allocating():
    with pytest.raises(ConfigError) as e:
        _reset(registry.make("sph", preset="paper"), from_dict(HUGE))
    assert str(e.value) == HUGE_LINE


def test_cli_huge_world_exits_2_with_one_line(tmp_path):
    f = tmp_path / "big.toml"
    f.write_text("[world]\nbounds = [-1000000.0, -1000000.0, 1000000.0, 1000000.0]\n[swarm]\nn = 5\n"
                 "spawn = [0.0, 0.0, 4.0, 4.0]\n[goal]\nposition = [20.0, 2.0]\n")
    p = run_cli("run", "--method", "sph", "--scenario-file", f, "--out", tmp_path / "o", "--set", "preset=paper")
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    assert p.stderr.splitlines() == ["swarmnav: error: " + HUGE_LINE]
    err = io.StringIO()  # a coarser map and a larger limit say so in the message
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["run", "--method", "sph", "--scenario-file", str(f), "--out", str(tmp_path / "o"),
                     "--set", "preset=paper", "--set", "grid_resolution=1", "--set", "max_map_bytes=4e9"])
    assert code == 2 and err.getvalue().count("\n") == 1
    assert "at 0.1 m (ESDF) and 1 m (grid) resolution needs 2.92 PiB of maps (limit 3.73 GiB" in err.getvalue()


@pytest.mark.parametrize(("scene", "params"), [
    ("default_corridor", {}),
    ("default_corridor", {"preset": "queue", "plan_neighbours": 1.0, "grid_resolution": 0.2}),
    ("sph_cluttered_3d", {"n": 4}),
    ("sph_cluttered_3d", {"n": 4, "search_3d": "field", "esdf_resolution": 0.2}),
])
def test_the_count_is_what_the_maps_allocate_and_the_limit_is_exact(scene, params):
    params = dict(params)
    scn = load_scenario(scene, n=params.pop("n", None))
    m = registry.make("sph", **params)
    need = map_bytes(scn, m.params)
    _reset(m, scn)
    # the ESDF and the occupancy grids are counted as allocated; the searches' arrays on top
    assert m.esdf.values.nbytes == 8 * np.prod(m.esdf.shape)
    assert m.maps.grids.nbytes == scn.n * np.prod(m.maps.shape)
    assert need >= m.esdf.values.nbytes + m.maps.grids.nbytes + 17 * np.prod(m.maps.shape)
    # a limit one byte short refuses the scene, the limit itself lets it run
    with pytest.raises(ConfigError, match="needs .* of maps .*: max_map_bytes"):
        _reset(registry.make("sph", **params, max_map_bytes=int(need) - 1), scn)
    _reset(registry.make("sph", **params, max_map_bytes=int(np.ceil(need))), scn)


def test_yielding_and_more_robots_need_more():
    scn = load_scenario("default_corridor")
    paper = map_bytes(scn, registry.make("sph", preset="paper").params)
    assert map_bytes(scn, registry.make("sph", preset="queue").params) > paper
    assert map_bytes(scn.with_n(40), registry.make("sph", preset="paper").params) > paper
    big = copy.deepcopy(HUGE)
    big["world"]["bounds"] = [0.0, 0.0, 1e308, 10.0]  # a node count beyond a float: still one line
    with pytest.raises(ConfigError, match="needs over 1e308 B of maps"):
        _reset(registry.make("sph", esdf_resolution=0.01), from_dict(big))
