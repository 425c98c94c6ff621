"""Offline Pareto fronts: attained by real designs, feasible, non-dominated, complete,
and matching published values (Ma & Wang 2019; Jain & Deb 2014; Fan et al. 2020)."""

import numpy as np
import pytest
from pymoo.problems import get_problem

from tmopt.metrics import igd
from tmopt.problems.fronts import cdtlz, dascmop, front_designs, front_sample, mw, pareto_front
from tmopt.problems.fronts.sampling import grid_front, nondominated_index
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

N = 300  # front points in the tests (the runs use 2000)
MW2D = [k for k in range(1, 15) if k not in (4, 8, 14)]


def _max_dist(A, B):
    """Largest distance from a row of A to its nearest row of B."""
    return float(np.max(np.min(np.linalg.norm(A[:, None] - B[None], axis=2), axis=1)))


# ---- constraints restated in objective space agree with the problems ---------------------
@pytest.mark.parametrize("k", range(1, 15))
def test_mw_constraints_in_objective_space_equal_the_problems(k):
    p = get_problem(f"mw{k}") if k in MW2D else get_problem(f"mw{k}", n_obj=3)
    X = p.xl + np.random.default_rng(k).random((500, p.n_var)) * (p.xu - p.xl)
    out = p.evaluate(X, return_as_dictionary=True)
    np.testing.assert_allclose(mw.constraints(k, out["F"]), out["G"], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("name", ["c1dtlz1", "c1dtlz3", "c2dtlz2", "c3dtlz1", "c3dtlz4"])
@pytest.mark.parametrize("n_obj", [2, 3, 5])
def test_cdtlz_constraints_equal_the_problems(name, n_obj):
    p = get_problem(name, n_var=n_obj + 9, n_obj=n_obj)
    out = p.evaluate(np.random.default_rng(n_obj).random((300, p.n_var)),
                     return_as_dictionary=True)
    G = np.asarray(out["G"]).reshape(300, -1)
    np.testing.assert_allclose(cdtlz.constraints(name, out["F"]), G, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("k", range(1, 10))
def test_dascmop_type3_constraints_equal_the_problems(k):
    p = get_problem(f"dascmop{k}", 12)
    out = p.evaluate(np.random.default_rng(k).random((300, 30)), return_as_dictionary=True)
    G3 = dascmop.type3(out["F"], dascmop.triplet(12)[2])
    np.testing.assert_allclose(G3, out["G"][:, -G3.shape[1]:], rtol=1e-9, atol=1e-9)


# ---- every front point is attained by a design the real problem finds feasible ----------
@pytest.mark.parametrize("name", list(SUITE_PROBLEMS))
@pytest.mark.parametrize("n_var", [None, 10])
def test_front_is_attained_and_feasible(name, n_var):
    p = PymooBenchmark(name, n_var=n_var, front_points=N)
    sample = front_sample(name, p.n_obj, N, p.difficulty)
    X = front_designs(name, p.n_var, p.n_obj, float(p.xu[0]), sample)
    assert np.all(X >= p.xl) and np.all(X <= p.xu)
    out = p.evaluate(X, return_as_dictionary=True)
    np.testing.assert_allclose(out["F"], sample.F, atol=1e-9)
    assert np.max(out["G"]) <= 1e-9
    np.testing.assert_array_equal(p.pareto_front(), sample.F[np.argsort(sample.F[:, 0])]
                                  if p.n_obj == 2 else sample.F)


@pytest.mark.parametrize("name", list(SUITE_PROBLEMS))
def test_front_is_mutually_non_dominated_and_has_igd_zero_to_itself(name):
    p = PymooBenchmark(name, front_points=N)
    F = p.pareto_front()
    assert len(F) >= 10 and np.all(np.isfinite(F))
    assert len(nondominated_index(F)) == len(F)
    assert igd(F, F) == 0.0


# ---- nothing feasible dominates the front, and the front misses nothing: brute force -----
def _brute_force_check(front, grid, spacing):
    """No grid point dominates a front point; grid points the front does not dominate lie
    within ``spacing`` of it."""
    U = np.vstack([front, grid])
    nd = nondominated_index(U)
    assert np.all(np.isin(np.arange(len(front)), nd)), "a feasible point dominates the front"
    free = grid[nd[nd >= len(front)] - len(front)]
    if len(free):
        assert _max_dist(free, front) <= spacing


@pytest.mark.parametrize("k", MW2D)
def test_mw_front_agrees_with_brute_force_grid(k):
    (lo, hi), curve, shift, _ = mw._CURVES[k]
    base = np.column_stack(curve(np.linspace(lo, hi, 1000)))
    s = np.linspace(0, 0.8, 300) if shift is not None else np.geomspace(1, 2, 300)
    grid = grid_front(base, mw.violation(k), s, None if shift is None else np.array(shift))
    front = pareto_front(f"mw{k}", 2, N)
    # spacing: the front's largest step within a piece, plus the grid's step
    steps = np.linalg.norm(np.diff(front, axis=0), axis=1)
    _brute_force_check(front, grid, 2 * np.percentile(steps, 95) + 0.01)


@pytest.mark.parametrize("k", range(1, 7))
@pytest.mark.parametrize("difficulty", [8, 12])
def test_dascmop_front_agrees_with_brute_force_grid(k, difficulty):
    eta, zeta, gamma = dascmop.triplet(difficulty)
    g_lo, g_hi = dascmop.g_range(zeta)
    t = np.linspace(0, 1, 2000)
    t = t[np.sin(20 * np.pi * t) >= 2 * eta - 1]
    grid = grid_front(dascmop._base2(k, t) + g_lo, lambda F: dascmop.type3(F, gamma).max(1),
                      np.linspace(0, min(g_hi - g_lo, 1.0), 300), np.ones(2))
    front = pareto_front(f"dascmop{k}", 2, N, difficulty)
    steps = np.linalg.norm(np.diff(front, axis=0), axis=1)
    _brute_force_check(front, grid, 2 * np.percentile(steps, 95) + 0.01)


# ---- published values and closed forms ---------------------------------------------------
def test_mw5_contains_the_16_points_published_in_platemo():
    # PlatEMO's MW5 GetOptimum lists these points (4 decimals) and their mirror images
    half = np.array([[0, 1], [0.3922, 0.9199], [0.4862, 0.8739], [0.5490, 0.8358],
                     [0.5970, 0.8023], [0.6359, 0.7719], [0.6686, 0.7436], [0.6969, 0.7174]])
    published = np.vstack([half, half[:, ::-1]])
    exact = mw.mw5_isolated_points()
    # 4 decimals; four of PlatEMO's values sit 1 unit of the last digit above the rounded
    # closed form (e.g. 0.8739 for 0.873843), hence 1.5e-4 per coordinate
    np.testing.assert_allclose(exact[np.argsort(exact[:, 0])],
                               published[np.argsort(published[:, 0])], atol=1.5e-4)
    assert _max_dist(exact, pareto_front("mw5", 2, N)) < 1e-9


def test_mw11_contains_its_isolated_point_and_mw2_its_ends():
    assert _max_dist(np.array([[1.0, 1.0]]), pareto_front("mw11", 2, N)) < 1e-12
    F2 = pareto_front("mw2", 2, N)
    np.testing.assert_allclose(F2.sum(1), 1.0)
    assert _max_dist(np.array([[0.0, 1.0], [1.0, 0.0]]), F2) < 1e-12


def test_mw14_intervals_match_an_independent_root_search_and_platemo():
    from scipy.optimize import brentq, minimize_scalar

    def h(x):
        return 6 - np.exp(x) - 1.5 * np.sin(1.1 * np.pi * x ** 2)

    # first interval ends at the local minimum of h, the second starts where h falls to it
    end1 = minimize_scalar(h, bounds=(0.5, 0.9), method="bounded", options={"xatol": 1e-12}).x
    start2 = brentq(lambda x: h(x) - h(end1), 1.0, 1.5, xtol=1e-14)
    # PlatEMO's GetOptimum uses [0, 0.731] and [1.331, 1.5]
    assert abs(end1 - 0.731) < 1e-3 and abs(start2 - 1.331) < 2e-3
    x = pareto_front("mw14", 3, N)[:, :2]
    assert np.all((x <= end1 + 1e-4) | (x >= start2 - 1e-4))  # 1e-4: the 15001-point grid
    assert x.min() == 0.0 and x.max() == pytest.approx(1.5)
    assert x[x < 1.0].max() == pytest.approx(end1, abs=1e-4)
    assert x[x > 1.0].min() == pytest.approx(start2, abs=1e-4)


@pytest.mark.parametrize("n_obj", [2, 3, 5])
def test_cdtlz_closed_forms(n_obj):
    np.testing.assert_allclose(pareto_front("c1dtlz1", n_obj, N).sum(1), 0.5)
    np.testing.assert_allclose(np.linalg.norm(pareto_front("c1dtlz3", n_obj, N), axis=1), 1.0)
    np.testing.assert_allclose(np.linalg.norm(pareto_front("c2dtlz2", n_obj, N), axis=1), 1.0)
    F = pareto_front("c3dtlz4", n_obj, N)
    assert F.max() == pytest.approx(2.0)  # u = e_i -> e_i / sqrt(1 - 3/4) (Jain & Deb)
    F = pareto_front("c3dtlz1", n_obj, N)
    assert F.max() == pytest.approx(1.0)  # w = e_i -> e_i / (1 + 0)
    # C3 fronts lie on the constraint boundaries (Jain & Deb 2014, Sec. VI-A)
    np.testing.assert_allclose(cdtlz.constraints("c3dtlz1", F).max(1), 0.0, atol=1e-12)
    G4 = cdtlz.constraints("c3dtlz4", pareto_front("c3dtlz4", n_obj, N))
    np.testing.assert_allclose(G4.max(1), 0.0, atol=1e-12)


@pytest.mark.parametrize("name", ["c1dtlz1", "c1dtlz3", "c2dtlz2", "c3dtlz1", "c3dtlz4"])
@pytest.mark.parametrize("n_obj", [2, 3])
def test_cdtlz_closed_forms_equal_the_generic_construction(name, n_obj):
    A, B = cdtlz.front(name, n_obj, N), cdtlz.generic_front(name, n_obj, N)
    assert len(A) == len(B) and _max_dist(A, B) < 1e-9 and _max_dist(B, A) < 1e-9


def test_pymoo_c3dtlz1_front_is_infeasible_ours_is_not():
    # pymoo inherits DTLZ1's simplex for C3-DTLZ1; every such point violates a constraint
    theirs = get_problem("c3dtlz1").pareto_front()
    assert np.all(cdtlz.constraints("c3dtlz1", theirs).max(1) > 0)
    assert cdtlz.constraints("c3dtlz1", pareto_front("c3dtlz1", 3, N)).max() <= 1e-12


@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning")  # pymoo's MW6 front code
@pytest.mark.parametrize("name, n_obj", [("mw1", 2), ("mw2", 2), ("mw3", 2), ("mw6", 2),
                                          ("mw12", 2), ("mw4", 3), ("mw8", 3), ("c2dtlz2", 3)])
def test_pymoo_offline_fronts_lie_on_ours(name, n_obj):
    # pymoo computes these fronts itself (MW3, MW12: by walking outwards in 0.1 % steps)
    theirs = np.asarray(get_problem(name).pareto_front())
    ours = pareto_front(name, n_obj, 500)
    nn = np.min(np.linalg.norm(ours[:, None] - ours[None], axis=2) + 9 * np.eye(len(ours)), 1)
    assert _max_dist(theirs, ours) <= 2 * np.percentile(nn, 95) + 2e-3


def test_dascmop_without_constraints_is_the_plain_curve_and_zeta_shifts_it():
    F = pareto_front("dascmop1", 2, N, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(F[:, 1], 1 - F[:, 0] ** 2, atol=1e-12)
    assert F[:, 0].min() == 0.0 and F[:, 0].max() == pytest.approx(1.0)
    # zeta > 0: g must reach d = 0.5 (Fan et al. 2020), so the front moves by (0.5, 0.5)
    for k in range(1, 10):
        assert pareto_front(f"dascmop{k}", 2 if k <= 6 else 3, N, 8).min() >= 0.5 - 1e-12


def test_unknown_names_and_difficulties_are_refused():
    with pytest.raises(ValueError, match="no offline Pareto front for problem 'zdt1'"):
        pareto_front("zdt1", 2)
    with pytest.raises(ValueError, match="1..16"):
        pareto_front("dascmop1", 2, N, 0)
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        pareto_front("dascmop1", 2, N, [0.5, 2.0, 0.5])
