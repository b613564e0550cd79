"""Oracle tests: the sparse numba kernels against the dense transcription of the paper
(``dense_reference.py``) on small swarms, in open, periodic and seam-free periodic worlds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swarmnav.methods.vicsek import kernels as K

from . import dense_reference as R

MODELS = {"vem": K.VEM, "vem-a": K.VEM_A, "ivem": K.IVEM, "ivem-a": K.IVEM_A, "wvem": K.WVEM, "hwvem": K.HWVEM}


def csr(pos, radius, box=0.0, wrap=True, cap=None):
    cap = cap if cap is not None else 64 * len(pos)
    idx = np.empty(cap, dtype=np.int64)
    d2 = np.empty(cap)
    indptr, total = K.neighbour_csr(pos, radius, box, wrap, idx, d2)
    if total > cap and cap > 1:
        return csr(pos, radius, box, wrap, total)
    return indptr, idx[:total], d2[:total], total


def dense_box(box, wrap):
    return box if (box > 0 and wrap) else None


WORLDS = [(0.0, True), (6.0, True), (6.0, False), (2.5, True)]  # open, periodic, no seam, < 3 cells


@pytest.mark.parametrize("box,wrap", WORLDS)
def test_neighbour_lists_match_bruteforce(box, wrap):
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, box if box else 6.0, (150, 2))
    indptr, idx, d2, _ = csr(pos, 1.0, box, wrap)
    A = R.adjacency(pos, 1.0, dense_box(box, wrap))
    _, dist = R.offsets(pos, dense_box(box, wrap))
    for i in range(len(pos)):
        row = idx[indptr[i]:indptr[i + 1]]
        assert len(set(row.tolist())) == len(row)  # no agent listed twice
        assert set(row.tolist()) == set(np.nonzero(A[i])[0].tolist())
        np.testing.assert_allclose(d2[indptr[i]:indptr[i + 1]], dist[i, row] ** 2, rtol=1e-12)


def test_neighbour_lists_exclude_coincident_agents_and_report_overflow():
    pos = np.array([[0.0, 0.0], [0.0, 0.0], [0.5, 0.0], [3.0, 3.0]])
    indptr, idx, _, total = csr(pos, 1.0)
    assert idx[indptr[0]:indptr[1]].tolist() == [2]  # 0 < |x_i - x_j|: the twin is not a neighbour
    assert total == 4
    _, _, _, total_small = csr(pos, 1.0, cap=1)
    assert total_small == 4  # the true size, so the caller can grow its buffer


def random_state(rng, n, box, with_iu=True, avoid_frac=0.2, unreached_frac=0.2):
    pos = rng.uniform(0, box, (n, 2))
    theta = R.wrap(rng.uniform(-np.pi, np.pi, n))
    theta_g = R.wrap(theta + rng.normal(0, 0.3, n))
    layers = rng.integers(1, 7, n).astype(np.int64)
    layers[rng.random(n) < unreached_frac] = K.NO_LAYER
    iu = 0 if with_iu else -1
    if with_iu:
        layers[iu] = 1
    avoiding = rng.random(n) < avoid_frac
    return pos, theta, theta_g, layers, avoiding, iu


def dense_layers(layers):
    return np.where(layers == K.NO_LAYER, np.inf, layers.astype(float))


KW = [dict(p1=0.1, p2=5.0, use_nei=True), dict(p1=0.0, p2=100.0, use_nei=True), dict(p1=0.3, p2=1.0, use_nei=True),
      dict(p1=0.01, p2=5.0, use_nei=False)]


# p1, p2 and the neighbourhood weight only act in HWVEM
CASES = [(m, kw) for m in MODELS for kw in (KW if m == "hwvem" else KW[:1])]


@pytest.mark.parametrize("model,kw", CASES, ids=[f"{m}-{i}" for m, kw in CASES for i in [KW.index(kw)]])
@pytest.mark.parametrize("box,wrap", WORLDS[:3])
def test_heading_kernel_matches_dense_paper_equations(model, kw, box, wrap):
    rng = np.random.default_rng(11)
    side = box if box else 5.0
    for trial in range(4):
        with_iu = model not in ("vem", "ivem")
        pos, theta, theta_g, layers, avoiding, iu = random_state(rng, 90, side, with_iu)
        theta_d = 0.7
        indptr, idx, d2, _ = csr(pos, 1.0, box, wrap)
        r2 = 1.0
        iu_nb = np.zeros(len(pos), dtype=np.bool_)
        if iu >= 0:
            iu_nb[idx[indptr[iu]:indptr[iu + 1]]] = True
        out = np.empty(len(pos))
        K.genuine_heading(MODELS[model], indptr, idx, d2, r2, theta, theta_g, layers, avoiding, iu, iu_nb, theta_d,
                          kw["p1"], kw["p2"], kw["use_nei"], 30.0, 18.0, 1.0, 100.0, out)
        A = R.adjacency(pos, 1.0, dense_box(box, wrap))
        ref = R.genuine_heading(model, A, theta, theta_g, dense_layers(layers), avoiding, iu if iu >= 0 else None,
                                theta_d, **kw)
        np.testing.assert_allclose(R.wrap(out - ref), 0.0, atol=1e-9, err_msg=f"trial {trial}")


def test_heading_kernel_ignores_entries_beyond_the_alignment_radius():
    """The CSR may be built at the attraction range; alignment uses only r."""
    rng = np.random.default_rng(5)
    pos, theta, theta_g, layers, avoiding, iu = random_state(rng, 80, 5.0)
    for code in MODELS.values():
        outs = []
        for radius in (0.8, 1.3):
            indptr, idx, d2, _ = csr(pos, radius)
            iu_nb = np.zeros(80, dtype=np.bool_)
            m = d2[indptr[iu]:indptr[iu + 1]] <= 0.64
            iu_nb[idx[indptr[iu]:indptr[iu + 1]][m]] = True
            out = np.empty(80)
            K.genuine_heading(code, indptr, idx, d2, 0.64, theta, theta_g, layers, avoiding, iu, iu_nb, 0.3,
                              0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, out)
            outs.append(out)
        np.testing.assert_allclose(outs[0], outs[1], atol=1e-12)


def test_hwvem_deep_layers_do_not_underflow():
    """p2^-l underflows for l ~ 150 at p2 = 100; the row-relative form must not."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [5.0, 5.0]])
    theta = np.array([0.0, 1.0, 2.0, 0.0])
    layers = np.array([400, 399, 401, 1], dtype=np.int64)
    indptr, idx, d2, _ = csr(pos, 1.0)
    out = np.empty(4)
    K.genuine_heading(K.HWVEM, indptr, idx, d2, 1.0, theta, theta.copy(), layers, np.zeros(4, np.bool_), 3,
                      np.zeros(4, np.bool_), 0.0, 0.0, 100.0, False, 30.0, 18.0, 1.0, 100.0, out)
    # agent 0 hears layer 399 (weight 1/399 * 1) and layer 401 (1/401 * 1e-4): essentially agent 1
    w1, w2 = 1 / 399, 1 / 401 * 100.0**-2
    assert out[0] == pytest.approx(math.atan2(w1 * math.sin(1) + w2 * math.sin(2), w1 * math.cos(1) + w2 * math.cos(2)))


