"""2-D runs are bit-identical to the stored reference runs (``tests/data/reference_runs.json``,
written by ``tests/data/reference_runs.py`` in portable mode): every array hash and every metric
of every case must match exactly, on any x86-64 Linux machine.

The cases run in one fresh process started with portable mode's environment (this test process
may have loaded NumPy natively, or started without glibc's setting); that process refuses to run
natively, and the test fails with its reason."""

import json
import math
import subprocess
import sys

import pytest

from data.reference_runs import FILE

REFERENCE = json.loads(FILE.read_text())
CASE_KEYS = ("method", "scene", "seed", "steps")


@pytest.fixture(scope="module")
def rerun(request) -> dict[tuple, dict]:
    """The selected reference cases, recorded again by a fresh portable process."""
    selected = [item.callspec.params["ref"] for item in request.session.items
                if item.module is request.module and hasattr(item, "callspec")]
    cases = [[r[k] for k in CASE_KEYS] for r in selected]
    p = subprocess.run([sys.executable, str(FILE.with_suffix(".py")), "--cases", "-"], input=json.dumps(cases),
                       capture_output=True, text=True, timeout=3600)
    if p.returncode != 0:
        last = p.stderr.strip().splitlines()[-1:] or [f"exit code {p.returncode}"]
        pytest.fail(f"the reference process failed: {last[0]}")
    return {tuple(g[k] for k in CASE_KEYS): g for g in json.loads(p.stdout)}


@pytest.mark.parametrize("ref", REFERENCE, ids=lambda r: f"{r['method']}-{r['scene']}")
def test_run_is_identical_to_stored_reference(ref, rerun):
    got = rerun[tuple(ref[k] for k in CASE_KEYS)]
    for key in ("shape", "positions", "velocities", "clearance", "labels", "events"):
        assert got[key] == ref[key], f"{key} differs from the stored reference run"
    assert got["metrics"] == ref["metrics"]


def test_reference_covers_every_registered_method():
    from swarmnav.methods import registry

    assert {r["method"] for r in REFERENCE} == set(registry.names())
    assert all(math.prod(r["shape"]) > 0 for r in REFERENCE)
