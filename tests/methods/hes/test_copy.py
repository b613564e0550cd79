"""Copy-and-continue identity: a HES run copied mid-flight continues bit-identically (issue 39).

The oracle decider (docs/oracle.md) flies copies of the run; its bound means something only if a
copy is the run itself. ``Flight`` starts where ``swarmnav.run`` starts and steps as it steps, so
both a copy and its original must reproduce the stored arrays of ``run`` exactly.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import swarmnav
from swarmnav.sim.flight import Flight

SCENE, SEED, K, COPY_AT = "off_axis_goal", 3, 60, 30  # a split at step 19: the copy holds two sub-swarms


@pytest.fixture(scope="module")
def reference():
    return swarmnav.run("hes", SCENE, seed=SEED, steps=K)


@pytest.mark.parametrize("how", ["flight", "deepcopy"])
def test_a_copied_run_continues_bit_identically(reference, how):
    f = Flight.start("hes", SCENE, seed=SEED)
    for _ in range(COPY_AT):
        f.step()
    assert np.array_equal(f.pos, reference.positions[COPY_AT])  # a Flight is the run up to the copy
    g = f.copy() if how == "flight" else Flight(copy.deepcopy(f.method), f.scene, f.k, f.pos.copy(), f.vel.copy(),
                                                 copy.deepcopy(f.rng), copy.deepcopy(f.referee))
    assert g.method is not f.method and g.method.labels is not f.method.labels
    assert len(g.method.subs) == 2  # the copy holds the structure the split made
    for k in range(COPY_AT, K):  # interleaved: a copy that shared state with its original would drift
        f.step()
        g.step()
        assert np.array_equal(g.pos, reference.positions[k + 1]), f"copy drifted at step {k + 1}"
        assert np.array_equal(f.pos, reference.positions[k + 1]), f"original drifted at step {k + 1}"
        assert np.array_equal(g.vel, reference.velocities[k + 1])
        assert np.array_equal(g.method.labels, reference.labels[k + 1])
    assert g.method.summary() == f.method.summary()


def test_a_clone_keeps_the_shared_scene_and_copies_the_memory():
    f = Flight.start("hes", SCENE, seed=SEED)
    for _ in range(COPY_AT):
        f.step()
    c = f.method.clone()
    assert c.obstacles is f.method.obstacles and c.params is f.method.params  # never changed after reset
    c.labels[:] = 7  # the copy's memory is its own
    assert not np.any(f.method.labels == 7)


def test_an_llm_source_refuses_to_be_copied():
    """A model or a server cannot be copied: a copied run must say so, not share the back end."""
    from swarmnav.llm import LlmDecisionSource

    from swarmnav.methods.hes import Hes

    f = Flight.start(Hes().use_source(LlmDecisionSource(rule=None, decider=None, project=None)), SCENE, seed=SEED)
    with pytest.raises(TypeError, match="cannot be copied"):
        f.copy()
