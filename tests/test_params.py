"""Parameter records: every method parameter declares unit, valid range and source, and the one
builder (``params.build``) enforces the range for every registered method, from the command
line and from Python alike."""

from __future__ import annotations

import contextlib
import io
import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import swarmnav
from swarmnav.cli import main
from swarmnav.errors import ConfigError, SwarmnavError
from swarmnav.methods import registry
from swarmnav.params import Range, aliases, as_dict, build, default_build, describe, differences, presets

METHODS = registry.names()
#: (method, ParamInfo) for every numeric parameter of every registered method.
NUMERIC = [(m, i) for m in METHODS for i in describe(registry.spec(m).params) if i.kind in ("float", "int")]

_SCENE = """
name = "tiny"
[world]
bounds = [-6.0, -6.0, 14.0, 6.0]
[swarm]
n = 4
spawn = [-5.0, -2.0, -1.0, 2.0]
[goal]
position = [12.0, 0.0]
path = [[-3.0, 0.0], [12.0, 0.0]]
[[obstacles]]
type = "circle"
center = [5.0, 0.5]
radius = 1.0
"""
_DIR = Path(tempfile.mkdtemp(prefix="swarmnav-params-"))
(_DIR / "tiny.toml").write_text(_SCENE)


def _cli(*args: str) -> tuple[int, str]:
    """``swarmnav ARGS`` in-process: exit code and stderr (an uncaught exception fails the test)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(list(args))
    return code, err.getvalue()


def _run(method: str, key: str, value: str, steps: int = 1) -> tuple[int, str]:
    return _cli("run", "--method", method, "--scenario-file", str(_DIR / "tiny.toml"), "--steps", str(steps),
                "--out", str(_DIR / "out"), "--quiet", "--force", "--set", f"{key}={value}")  # one dir, many runs


# ------------------------------------------------------------------ declarations


@pytest.mark.parametrize("method", METHODS)
def test_every_parameter_is_declared_with_its_range_unit_and_source(method):
    infos = describe(registry.spec(method).params)
    assert infos
    for i in infos:
        assert i.source, f"{method}.{i.name}: no source"
        assert i.doc, f"{method}.{i.name}: no meaning"
        if i.kind in ("float", "int"):
            assert i.range is not None, f"{method}.{i.name}: numeric parameter without a range"
            assert i.default in i.range, f"{method}.{i.name}: default {i.default} outside {i.range}"
        if i.kind == "choice":
            assert i.default in i.choices


@pytest.mark.parametrize("method", METHODS)
def test_presets_name_real_parameters_with_valid_values(method):
    cls = registry.spec(method).params
    for name, values in presets(cls).items():
        built = registry.make(method, preset=name)  # through the one builder: ranges checked
        for k, v in values.items():
            assert as_dict(built.params)[k] == v, (name, k)


def test_a_preset_then_overrides_on_top():
    m = registry.make("hes", preset="paper", passage_mode=True)  # an old flat name, on top of the preset
    assert m.params.passage.on is True and m.params.stall.on is False
    m = registry.make("hes", **{"preset": "paper", "passage.on": "true"})
    assert m.params.passage.on is True and m.params.stall.on is False
    with pytest.raises(ConfigError, match="unknown preset 'papr' .*did you mean paper"):
        registry.make("hes", preset="papr")


def test_an_earlier_preset_name_resolves_to_the_same_build():
    # HES's paper build was called "faithful" before issue 34: old specs and stored runs keep their meaning
    assert registry.make("hes", preset="faithful").params == registry.make("hes", preset="paper").params
    assert registry.make("hes", preset="paper").params != registry.make("hes").params


@pytest.mark.parametrize("method", ["hes", "sph", "hwvem", "ego-swarm"])
def test_every_family_names_its_default_and_its_paper_build(method):
    cls = registry.spec(method).params
    assert "paper" in presets(cls) and default_build(cls) in presets(cls)
    assert build(cls, {"preset": default_build(cls)}) == cls()  # the default build is the defaults
    diff = differences(cls, "paper")
    assert all(a != b for _, a, b in diff)
    assert (diff == []) == (default_build(cls) == "paper")  # only SPH's default is its paper build today


@given(st.sampled_from(["(", "["]), st.floats(-1e6, 1e6), st.floats(0, 1e6), st.sampled_from([")", "]"]))
def test_interval_text_round_trips(left, lo, width, right):
    hi = lo + width
    r = Range.parse(f"{left}{lo!r}, {hi!r}{right}")
    assert Range.parse(str(r)) == r
    if lo < hi:
        assert (lo in r) == (left == "[") and (hi in r) == (right == "]")
        assert (lo + hi) / 2 in r or (lo + hi) / 2 in (lo, hi)
    assert lo - 1.0 - abs(lo) not in r and hi + 1.0 + abs(hi) not in r


@pytest.mark.parametrize("text", ["0, 1", "(1, 0)", "[a, b]", "(0; 1)", "", "(nan, 1)"])
def test_malformed_interval_is_refused(text):
    with pytest.raises(ValueError):
        Range.parse(text)


def test_infinite_bounds_are_open_and_pi_multiples_print_as_declared():
    assert str(Range.parse("[-inf, inf]")) == "(-inf, inf)"
    assert str(Range.parse("[0, 2pi]")) == "[0, 2pi]" and 2 * math.pi in Range.parse("[0, 2pi]")


# ------------------------------------------------------------------ out-of-range values are refused


def _out_of_range(info) -> list[str]:
    """Values just outside ``info``'s range, non-finite values, and non-integers for an int."""
    r = info.range
    bad = ["nan", "inf", "-inf"]
    if math.isfinite(r.lo):
        bad += [repr(r.lo - max(1.0, abs(r.lo))), repr(r.lo - 1e-9 * max(1.0, abs(r.lo)))]
        if not r.lo_closed or info.kind == "int" and r.lo != int(r.lo):
            bad.append(repr(r.lo))
    if math.isfinite(r.hi):
        bad += [repr(r.hi + max(1.0, abs(r.hi))), repr(r.hi * (1 + 1e-9) + 1e-9)]
        if not r.hi_closed:
            bad.append(repr(r.hi))
    if info.kind == "int":
        bad.append(repr(float(info.default) + 0.5))
    return [b for b in bad if not (info.kind == "int" and b.endswith(".0") and float(b) in r)]


