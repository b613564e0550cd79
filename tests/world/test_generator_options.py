"""Generator specs: every option of every generator is read with its type and checked against its
range, from a spec string and from Python alike; bad options end in one ScenarioError line that
names the generator, the option and its valid values (exit 2 in the CLI), never a traceback."""

import contextlib
import inspect
import io
import math

import pytest
from _helpers.cli import run_cli
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from swarmnav.cli import main
from swarmnav.errors import ScenarioError
from swarmnav.world.catalog import load_scenario
from swarmnav.world.generators import GENERATORS, OPTIONS, periodic_box, random_forest
from swarmnav.world.scenario import Scenario


def _cli(*args: str) -> tuple[int, str]:
    """``swarmnav ARGS`` in-process: exit code and stderr (an uncaught exception fails the test)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(list(args))
    return code, err.getvalue()


def test_every_generator_argument_is_a_declared_option():
    """The option table is the spec grammar: a generator argument missing from it could not be given
    in a spec (``max_tries``, a safety cap for Python callers, is deliberately not an option)."""
    assert set(OPTIONS) == set(GENERATORS)
    for name, fn in GENERATORS.items():
        args = set(inspect.signature(fn).parameters) - {"max_tries"}
        assert set(OPTIONS[name]) == args, name


@pytest.mark.parametrize("name", sorted(GENERATORS))
def test_every_default_is_a_valid_option(name):
    for key, p in inspect.signature(GENERATORS[name]).parameters.items():
        if key in OPTIONS[name]:
            kind, valid, _, _ = OPTIONS[name][key]
            assert isinstance(p.default, kind), (key, p.default)
            assert valid is None or p.default in valid, (key, p.default, valid)


@pytest.mark.parametrize(("spec", "message"), [
    ("random_forest:n=0", "random_forest: n must be in [1, 1000000], got 0"),
    ("random_forest:n=-2", "random_forest: n must be in [1, 1000000], got -2"),
    ("random_forest:n=2.5", "random_forest: n must be an integer in [1, 1000000], got '2.5'"),
    ("random_forest:width=1", "random_forest: width must be in [8, 200] m (the 8 m wide spawn area lies between "
                              "the side walls), got 1.0"),
    ("random_forest:density=abc", "random_forest: density must be a number in [0, 0.55)"),
    ("random_forest:density=nan", "random_forest: density must be in [0, 0.55)"),
    ("random_forest:seed=abc", "random_forest: seed must be an integer in [0, inf), got 'abc'"),
    ("random_forest:seed=-1", "random_forest: seed must be in [0, inf), got -1"),
    ("random_forest:length=0", "random_forest: length must be in (0, 200] m, got 0.0"),
    ("random_forest:length=1e999", "random_forest: length must be in (0, 200] m, got inf"),
    ("random_forest:max_forests=0", "random_forest: max_forests must be in [1, 10000], got 0"),
    ("random_forest:height=-6", "random_forest: height must be in [0, 100] m"),
    ("random_forest:r_max=6,width=10", "need 2 r_max <= length and width"),
    ("random_forest:min_passage=20", "min_passage must be < width"),
    ("random_forest:max_tries=5", "unknown parameter 'max_tries' for random_forest"),
    ("random_forest:n=3,n=4", "random_forest option 'n' is given twice"),
    ("random_forest_3d:width=4", "random_forest_3d: width must be in [6, 200] m (the 6 m wide spawn box"),
    ("random_forest_3d:height=1.5", "random_forest_3d: height must be in [2, 100] m"),
    ("random_forest_3d:overlap=1", "random_forest_3d: overlap must be true or false, got '1'"),
    ("random_forest_3d:n=1e7", "random_forest_3d: n must be in [1, 1000000], got 10000000"),
    ("periodic_box:rho=0", "periodic_box: rho must be in (0, inf) 1/m^2, got 0.0"),
    ("periodic_box:n=-5", "periodic_box: n must be in [1, 1000000], got -5"),
    ("hwvem_mission_family:passage_width=7", "hwvem_mission_family: passage_width must be in (0, 6.8) m"),
    ("hwvem_mission_family:turn_scale=-1", "hwvem_mission_family: turn_scale must be in [0, 10], got -1.0"),
    ("hwvem_mission_family:tiny_offset=x", "hwvem_mission_family: tiny_offset must be a number in [0, 9.75] m"),
    ("hwvem_mission_family:n=0", "hwvem_mission_family: n must be in [1, 1000000], got 0"),
])
def test_bad_option_names_generator_option_and_range(spec, message):
    with pytest.raises(ScenarioError) as e:
        load_scenario(spec)
    assert message in str(e.value) and "\n" not in str(e.value)
    code, err = _cli("scenarios", "show", spec)
    assert code == 2 and err.count("\n") == 1 and message in err, err


def test_integer_options_take_integral_numbers_and_python_calls_are_checked_alike():
    assert load_scenario("random_forest:n=15.0,seed=1e0").n == 15
    assert isinstance(load_scenario("random_forest:n=1.5e1").n, int)
    assert load_scenario("random_forest_3d:overlap=TRUE,density=0.05").n == 30
    with pytest.raises(ScenarioError, match=r"random_forest: n must be an integer in \[1, 1000000\], got 2.5"):
        random_forest(n=2.5)
    with pytest.raises(ScenarioError, match=r"random_forest: n must be in \[1, 1000000\], got 0"):
        random_forest(n=0)
    with pytest.raises(ScenarioError, match=r"periodic_box: rho must be a number in \(0, inf\) 1/m\^2, got '4'"):
        periodic_box(rho="4")


@pytest.mark.parametrize("name", sorted(GENERATORS))
def test_every_generator_at_its_defaults_keeps_spawn_and_goal_in_bounds(name):
    scn = load_scenario(name)  # validate refuses a spawn region or goal outside world.bounds
    d = scn.dim
    region = scn.swarm.region
    assert all(scn.bounds[a] <= region[a] and region[d + a] <= scn.bounds[d + a] for a in range(d))
    assert all(scn.bounds[a] <= scn.goal[a] <= scn.bounds[d + a] for a in range(d))


def test_cli_generator_error_is_one_line_exit_2_without_traceback(tmp_path):
    p = run_cli("run", "--method", "apf", "--scenario", "random_forest:n=2.5", "--out", tmp_path / "o")
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    assert p.stderr.splitlines() == ["swarmnav: error: random_forest: n must be an integer in [1, 1000000], got '2.5'"]


# --------------------------------------------------------------------------- property: any option string

#: Option values: text that is no number, non-finite and huge numbers, numbers at and beyond the
#: ranges' ends, integers, any float, any short text. Tiny positive floats are left out: a tiny
#: radius is a valid option, but random sequential addition of ~1e20 discs runs to max_tries
#: (tens of seconds), and that is the generator's cost, not the parser's business.
VALUES = st.one_of(
    st.sampled_from(["", "abc", "nan", "NaN", "inf", "-inf", "1e999", "-1e999", "1e400", "true", "false", "TRUE",
                     "0", "-0", "1", "-1", "0.25", "0.5", "2.5", "6", "8", "15.0", "1e3", "1e6", "1_0", "0x10",
                     "3 4", "=", ":", str(10**30), "-" + str(10**30)]),
    st.integers(-(10**7), 10**7).map(str),
    st.floats().filter(lambda x: not 0 < abs(x) < 0.1).map(repr),
    st.floats(0.1, 20.0).map(repr),  # mostly inside the ranges: these build scenes
    st.text(max_size=6),
)
JUNK_KEYS = ["bogus", "", "N", "max_tries", "dens ity", "Density"]


@st.composite
def specs(draw):
    name = draw(st.sampled_from(sorted(GENERATORS) * 4 + ["volcano", ""]))
    own = [k for k in OPTIONS.get(name, {}) if k not in ("max_forests", "resolution")]  # see below
    keys = st.sampled_from(own * 4 + JUNK_KEYS + sorted({k for o in OPTIONS.values() for k in o} - set(own)))
    items = [f"{draw(keys)}={draw(VALUES)}" for _ in range(draw(st.integers(0, 3)))]
    if draw(st.integers(0, 3)) == 0:
        items.append(draw(st.text(max_size=8)))  # no '=', stray separators, anything
    if name == "random_forest":
        # min_passage redraws the forest up to max_forests times (200 by default, ~0.1 s each);
        # two draws keep an example short (max_forests itself is checked in the named cases)
        items.append("max_forests=2")
    if name == "mockamap":
        # a 1 m voxel keeps every map small (at most 100 x 100 x 40 voxels; the default 0.1 m world
        # of 1.6 M voxels takes seconds); resolution itself is checked in tests/world/test_mockamap.py
        items.append("resolution=1")
    return f"{name}:{','.join(items)}" if items or draw(st.booleans()) else name


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(specs())
def test_any_option_string_gives_a_scene_or_one_scenario_error(spec):
    try:
        scn = load_scenario(spec)
    except ScenarioError as e:
        msg = str(e)
        assert msg and "\n" not in msg and "\r" not in msg, msg
        return
    assert isinstance(scn, Scenario)
    d = scn.dim
    assert all(scn.bounds[a] <= scn.goal[a] <= scn.bounds[d + a] for a in range(d))
    assert isinstance(scn.n, int) and scn.n >= 1 and all(map(math.isfinite, scn.bounds))
