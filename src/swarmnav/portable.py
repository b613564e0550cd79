"""Portable numerics: the same seed gives the same arrays on any x86-64 Linux machine.

Four parts of the numerical stack pick their code by CPU at run time, and each pick can change
the last bits of a result, which a closed-loop simulation grows into different trajectories
(docs/determinism.md has the measurements):

- NumPy dispatches its loops to AVX2 / AVX-512 variants (``__cpu_dispatch__``);
- OpenBLAS, in NumPy's and in SciPy's copy, picks a kernel per CPU (numba's ``np.dot`` calls
  SciPy's: the SPH spline optimiser's inner products);
- numba compiles for the host CPU;
- glibc's libm picks FMA variants of exp, log, pow, sin, cos, tan, atan, atan2, asin and acos.

Portable mode, the default, exports :data:`PINS` before those libraries load (``swarmnav``
calls :func:`apply` before it imports NumPy), so each runs the code every x86-64 CPU has.
glibc reads its setting only when a process starts: the ``swarmnav`` command restarts itself
once with it, a Python program that imports swarmnav must be started with it
(``GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA,-FMA4``) or call :func:`restart`, and child processes
inherit it. What is
actually in force is checked, not assumed: :func:`numerics` says ``"portable"`` only if every
library runs its pinned code, and warns once when portable mode was asked for but is not in
force (NumPy imported before swarmnav, a process started without the glibc setting).
``SWARMNAV_PORTABLE=0`` keeps the native, CPU-specific code (faster, identical on one machine).
"""

from __future__ import annotations

import ctypes
import functools
import os
import platform
import sys
import warnings
from pathlib import Path

#: The switch: ``0`` (or false/no/off) runs native code; unset or anything else, portable.
SWITCH = "SWARMNAV_PORTABLE"

#: Environment of portable mode, read by each library once, when it loads.
PINS = {
    # NumPy: enable none of the dispatched SIMD targets, i.e. run the build's baseline loops (an
    # empty list must be a non-empty string, or NumPy reads the variable as unset).
    "NPY_ENABLE_CPU_FEATURES": " ",
    # OpenBLAS: the SSE3 kernels, which every x86-64 CPU runs; one thread, so no reduction is
    # split by the machine's core count.
    "OPENBLAS_CORETYPE": "Prescott",
    "OPENBLAS_NUM_THREADS": "1",
    # numba: code for the generic x86-64 CPU without host features; no Intel SVML (its vector
    # maths dispatches by CPU too).
    "NUMBA_CPU_NAME": "generic",
    "NUMBA_CPU_FEATURES": "",
    "NUMBA_DISABLE_INTEL_SVML": "1",
}
#: Variables that would contradict :data:`PINS` (NumPy refuses both of its variables at once).
UNSET = ("NPY_DISABLE_CPU_FEATURES",)
#: glibc features masked so that libm runs its SSE2 code (``GLIBC_TUNABLES=glibc.cpu.hwcaps=...``).
LIBM_MASK = ("-FMA", "-FMA4")

# OpenBLAS builds without DYNAMIC_OLDER serve the pre-Core2 names from the Prescott table and
# report the first alias, Katmai (measured with scipy-openblas 0.3.31).
_PRESCOTT_NAMES = {"prescott", "katmai"}
# Set by the one restart; children inherit it with the mask, so none of them restarts again.
_RESTARTED = "SWARMNAV_PORTABLE_RESTARTED"
_warned = False


def requested() -> bool:
    """Whether portable mode is asked for (``SWARMNAV_PORTABLE`` unset or not 0/false/no/off)."""
    return os.environ.get(SWITCH, "1").strip().lower() not in ("0", "false", "no", "off")


def _unsupported() -> str | None:
    """Why this platform has no portable mode, or None on x86-64 Linux with glibc."""
    if sys.platform != "linux" or platform.machine() not in ("x86_64", "AMD64"):
        return f"portable mode covers x86-64 Linux, not {sys.platform} {platform.machine()}"
    if platform.libc_ver()[0] != "glibc":
        return "portable mode needs glibc (its libm is the one checked)"
    return None


