"""The SPH kernel of eq. (4) and the forces of Algorithm 1 against plain references."""

import math

import numpy as np
import pytest

from swarmnav.methods.sph.kernel import environment_force, kernel_sigma, kernel_slope, kernel_value, sph_forces
from swarmnav.methods.sph.parts.guard import band_guard

H, C = 10.0, 54.97


def test_paper_kernel_values_and_continuity():
    s = C / (math.pi * H**3)
    assert kernel_sigma(C, H) == pytest.approx(s)
    assert kernel_value(np.array([0.0]), H, C)[0] == pytest.approx(s)
    # both branches meet at k = 1 (value 1/4) and the kernel vanishes at and beyond 2h
    np.testing.assert_allclose(kernel_value(np.array([H - 1e-9, H + 1e-9]), H, C), 0.25 * s, rtol=1e-6)
    assert np.all(kernel_value(np.array([2 * H, 2.5 * H]), H, C) == 0.0)


def test_paper_slope_is_the_derivative_of_the_kernel():
    r = np.linspace(0.3, 19.7, 50)
    eps = 1e-6
    fd = (kernel_value(r + eps, H, C) - kernel_value(r - eps, H, C)) / (2 * eps)
    np.testing.assert_allclose(kernel_slope(r, H, C), fd, rtol=1e-5, atol=1e-12)


def test_released_kernel_is_the_integer_division_evaluation():
    """sph_zhang_3d.cpp: 3/2 -> 1, 3/4 -> 0, 1/4 -> 0, 9/4 -> 2, -3/4 -> 0; 2-D normalisation
    10 c / (7 pi h^2); gradient multiplied by h."""
    sig = 10 * C / (7 * math.pi * H**2)
    r = np.array([0.0, 3.0, 9.0, 12.0])
    k = r / H
    np.testing.assert_allclose(kernel_value(r, H, C, "released"), sig * np.where(k <= 1, 1 - k**2, 0.0))
    np.testing.assert_allclose(kernel_slope(r, H, C, "released"), sig * H * np.where(k <= 1, -3 * k + 2 * k**2, 0.0))


def _loop_forces(x, v, pairs, kind, rho0=1e6, k_den=1.0, k_rep=1.0, k_vis=1.5, gamma=7.0, rep_cutoff=0.0):
    """Plain per-agent loop of Algorithm 1 (lines 5-10), the oracle of the vectorised one."""
    n = len(x)
    nb = {a: [] for a in range(n)}
    for a, b in pairs:
        nb[a].append(b)
        nb[b].append(a)
    out = np.zeros_like(x)
    for a in range(n):
        rho = kernel_value(np.array([0.0]), H, C, kind)[0] + sum(
            kernel_value(np.array([np.linalg.norm(x[a] - x[b])]), H, C, kind)[0] for b in nb[a])
        grad = np.zeros(x.shape[1])
        rep = np.zeros(x.shape[1])
        for b in nb[a]:
            q = x[a] - x[b]
            r = np.linalg.norm(q)
            grad += kernel_slope(np.array([r]), H, C, kind)[0] * q / r
            if rep_cutoff == 0 or r < rep_cutoff:
                rep += q / r**2
        out[a] = -k_den / rho * ((rho / rho0) ** gamma - 1) * grad + k_rep * rep - k_vis * v[a]
    return out


@pytest.mark.parametrize("kind", ["paper", "released"])
@pytest.mark.parametrize("dim", [2, 3])
def test_vectorised_forces_match_the_loop(kind, dim):
    rng = np.random.default_rng(3)
    x = rng.uniform(-6, 6, (9, dim))
    v = rng.normal(size=(9, dim))
    pairs = [(a, b) for a in range(9) for b in range(a + 1, 9) if rng.random() < 0.6]
    i = np.array([p[0] for p in pairs])
    j = np.array([p[1] for p in pairs])
    f, rho, parts = sph_forces(x, v, i, j, h=H, c=C, m=1.0, k_den=1.0, k_rep=1.0, k_vis=1.5, rho0=1e6,
                               gamma=7.0, kind=kind)
    np.testing.assert_allclose(f, _loop_forces(x, v, pairs, kind), rtol=1e-10, atol=1e-12)
    # repulsion is pairwise antisymmetric: it sums to zero over the swarm
    np.testing.assert_allclose(parts["repulsive"].sum(axis=0), 0.0, atol=1e-10)