@pytest.mark.parametrize("method, info", NUMERIC, ids=[f"{m}-{i.name}" for m, i in NUMERIC])
def test_every_numeric_parameter_refuses_out_of_range_values_in_one_line(method, info):
    for value in _out_of_range(info):
        code, err = _run(method, info.name, value)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1, (value, err)
        assert info.name in lines[0] and "Traceback" not in err
        x = float(value)
        if math.isfinite(x) and (info.kind == "float" or x.is_integer()):  # a number of the right type
            shown = int(x) if info.kind == "int" else x
            assert lines[0].endswith(f"{info.name} must be in {info.range}{' ' + info.unit if info.unit else ''}, "
                                     f"got {shown!r}"), lines[0]
        with pytest.raises(ConfigError):  # the Python API refuses the same value
            registry.make(method, **{info.name: float(value)})


@st.composite
def _bad_setting(draw):
    method, info = draw(st.sampled_from(NUMERIC))
    r = info.range
    choices = [st.sampled_from(["nan", "inf", "-inf", "NaN", "+inf", "1e999"])]
    if math.isfinite(r.lo):
        choices.append(st.floats(max_value=r.lo, exclude_max=r.lo_closed, allow_nan=False, allow_infinity=False,
                                 min_value=-1e300).map(repr))
    if math.isfinite(r.hi):
        choices.append(st.floats(min_value=r.hi, exclude_min=r.hi_closed, allow_nan=False, allow_infinity=False,
                                 max_value=1e300).map(repr))
    if info.kind == "int":
        choices.append(st.floats(-1e6, 1e6).filter(lambda x: not x.is_integer()).map(repr))
    value = draw(st.one_of(choices))
    if info.kind == "int" and math.isfinite(float(value)) and float(value).is_integer() and float(value) in r:
        value = "nan"  # an integral float inside the range of an int parameter is valid
    return method, info.name, value


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_bad_setting())
def test_random_out_of_range_and_non_finite_values_never_run(setting):
    method, key, value = setting
    code, err = _run(method, key, value)
    assert code == 2, (setting, err)
    assert len(err.strip().splitlines()) == 1 and key in err