def libm_tunables(current: str = "") -> str:
    """``GLIBC_TUNABLES`` value ``current`` with :data:`LIBM_MASK` added to ``glibc.cpu.hwcaps``."""
    parts = [p for p in current.split(":") if p]
    for i, part in enumerate(parts):
        name, _, value = part.partition("=")
        if name == "glibc.cpu.hwcaps":
            have = [v for v in value.split(",") if v]
            parts[i] = f"{name}={','.join(have + [m for m in LIBM_MASK if m not in have])}"
            break
    else:
        parts.append(f"glibc.cpu.hwcaps={','.join(LIBM_MASK)}")
    return ":".join(parts)


def environment() -> dict[str, str]:
    """The variables a process must start with to run portably (for workers and subprocesses)."""
    return {**PINS, "GLIBC_TUNABLES": libm_tunables(os.environ.get("GLIBC_TUNABLES", ""))}


def apply() -> None:
    """Export :data:`PINS` and the libm mask; restart the ``swarmnav`` command once if glibc
    started without the mask. Runs before NumPy loads (first thing in ``swarmnav/__init__``)."""
    if not requested() or _unsupported():
        return
    for name in UNSET:
        os.environ.pop(name, None)
    os.environ.update(environment())
    if "numba" in sys.modules:  # imported before swarmnav: it may not have compiled yet
        from numba.core import config

        config.reload_config()
    if _is_command():  # nothing is loaded yet but the interpreter: the restart is cheap here
        restart()


def restart() -> None:
    """Start this program again, same interpreter and arguments, with portable mode's
    environment if this process does not run portably: glibc reads ``GLIBC_TUNABLES`` only when
    a process starts, NumPy its variable only when it loads. At most once, and only when
    portable mode is asked for; never in an interactive session or a Jupyter kernel.

    The ``swarmnav`` command does this before it loads anything; a script that wants portable
    runs can call it right after ``import swarmnav`` (what ran before the call runs again).
    """
    if (not requested() or _unsupported() or os.environ.get(_RESTARTED)
            or hasattr(sys, "ps1") or sys.flags.interactive or "ipykernel" in sys.modules):
        return
    if not _libm_problem() and ("numpy" not in sys.modules or report()["numerics"] == "portable"):
        return
    for name in UNSET:
        os.environ.pop(name, None)
    os.environ.update(environment())
    os.environ[_RESTARTED] = "1"
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, *sys.orig_argv[1:]])


def _is_command() -> bool:
    """True in the ``swarmnav`` command: its console script, ``python -m swarmnav[.cli]``."""
    main = sys.modules.get("__main__")
    if Path(getattr(main, "__file__", None) or "").name == "swarmnav":
        return True
    argv = sys.orig_argv
    return any(a == "-m" and argv[i + 1:i + 2] in (["swarmnav"], ["swarmnav.cli"]) for i, a in enumerate(argv))


def _libm_problem() -> str | None:
    """Why glibc's libm may run CPU-specific code here, or None when it runs its SSE2 code.

    glibc >= 2.33 reports the features it uses (``__x86_get_cpuid_feature_leaf``, the function
    behind ``CPU_FEATURE_ACTIVE``); libm picks its FMA code when FMA (with AVX2) or FMA4 is active.
    """
    get = getattr(ctypes.CDLL(None), "__x86_get_cpuid_feature_leaf", None)
    if get is None:
        return f"glibc {platform.libc_ver()[1]} cannot say which libm code it runs (needs glibc >= 2.33)"
    get.restype = ctypes.POINTER(ctypes.c_uint32 * 8)  # cpuid eax..edx, then active eax..edx
    get.argtypes = [ctypes.c_uint]
    fma = get(0).contents[6] >> 12 & 1  # CPUID_INDEX_1, ECX bit 12
    fma4 = get(2).contents[6] >> 16 & 1  # CPUID_INDEX_80000001, ECX bit 16
    if fma or fma4:
        return ("glibc's libm runs its FMA code: this process started without "
                f"GLIBC_TUNABLES={libm_tunables()}")
    return None


def _numpy_problem() -> str | None:
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:  # NumPy 1.x
        from numpy.core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    on = [f for f in __cpu_dispatch__ if __cpu_features__.get(f)]
    return f"NumPy runs its {' '.join(on)} loops (it was imported before swarmnav)" if on else None


