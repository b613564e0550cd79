"""Oracle tests: the sparse numba kernels against the dense transcription of the paper
(``dense_reference.py``) on small swarms, in open, periodic and seam-free periodic worlds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swarmnav.methods.vicsek import kernels as K

from . import dense_reference as R

NO_NOISE = np.zeros(0)

MODELS = {"vem": K.VEM, "vem-a": K.VEM_A, "ivem": K.IVEM, "ivem-a": K.IVEM_A, "wvem": K.WVEM, "hwvem": K.HWVEM}


def csr(pos, radius, box=0.0, wrap=True, cap=None):
    cap = cap if cap is not None else 64 * len(pos)
    idx = np.empty(cap, dtype=np.int64)
    d2 = np.empty(cap)
    order, start, end, total = K.neighbour_csr(pos, radius, box, wrap, idx, d2)
    if total > cap and cap > 1:
        return csr(pos, radius, box, wrap, total)
    assert sorted(order.tolist()) == list(range(len(pos)))  # a permutation of the agents
    return (order, start, end, idx[:total], d2[:total]), total


def row(nb, i):
    """Neighbour indices and squared distances of agent ``i``."""
    _, start, end, idx, d2 = nb
    return idx[start[i]:end[i]], d2[start[i]:end[i]]


def dense_box(box, wrap):
    return box if (box > 0 and wrap) else None


WORLDS = [(0.0, True), (6.0, True), (6.0, False), (2.5, True)]  # open, periodic, no seam, < 3 cells


@pytest.mark.parametrize("box,wrap", WORLDS)
def test_neighbour_lists_match_bruteforce(box, wrap):
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, box if box else 6.0, (150, 2))
    nb, total = csr(pos, 1.0, box, wrap)
    A = R.adjacency(pos, 1.0, dense_box(box, wrap))
    _, dist = R.offsets(pos, dense_box(box, wrap))
    assert total == A.sum() and np.sum(nb[2] - nb[1]) == total  # rows tile the entries
    np.testing.assert_array_equal(nb[1][nb[0]], np.r_[0, nb[2][nb[0]][:-1]])  # stored in `order`
    for i in range(len(pos)):
        js, d2 = row(nb, i)
        assert len(set(js.tolist())) == len(js)  # no agent listed twice
        assert set(js.tolist()) == set(np.nonzero(A[i])[0].tolist())
        np.testing.assert_allclose(d2, dist[i, js] ** 2, rtol=1e-12)


def test_neighbour_lists_exclude_coincident_agents_and_report_overflow():
    pos = np.array([[0.0, 0.0], [0.0, 0.0], [0.5, 0.0], [3.0, 3.0]])
    nb, total = csr(pos, 1.0)
    assert row(nb, 0)[0].tolist() == [2]  # 0 < |x_i - x_j|: the twin is not a neighbour
    assert total == 4
    _, total_small = csr(pos, 1.0, cap=1)
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
        nb, _ = csr(pos, 1.0, box, wrap)
        r2 = 1.0
        iu_nb = np.zeros(len(pos), dtype=np.bool_)
        if iu >= 0:
            iu_nb[row(nb, iu)[0]] = True
        out = np.empty(len(pos))
        K.genuine_heading(MODELS[model], *nb, r2, theta, theta_g, layers, avoiding, iu, iu_nb, theta_d,
                          kw["p1"], kw["p2"], kw["use_nei"], 30.0, 18.0, 1.0, 100.0, NO_NOISE, out)
        A = R.adjacency(pos, 1.0, dense_box(box, wrap))
        ref = R.genuine_heading(model, A, theta, theta_g, dense_layers(layers), avoiding, iu if iu >= 0 else None,
                                theta_d, **kw)
        np.testing.assert_allclose(R.wrap(out - ref), 0.0, atol=1e-9, err_msg=f"trial {trial}")


@pytest.mark.parametrize("model", ["ivem", "ivem-a"])
@pytest.mark.parametrize("unsigned,own", [(True, False), (False, True), (True, True)])
@pytest.mark.parametrize("box,wrap", WORLDS[:3])
def test_ivem_readings_match_dense_paper_equations(model, unsigned, own, box, wrap):
    """ivem_range = unsigned (headings compared as numbers in [0, 2 pi)) and ivem_self (the
    agent's own heading among the min and max) against the plain transcription of eq. (30)-(31)."""
    rng = np.random.default_rng(12)
    side = box if box else 5.0
    for trial in range(4):
        pos, theta, theta_g, layers, avoiding, iu = random_state(rng, 90, side, model == "ivem-a")
        nb, _ = csr(pos, 1.0, box, wrap)
        iu_nb = np.zeros(len(pos), dtype=np.bool_)
        if iu >= 0:
            iu_nb[row(nb, iu)[0]] = True
        out = np.empty(len(pos))
        K.genuine_heading(MODELS[model], *nb, 1.0, theta, theta_g, layers, avoiding, iu, iu_nb, 0.7,
                          0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out, K.IVEM_PRINTED,
                          math.pi if unsigned else 0.0, own)
        A = R.adjacency(pos, 1.0, dense_box(box, wrap))
        ref = R.genuine_heading(model, A, theta, theta_g, dense_layers(layers), avoiding, iu if iu >= 0 else None,
                                0.7, ivem_unsigned=unsigned, ivem_self=own, **KW[0])
        np.testing.assert_allclose(R.wrap(out - ref), 0.0, atol=1e-9, err_msg=f"trial {trial}")
        signed = np.empty(len(pos))
        K.genuine_heading(MODELS[model], *nb, 1.0, theta, theta_g, layers, avoiding, iu, iu_nb, 0.7,
                          0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, signed)
        assert np.any(np.abs(R.wrap(out - signed)) > 1e-6)  # the reading changes some agent's heading


@pytest.mark.parametrize("model", ["ivem", "ivem-a"])
@pytest.mark.parametrize("box,wrap", WORLDS[:3])
def test_ivem_raw_numbers_match_dense_paper_equations(model, box, wrap):
    """ivem_range = raw: eq. (30)-(31) compare the unwrapped numbers given (here spread over
    [-pi, 2 pi), as a run that mixes [0, 2 pi) draws and arc tangents holds them), and the kernel
    returns eq. (30)'s sums, the arc tangents and theta_d as the new numbers."""
    rng = np.random.default_rng(13)
    side = box if box else 5.0
    for trial in range(4):
        pos, theta, theta_g, layers, avoiding, iu = random_state(rng, 90, side, model == "ivem-a")
        keys = np.where((theta < 0) & (rng.random(len(theta)) < 0.5), theta + 2 * np.pi, theta)  # half in [pi, 2 pi)
        nb, _ = csr(pos, 1.0, box, wrap)
        iu_nb = np.zeros(len(pos), dtype=np.bool_)
        if iu >= 0:
            iu_nb[row(nb, iu)[0]] = True
        out = np.empty(len(pos))
        new_keys = np.empty(len(pos))
        K.genuine_heading(MODELS[model], *nb, 1.0, theta, theta_g, layers, avoiding, iu, iu_nb, 0.7,
                          0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out, K.IVEM_PRINTED, 0.0, False,
                          keys, new_keys)
        A = R.adjacency(pos, 1.0, dense_box(box, wrap))
        ref, ref_keys = R.genuine_heading(model, A, theta, theta_g, dense_layers(layers), avoiding,
                                          iu if iu >= 0 else None, 0.7, keys=keys, **KW[0])
        np.testing.assert_allclose(R.wrap(out - ref), 0.0, atol=1e-9, err_msg=f"trial {trial}")
        np.testing.assert_allclose(new_keys, ref_keys, atol=1e-9, err_msg=f"trial {trial}")
        np.testing.assert_allclose(R.wrap(new_keys - out), 0.0, atol=1e-9)  # the numbers are the headings


def test_heading_kernel_ignores_entries_beyond_the_alignment_radius():
    """The CSR may be built at the attraction range; alignment uses only r."""
    rng = np.random.default_rng(5)
    pos, theta, theta_g, layers, avoiding, iu = random_state(rng, 80, 5.0)
    for code in MODELS.values():
        outs = []
        for radius in (0.8, 1.3):
            nb, _ = csr(pos, radius)
            iu_nb = np.zeros(80, dtype=np.bool_)
            js, d2 = row(nb, iu)
            iu_nb[js[d2 <= 0.64]] = True
            out = np.empty(80)
            K.genuine_heading(code, *nb, 0.64, theta, theta_g, layers, avoiding, iu, iu_nb, 0.3,
                              0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out)
            outs.append(out)
            if radius == 0.8:  # a list built at r: r2 = inf (no distance test) gives the same
                out_inf = np.empty(80)
                K.genuine_heading(code, *nb, np.inf, theta, theta_g, layers, avoiding, iu, iu_nb, 0.3,
                                  0.1, 5.0, True, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out_inf)
                np.testing.assert_array_equal(out_inf, out)
        np.testing.assert_allclose(outs[0], outs[1], atol=1e-12)


def test_hwvem_deep_layers_do_not_underflow():
    """p2^-l underflows for l ~ 150 at p2 = 100; the row-relative form must not."""
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [5.0, 5.0]])
    theta = np.array([0.0, 1.0, 2.0, 0.0])
    layers = np.array([400, 399, 401, 1], dtype=np.int64)
    nb, _ = csr(pos, 1.0)
    out = np.empty(4)
    K.genuine_heading(K.HWVEM, *nb, 1.0, theta, theta.copy(), layers, np.zeros(4, np.bool_), 3,
                      np.zeros(4, np.bool_), 0.0, 0.0, 100.0, False, 30.0, 18.0, 1.0, 100.0, NO_NOISE, out)
    # agent 0 hears layer 399 (weight 1/399 * 1) and layer 401 (1/401 * 1e-4): essentially agent 1
    w1, w2 = 1 / 399, 1 / 401 * 100.0**-2
    assert out[0] == pytest.approx(math.atan2(w1 * math.sin(1) + w2 * math.sin(2), w1 * math.cos(1) + w2 * math.cos(2)))