# ------------------------------------------------------------------ valid values never crash


@st.composite
def _valid_setting(draw):
    method, info = draw(st.sampled_from(NUMERIC))
    r = info.range
    lo = r.lo if math.isfinite(r.lo) else -1e3
    hi = r.hi if math.isfinite(r.hi) else max(1e3, 100 * abs(info.default))
    if info.kind == "int":
        hi = min(hi, max(4 * abs(info.default), lo + 8))
        value = draw(st.integers(math.ceil(lo), math.floor(hi)))
    else:
        value = draw(st.floats(lo, hi, exclude_min=not r.lo_closed, exclude_max=not r.hi_closed))
    return method, info.name, repr(value)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_valid_setting())
@example(("sph", "rho0", "3.5802690758179364e-104"))  # found by this test: NumPy's overflow warning came before the line
@example(("mader", "v_max", "5e-324"))  # found by this test: a NaN knot span, now refused in one line
@example(("sph", "plan_speed", "1.1125369292536007e-308"))  # found by this test: the spline's knot span overflowed
@example(("sph", "inflation", "5.0"))  # found by this test: no free node for the yielding order's field
def test_random_valid_values_run_or_fail_in_one_line(setting):
    """In-range values of one parameter: the run completes, or (a relation between parameters,
    a diverged state) ends in one line with exit 2; never a traceback."""
    method, key, value = setting
    code, err = _run(method, key, value, steps=3)
    assert code in (0, 2), (setting, err)
    if code == 2:
        assert len(err.strip().splitlines()) == 1, (setting, err)


def test_the_python_api_refuses_what_the_cli_refuses():
    scn = swarmnav.load_scenario(_DIR / "tiny.toml")
    for bad in ({"dt": -0.1}, {"dt": 0.0}, {"a_max": -1.0}, {"n_rays": 0}, {"lidar_range": -5.0}, {"k_rep": math.inf}):
        with pytest.raises(SwarmnavError):
            swarmnav.run("apf", scn, seed=1, steps=2, **bad)


def test_nested_records_take_dotted_names_and_the_old_flat_names():
    cls = registry.spec("hes").params
    dotted = build(cls, {"paper.k_p": "0.5", "passage.margin": 0.25, "stall.on": "false"})
    flat = build(cls, {"k_p": 0.5, "passage_margin": "0.25", "stall_plan": False})
    assert dotted == flat
    assert dotted.paper.k_p == 0.5 and dotted.passage.margin == 0.25 and dotted.stall.on is False
    assert dotted.paper.k_v == cls().paper.k_v  # untouched fields keep their defaults
    for old, new in aliases(cls).items():  # every alias names a real parameter
        assert new in as_dict(cls()), (old, new)


@pytest.mark.parametrize("method", METHODS)
def test_as_dict_rebuilds_the_record(method):
    cls = registry.spec(method).params
    for name in ["", *presets(cls)]:
        p = build(cls, {"preset": name} if name else {})
        assert build(cls, as_dict(p)) == p
        assert [i.name for i in describe(cls)] == list(as_dict(p))


def test_nested_errors_name_the_dotted_key():
    cls = registry.spec("hes").params
    with pytest.raises(ConfigError, match=r"passage\.margin must be in \[0, inf\) m, got -1.0"):
        build(cls, {"passage.margin": -1})
    with pytest.raises(ConfigError, match=r"passage_margin must be|passage\.margin must be"):
        build(cls, {"passage_margin": -1})
    with pytest.raises(ConfigError, match=r"unknown parameter 'passage\.margn' \(did you mean passage\.margin"):
        build(cls, {"passage.margn": 1})
    with pytest.raises(ConfigError, match=r"unknown parameter 'passage'"):
        build(cls, {"passage": False})  # a record is not a value: its switch is passage.on
