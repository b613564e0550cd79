"""Portable numerics (docs/determinism.md): on by default, off with SWARMNAV_PORTABLE=0, and each
run's config says which was in force, checked in fresh processes (the settings act at load time)."""

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

import swarmnav
from swarmnav import portable

SRC = str(Path(swarmnav.__file__).resolve().parents[1])
GLIBC = platform.libc_ver()
pytestmark = pytest.mark.skipif(
    sys.platform != "linux" or platform.machine() != "x86_64" or GLIBC[0] != "glibc"
    or tuple(map(int, GLIBC[1].split(".")[:2])) < (2, 33),
    reason="portable mode is checked on x86-64 Linux with glibc >= 2.33")

# What the child reports: the run's config field, whether NumPy dispatches to any SIMD target,
# the CPU numba compiles for, swarmnav's variables in its environment, its warnings.
PROBE = """
import json, os, sys, warnings
warnings.simplefilter("always")
with warnings.catch_warnings(record=True) as caught:
    {first}
    import swarmnav
    runs = [swarmnav.run("apf", "default_corridor", seed=1, steps=5) for _ in range(2)]
from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
from numba.core.registry import cpu_target
print(json.dumps({{
    "numerics": [r.config["numerics"] for r in runs],
    "problems": swarmnav.portable.report()["problems"],
    "simd": [f for f in __cpu_dispatch__ if __cpu_features__[f]],
    "numba_cpu": cpu_target.target_context.codegen().magic_tuple()[1],
    "pinned": sorted(k for k in swarmnav.portable.PINS if k in os.environ),
    "warnings": [str(w.message) for w in caught if "portable numerics" in str(w.message)],
}}))
"""


def clean_env(**extra: str) -> dict[str, str]:
    """This environment without anything portable mode sets, as a user's shell would be."""
    drop = {*portable.PINS, *portable.UNSET, "GLIBC_TUNABLES"}
    env = {k: v for k, v in os.environ.items() if k not in drop and not k.startswith(portable.SWITCH)}
    return {**env, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", ""), **extra}


def probe(env: dict[str, str], first: str = "pass") -> dict:
    p = subprocess.run([sys.executable, "-c", PROBE.format(first=first)], env=env, capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def has_fma() -> bool:
    flags = next(line for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("flags"))
    return bool({"fma", "fma4"} & set(flags.split()))


def command_numerics(tmp_path: Path, **extra: str) -> str:
    out = tmp_path / "run"
    p = subprocess.run([sys.executable, "-m", "swarmnav", "run", "--method", "apf", "--scenario", "default_corridor",
                        "--steps", "5", "--out", str(out), "--quiet"], env=clean_env(**extra), capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0 and "portable numerics" not in p.stderr, p.stderr
    return json.loads((out / "config.json").read_text())["numerics"]


def test_the_command_is_portable_by_default(tmp_path):
    # started from a shell without glibc's setting: the command restarts itself with it
    assert command_numerics(tmp_path) == "portable"


def test_switched_off_the_command_is_native(tmp_path):
    assert command_numerics(tmp_path, SWARMNAV_PORTABLE="0") == "native"


def test_a_program_started_with_the_portable_environment_runs_the_pinned_code():
    got = probe(clean_env(**portable.environment()))
    assert got["numerics"] == ["portable", "portable"] and got["problems"] == [] and got["warnings"] == []
    assert got["simd"] == [] and got["numba_cpu"] == "generic"


def test_switched_off_nothing_is_pinned_and_nothing_is_said():
    got = probe(clean_env(SWARMNAV_PORTABLE="0"))
    assert got["numerics"] == ["native", "native"] and got["warnings"] == []
    assert got["pinned"] == [] and got["numba_cpu"] != "generic"


def test_numpy_imported_before_swarmnav_is_recorded_native_with_one_warning():
    env = clean_env(GLIBC_TUNABLES=portable.libm_tunables())  # only NumPy (and its OpenBLAS) go unpinned
    got = probe(env, first="import numpy")
    assert got["numerics"] == ["native", "native"] and len(got["warnings"]) == 1
    assert any("NumPy" in p or "OpenBLAS" in p for p in got["problems"]), got["problems"]
    assert got["numba_cpu"] == "generic"  # numba loaded after swarmnav: still pinned


def test_numba_loaded_before_swarmnav_is_pinned_unless_it_already_compiled():
    env = clean_env(**{k: v for k, v in portable.environment().items() if not k.startswith("NUMBA_")})
    loaded = probe(env, first="import numba")
    assert loaded["numerics"] == ["portable", "portable"] and loaded["numba_cpu"] == "generic"
    compiled = probe(env, first="import numba; numba.njit(lambda x: x + 1)(1)")
    assert compiled["numerics"] == ["native", "native"] and len(compiled["warnings"]) == 1
    assert [p for p in compiled["problems"] if "numba" in p] == compiled["problems"] != []


@pytest.mark.skipif(not has_fma(), reason="without FMA, glibc's libm runs its SSE2 code anyway")
def test_a_program_started_without_glibcs_setting_says_so():
    got = probe(clean_env())
    assert got["numerics"] == ["native", "native"] and len(got["warnings"]) == 1
    assert got["simd"] == [] and got["numba_cpu"] == "generic"  # what could be pinned was
    assert [p for p in got["problems"] if "GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA,-FMA4" in p] == got["problems"]


def test_the_libm_mask_joins_existing_tunables():
    assert portable.libm_tunables() == "glibc.cpu.hwcaps=-FMA,-FMA4"
    mixed = portable.libm_tunables("glibc.malloc.check=3:glibc.cpu.hwcaps=-AVX2")
    assert mixed == "glibc.malloc.check=3:glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4"
    assert portable.libm_tunables(mixed) == mixed