@pytest.mark.parametrize("dim", [2, 3])
def test_repulsion_cut_off_drops_only_the_pairs_beyond_it(dim):
    rng = np.random.default_rng(5)
    x = rng.uniform(-4, 4, (12, dim))
    v = rng.normal(size=(12, dim))
    pairs = [(a, b) for a in range(12) for b in range(a + 1, 12)]
    i, j = np.array(pairs).T
    kw = dict(h=H, c=C, m=1.0, k_den=1.0, k_rep=1.0, k_vis=1.5, rho0=1e6, gamma=7.0)
    f, _, parts = sph_forces(x, v, i, j, rep_cutoff=3.0, **kw)
    np.testing.assert_allclose(f, _loop_forces(x, v, pairs, "paper", rep_cutoff=3.0), rtol=1e-10, atol=1e-12)
    _, _, full = sph_forces(x, v, i, j, **kw)
    assert not np.allclose(parts["repulsive"], full["repulsive"])  # some pairs are beyond 3 m
    np.testing.assert_array_equal(parts["density"], full["density"])  # the cut-off is line 9's only
    _, _, wide = sph_forces(x, v, i, j, rep_cutoff=100.0, **kw)  # beyond every pair: the paper's sum
    np.testing.assert_array_equal(wide["repulsive"], full["repulsive"])


def test_density_term_attracts_below_and_repels_above_the_reference_density():
    x = np.array([[0.0, 0.0], [2.0, 0.0]])
    v = np.zeros((2, 2))
    i, j = np.array([0]), np.array([1])
    kw = dict(h=H, c=C, m=1.0, k_den=1.0, k_rep=1.0, k_vis=1.5, gamma=7.0)
    _, rho, low = sph_forces(x, v, i, j, rho0=1e6, **kw)  # rho << rho0 (Table I): aggregation
    assert low["density"][0, 0] > 0 and low["density"][1, 0] < 0
    _, _, high = sph_forces(x, v, i, j, rho0=0.5 * rho[0], **kw)  # rho > rho0: dispersion
    assert high["density"][0, 0] < 0 and high["density"][1, 0] > 0
    # repulsion magnitude k_rep / r, viscosity -k_vis v
    assert low["repulsive"][0, 0] == pytest.approx(-1.0 / 2.0)
    _, _, p = sph_forces(x, np.array([[1.0, 0.0], [0.0, -2.0]]), i, j, rho0=1e6, **kw)
    np.testing.assert_allclose(p["viscosity"], [[-1.5, 0.0], [0.0, 3.0]])


def test_environment_force_pushes_away_inside_the_threshold_only():
    grad = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0]])  # ESDF gradient: away from the obstacle
    f = environment_force(np.array([0.2, 0.7, np.inf]), grad, k_env=10.0, d_thr=0.5)
    np.testing.assert_allclose(f, [[2 * 10 * 0.3, 0.0], [0.0, 0.0], [0.0, 0.0]])