@pytest.mark.parametrize("box,wrap", WORLDS)
def test_layers_match_dense_eq5_and_bfs_is_its_fixed_point(box, wrap):
    rng = np.random.default_rng(8)
    side = box if box else 5.0
    pos, _, _, layers, _, iu = random_state(rng, 100, side)
    nb, _ = csr(pos, 1.0, box, wrap)
    out = np.empty_like(layers)
    K.next_layers(*nb, 1.0, layers, iu, out)
    A = R.adjacency(pos, 1.0, dense_box(box, wrap))
    np.testing.assert_array_equal(dense_layers(out), R.next_layers(A, dense_layers(layers), iu))
    bfs = np.empty_like(layers)
    K.bfs_layers(*nb, 1.0, iu, bfs)
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
    nb, _ = csr(pos, 1.0, box, wrap)
    att = np.empty((70, 2))
    rep = np.empty((70, 2))
    K.attraction_repulsion(*nb, pos, box, wrap, 0.7, 1.0, 4, att, rep)
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


def test_noise_is_added_and_wrapped_except_for_the_information_uav():
    rng = np.random.default_rng(6)
    pos, theta, theta_g, layers, avoiding, iu = random_state(rng, 60, 4.0)
    nb, _ = csr(pos, 1.0)
    iu_nb = np.zeros(60, np.bool_)
    outs = []
    noise = rng.uniform(-2.0, 2.0, 60)
    for nz in (NO_NOISE, noise):
        out = np.empty(60)
        K.genuine_heading(K.IVEM_A, *nb, 1.0, theta, theta_g, layers, avoiding, iu, iu_nb, 0.4, 0.1, 5.0, True,
                          30.0, 18.0, 1.0, 100.0, nz, out)
        outs.append(out)
    expect = R.wrap(outs[0] + noise)
    expect[iu] = 0.4
    np.testing.assert_allclose(outs[1], expect, atol=1e-12)
    assert np.all((outs[1] >= -np.pi) & (outs[1] < np.pi))