def _openblas() -> list[tuple[str, str | None, int | None, str | None]]:
    """(file, kernel name, threads, build configuration) of every OpenBLAS loaded in this process."""
    return [(Path(p).name, *(f() if f else None for f in _openblas_calls(p))) for p in _openblas_paths(len(sys.modules))]


@functools.lru_cache(maxsize=1)
def _openblas_paths(n_modules: int) -> list[str]:
    """Files of the loaded OpenBLAS libraries. Reading /proc/self/maps takes a millisecond, so it
    is read again only when modules were imported: an OpenBLAS arrives with the extension module
    that links it (NumPy's at import, SciPy's with scipy.linalg)."""
    maps = Path("/proc/self/maps").read_text()
    return sorted({line.split(None, 5)[5] for line in maps.splitlines()
                   if "openblas" in line.lower() and len(line.split(None, 5)) == 6})


@functools.cache
def _openblas_calls(path: str) -> tuple:
    """The kernel-name and thread-count functions of the OpenBLAS at ``path`` (None if absent);
    their names carry the build's prefix and suffix (``scipy_openblas_get_corename64_``)."""
    lib = ctypes.CDLL(path)  # already loaded: the same handle

    def find(base: str, restype):
        for pre in ("", "scipy_"):
            for suf in ("", "64_", "_64"):
                fn = getattr(lib, f"{pre}{base}{suf}", None)
                if fn is not None:
                    fn.restype, fn.argtypes = restype, []
                    return fn
        return None

    name = find("openblas_get_corename", ctypes.c_char_p)
    config = find("openblas_get_config", ctypes.c_char_p)
    return ((lambda: (name() or b"").decode() or None) if name else None, find("openblas_get_num_threads", ctypes.c_int),
            (lambda: (config() or b"").decode() or None) if config else None)


def _openblas_problems() -> list[str]:
    loaded = _openblas()
    if not loaded:  # NumPy links its BLAS, so it is loaded by now: this one is not OpenBLAS
        return ["NumPy's BLAS is not OpenBLAS, whose kernel portable mode pins"]
    # A build for one target (no DYNAMIC_ARCH in its configuration, e.g. CasADi's CORE2 copy that
    # IPOPT's MUMPS calls) runs the same kernels on every machine: only a dispatching build is pinned.
    return [f"OpenBLAS {f} runs the {name} kernels, {threads} thread(s) (loaded before swarmnav)"
            for f, name, threads, config in loaded
            if threads != 1 or ((name or "").lower() not in _PRESCOTT_NAMES and "DYNAMIC_ARCH" in (config or "DYNAMIC_ARCH"))]


def _numba_problem() -> str | None:
    from numba.core import config
    from numba.core.registry import cpu_target

    # The CPU name is read from the config on each call; the features are those numba's target
    # machine was made with, when it first compiled.
    _, cpu, features = cpu_target.target_context.codegen().magic_tuple()
    if features:
        return "numba compiles with the host CPU's features (it compiled before swarmnav was imported)"
    if cpu != "generic":
        return f"numba compiles for the {cpu} CPU"
    return "numba uses Intel SVML" if config.USING_SVML else None


def report() -> dict:
    """What is in force: ``{"numerics": "portable" | "native", "requested": bool, "problems": [...]}``.

    ``portable`` means every library checked runs its pinned code; ``problems`` says what does not.
    """
    if not requested():
        return {"numerics": "native", "requested": False, "problems": []}
    if (why := _unsupported()) is not None:
        return {"numerics": "native", "requested": True, "problems": [why]}
    problems = [p for p in (_numpy_problem(), _numba_problem(), _libm_problem()) if p] + _openblas_problems()
    return {"numerics": "native" if problems else "portable", "requested": True, "problems": problems}


def numerics() -> str:
    """``"portable"`` or ``"native"`` (see :func:`report`); warns once if portable mode was
    asked for on x86-64 Linux but is not in force."""
    global _warned
    r = report()
    if r["numerics"] == "native" and r["requested"] and not _unsupported() and not _warned:
        _warned = True
        warnings.warn("swarmnav: portable numerics were asked for but are not in force, so this "
                      "run is recorded as numerics=native: " + "; ".join(r["problems"])
                      + f" (docs/determinism.md; {SWITCH}=0 runs native code without this warning)",
                      RuntimeWarning, stacklevel=2)
    return r["numerics"]