def _loop_band_guard(track, d, grad, d_thr):
    """Plain per-robot reading of the band guard, the oracle."""
    out = track.copy()
    for i in range(len(d)):
        n = np.linalg.norm(grad[i])
        if d[i] < d_thr and n > 1e-12:
            u = grad[i] / n
            along = float(track[i] @ u)
            if along < 0.0:
                out[i] = track[i] - along * u
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_band_guard_drops_only_the_push_into_an_obstacle_inside_the_band(dim):
    rng = np.random.default_rng(dim)
    n = 400
    track = rng.normal(0.0, 3.0, (n, dim))
    d = rng.uniform(-0.2, 1.0, n)
    d[:5] = np.inf  # no obstacle in range
    grad = rng.normal(0.0, 1.0, (n, dim)) * rng.uniform(0.5, 1.5, (n, 1))  # ESDF gradients, not exactly unit
    grad[5] = 0.0  # a robot on a ridge of the ESDF
    out = band_guard(track, d, grad, d_thr=0.5)
    np.testing.assert_allclose(out, _loop_band_guard(track, d, grad, 0.5), rtol=0, atol=1e-12)
    unit = grad / np.maximum(np.linalg.norm(grad, axis=1), 1e-12)[:, None]
    inside = (d < 0.5) & (np.linalg.norm(grad, axis=1) > 0)
    along = np.einsum("nd,nd->n", out, unit)
    assert np.all(along[inside] >= -1e-12)  # never towards the obstacle inside the band
    keep = ~inside | (np.einsum("nd,nd->n", track, unit) >= 0)
    np.testing.assert_array_equal(out[keep], track[keep])  # away from it, or outside the band: as given
    tangent = track - np.einsum("nd,nd->n", track, unit)[:, None] * unit
    np.testing.assert_allclose((out - np.einsum("nd,nd->n", out, unit)[:, None] * unit)[inside], tangent[inside],
                               atol=1e-12)  # the part along the obstacle is kept
    assert (~keep).sum() > 50  # the case under test occurs


def test_paper_kernel_is_the_3d_normalised_cubic_spline_scaled_by_c():
    """Eq. (4)'s c / (pi h^3) is the 3-D normalisation of the cubic spline: the kernel integrates
    to c over space (numerical quadrature, relative error 1e-9), at any h. Over the plane the
    same printed kernel integrates to 7 c / (10 h), not c (the 2-D normalisation is
    10 / (7 pi h^2)); both are checked so a change of either normalisation is seen."""
    from scipy.integrate import quad

    for h in (0.5, 10.0):
        w = lambda r: float(kernel_value(np.array([r]), h, C)[0])  # noqa: E731
        vol = sum(quad(lambda r: 4 * math.pi * r * r * w(r), a, b, epsabs=0, epsrel=1e-12)[0]
                  for a, b in ((0, h), (h, 2 * h)))
        area = sum(quad(lambda r: 2 * math.pi * r * w(r), a, b, epsabs=0, epsrel=1e-12)[0]
                   for a, b in ((0, h), (h, 2 * h)))
        assert vol / C == pytest.approx(1.0, rel=1e-9)
        assert area == pytest.approx(7 * C / (10 * h), rel=1e-9)


def test_forces_in_3d_are_the_planar_forces_of_a_planar_swarm_and_rotate_with_it():
    """Algorithm 1 is written once for (N, d): a swarm in the plane z = 1.3 gets the planar
    forces with zero z component, and rotating a 3-D swarm rotates its forces."""
    rng = np.random.default_rng(7)
    x2, v2 = rng.uniform(-3, 3, (9, 2)), rng.normal(size=(9, 2))
    i, j = np.triu_indices(9, 1)
    kw = dict(h=H, c=C, m=1.0, k_den=1.0, k_rep=1.0, k_vis=1.5, rho0=1e6, gamma=7.0)
    f2, rho2, _ = sph_forces(x2, v2, i, j, **kw)
    x3 = np.column_stack([x2, np.full(9, 1.3)])
    v3 = np.column_stack([v2, np.zeros(9)])
    f3, rho3, _ = sph_forces(x3, v3, i, j, **kw)
    np.testing.assert_allclose(f3[:, :2], f2, rtol=1e-12, atol=1e-12)
    assert np.all(f3[:, 2] == 0.0)
    np.testing.assert_allclose(rho3, rho2, rtol=1e-12)
    x, v = rng.uniform(-3, 3, (9, 3)), rng.normal(size=(9, 3))
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    f, _, _ = sph_forces(x, v, i, j, **kw)
    fr, _, _ = sph_forces(x @ q.T, v @ q.T, i, j, **kw)
    np.testing.assert_allclose(fr, f @ q.T, rtol=1e-9, atol=1e-9)