def test_consistency_kernel_matches_measures():
    from swarmnav.methods.vicsek.measures import circular_mean, deg_con

    rng = np.random.default_rng(1)
    for spread in (3.0, 0.3, 0.003):
        th = R.wrap(0.7 + rng.normal(0, spread, 500))
        for norm, code in (("l1", K.NORM_L1), ("l2", K.NORM_L2), ("linf", K.NORM_LINF)):
            assert K.consistency(th, 0.7, False, code) == pytest.approx(deg_con(th, 0.7, norm), abs=1e-12)
            assert K.consistency(th, 0.0, True, code) == pytest.approx(deg_con(th, circular_mean(th), norm), abs=1e-12)


def test_velocity_kernel_is_eq25_26():
    rng = np.random.default_rng(9)
    n = 50
    theta = rng.uniform(-np.pi, np.pi, n)
    att, rep = rng.normal(0, 1, (n, 2)), rng.normal(0, 1, (n, 2))
    avoiding = rng.random(n) < 0.3
    for tangent in (False, True):
        out = np.empty((n, 2))
        K.velocity(theta, avoiding, att, rep, 0.1, 0.1, 0.003, 0.1, tangent, out)
        u = np.column_stack([np.cos(theta), np.sin(theta)])
        v = 0.1 * u + 0.1 * rep + 0.003 * att
        sp = np.linalg.norm(v, axis=1)
        expect = v / sp[:, None] * np.minimum(sp, 0.1)[:, None]
        if tangent:
            expect[avoiding] = (np.minimum(sp, 0.1)[:, None] * u)[avoiding]
        np.testing.assert_allclose(out, expect, atol=1e-15)
    out = np.empty((n, 2))
    K.velocity(theta, avoiding, np.zeros((0, 2)), np.zeros((0, 2)), 0.03, 0.1, 0.003, 0.1, True, out)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 0.03)  # eq. (7): constant speed v0