@pytest.mark.parametrize("box,wrap", WORLDS)
def test_layers_match_dense_eq5_and_bfs_is_its_fixed_point(box, wrap):
    rng = np.random.default_rng(8)
    side = box if box else 5.0
    pos, _, _, layers, _, iu = random_state(rng, 100, side)
    indptr, idx, d2, _ = csr(pos, 1.0, box, wrap)
    out = np.empty_like(layers)
    K.next_layers(indptr, idx, d2, 1.0, layers, iu, out)
    A = R.adjacency(pos, 1.0, dense_box(box, wrap))
    np.testing.assert_array_equal(dense_layers(out), R.next_layers(A, dense_layers(layers), iu))
    bfs = np.empty_like(layers)
    K.bfs_layers(indptr, idx, d2, 1.0, iu, bfs)
    fixed = np.full(len(pos), np.inf)
    fixed[iu] = 1
    for _ in range(len(pos)):
        fixed = R.next_layers(A, fixed, iu)
    np.testing.assert_array_equal(dense_layers(bfs), fixed)
    assert bfs[iu] == 1


@pytest.mark.parametrize("box,wrap", WORLDS[:3])
def test_attraction_repulsion_match_dense(box, wrap):
    rng = np.random.default_rng(2)
    side = box if box else 4.0
    pos = rng.uniform(0, side, (70, 2))
    indptr, idx, d2, _ = csr(pos, 1.0, box, wrap)
    att = np.empty((70, 2))
    rep = np.empty((70, 2))
    K.attraction_repulsion(indptr, idx, d2, pos, box, wrap, 0.7, 1.0, 4, att, rep)
    da, dr = R.att_rep(pos, dense_box(box, wrap), 0.7, 1.0)
    da[4] = dr[4] = 0.0  # the information UAV feels neither term
    np.testing.assert_allclose(att, da, atol=1e-12)
    np.testing.assert_allclose(rep, dr, atol=1e-12)
    assert np.all(np.einsum("ij,ij->i", rep, rep) >= 0)


def test_wrap_angle_range():
    xs = np.array([-np.pi, np.pi, 3 * np.pi, -3 * np.pi, 0.0, np.nextafter(np.pi, 0), 1e3])
    got = np.array([K.wrap_angle(x) for x in xs])
    assert np.all((got >= -np.pi) & (got < np.pi))
    np.testing.assert_allclose(np.cos(got), np.cos(xs), atol=1e-12)
