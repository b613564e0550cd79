"""2-D runs are bit-identical to the stored reference runs (``tests/data/reference_runs.json``,
written by ``tests/data/reference_runs.py`` before 3-D worlds were added): every array hash and
every metric of every case must match exactly."""

import json
import math

import pytest

from data.reference_runs import FILE, record

REFERENCE = json.loads(FILE.read_text())


@pytest.mark.parametrize("ref", REFERENCE, ids=lambda r: f"{r['method']}-{r['scene']}")
def test_run_is_identical_to_stored_reference(ref):
    got = record(ref["method"], ref["scene"], ref["seed"], ref["steps"])
    for key in ("shape", "positions", "velocities", "clearance", "labels", "events"):
        assert got[key] == ref[key], f"{key} differs from the stored reference run"
    assert got["metrics"] == ref["metrics"]


def test_reference_covers_every_registered_method():
    from swarmnav.methods import registry

    assert {r["method"] for r in REFERENCE} == set(registry.names())
    assert all(math.prod(r["shape"]) > 0 for r in REFERENCE)
