"""LIR-CMOP1-14 against code we did not write (jMetal's Java, PlatEMO's MATLAB) and their
fronts against PlatEMO's published points and a brute-force search."""

import numpy as np
import pytest

from tests.problems.test_fronts import _brute_force_check, _max_dist
from tmopt.problems import lircmop as lir
from tmopt.problems.fronts import lircmop as flir
from tmopt.problems.fronts import pareto_front
from tmopt.problems.fronts.sampling import nondominated
from tmopt.problems.lircmop import LIRCMOP
from tmopt.problems.suites import PymooBenchmark

# ---- jMetal 6 (Java, org.uma.jmetal.problem.multiobjective.lircmop), run on the points
# np.random.default_rng(2019).random((3, 30)).round(6): its objectives and constraints
# (jMetal writes c >= 0 feasible, so G = -c). jMetal's LIR-CMOP5-14 carry typos (e.g.
# "+ 7057" for "+ 0.7057" in LIR-CMOP5-6, 1.7957 for 1.7057 in LIR-CMOP9) and are not
# used; LIR-CMOP1-4 follow the paper as ours do.
JMETAL_F = {
    1: [[1.782407298083555, 3.4993757589205186], [6.590115297017861, 3.6454899566292642],
        [3.9658494320988673, 7.519871088406496]],
    2: [[1.782407298083555, 3.1399193168883137], [6.590115297017861, 3.5706156977480914],
        [3.9658494320988673, 7.435926814023361]],
}
JMETAL_C = [[-1.2830008231317473, -4.0614649096508355], [-26.38937376931883, -9.237297263887614],
            [-11.928670979197138, -36.17924796928381]]
JMETAL_C3 = [-0.1731119703450566, -0.3780336472664841, -0.07109639920838984]


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_lircmop1_4_equal_jmetal(k):
    X = np.random.default_rng(2019).random((3, 30)).round(6)
    out = LIRCMOP(k, 30).evaluate(X, return_as_dictionary=True)
    F = JMETAL_F[1 if k in (1, 3) else 2]
    C = np.array(JMETAL_C) if k <= 2 else np.column_stack([JMETAL_C, JMETAL_C3])
    np.testing.assert_allclose(out["F"], F, rtol=1e-14)
    np.testing.assert_allclose(out["G"], -C, rtol=1e-13)


# ---- PlatEMO's MATLAB (Problems/Multi-objective optimization/LIR-CMOP), restated as its
# per-column loops, one row at a time: a second code path for every problem.
def _platemo(k: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = len(x)
    if k >= 13:
        s = sum(10 * (x[j - 1] - 0.5) ** 2 for j in range(3, n + 1))
        a, b = 0.5 * np.pi * x[0], 0.5 * np.pi * x[1]
        f = (1.7057 + s) * np.array([np.cos(a) * np.cos(b), np.cos(a) * np.sin(b), np.sin(a)])
        r2 = (f ** 2).sum()
        c = [(r2 - 9) * (4 - r2), (r2 - 3.61) * (3.24 - r2)]
        if k == 14:
            c.append((r2 - 3.0625) * (2.56 - r2))
        return f, np.array(c)
    s1 = s2 = 0.0
    for j in range(2, n + 1):
        if k <= 4:  # LIR-CMOP1's form (the paper's); PlatEMO's 2-4 use x1 instead
            if j % 2 == 1:
                s1 += (x[j - 1] - np.sin(0.5 * np.pi * x[0])) ** 2
            else:
                s2 += (x[j - 1] - np.cos(0.5 * np.pi * x[0])) ** 2
        elif j % 2 == 1:
            s1 += (x[j - 1] - np.sin((0.5 * j / n * np.pi) * x[0])) ** 2
        else:
            s2 += (x[j - 1] - np.cos((0.5 * j / n * np.pi) * x[0])) ** 2
    shape = x[0] ** 2 if k in (1, 3, 6, 8, 9, 12) else x[0] ** 0.5
    if k <= 4:
        f = np.array([x[0] + s1, 1 - shape + s2])
        c = [(0.5 - s1) * (0.51 - s1), (0.5 - s2) * (0.51 - s2)]
        if k >= 3:
            c.append(0.5 - np.sin(20 * np.pi * x[0]))
        return f, np.array(c)
    if k <= 8:
        f = np.array([x[0] + 10 * s1 + 0.7057, 1 - shape + 10 * s2 + 0.7057])
    else:
        f = 1.7057 * np.array([x[0] * (10 * s1 + 1), (1 - shape) * (10 * s2 + 1)])
    return f, _platemo_constraint(k, f)


# PlatEMO's Constraint(PopObj) of LIR-CMOP5-12: (p, q, a, b) per ellipse, then the wave
_PQAB = {5: [(1.6, 1.6, 2, 4), (2.5, 2.5, 2, 8)], 6: [(1.8, 1.8, 2, 8), (2.8, 2.8, 2, 8)],
         7: [(1.2, 1.2, 2, 6), (2.25, 2.25, 2.5, 12), (3.5, 3.5, 2.5, 10)],
         9: [(1.4, 1.4, 1.5, 6)], 10: [(1.1, 1.2, 2, 4)], 11: [(1.2, 1.2, 1.5, 5)],
         12: [(1.6, 1.6, 1.5, 6)]}
_PQAB[8] = _PQAB[7]
_WAVE = {9: 2.0, 10: 1.0, 11: 2.1, 12: 2.5}


def _platemo_constraint(k, f):
    th, al = -0.25 * np.pi, 0.25 * np.pi
    c = [0.1 - ((f[0] - p) * np.cos(th) - (f[1] - q) * np.sin(th)) ** 2 / a ** 2
         - ((f[0] - p) * np.sin(th) + (f[1] - q) * np.cos(th)) ** 2 / b ** 2
         for p, q, a, b in _PQAB[k]]
    if k in _WAVE:
        c.append(_WAVE[k] - f[0] * np.sin(al) - f[1] * np.cos(al)
                 + np.sin(4 * np.pi * (f[0] * np.cos(al) - f[1] * np.sin(al))))
    return np.array(c)


@pytest.mark.parametrize("k", range(1, 15))
@pytest.mark.parametrize("n_var", [30, 7])
def test_lircmop_equals_platemo_loops(k, n_var):
    X = np.random.default_rng(k).random((50, n_var))
    out = LIRCMOP(k, n_var).evaluate(X, return_as_dictionary=True)
    ref = [_platemo(k, x) for x in X]
    np.testing.assert_allclose(out["F"], [f for f, _ in ref], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out["G"], [c for _, c in ref], rtol=1e-12, atol=1e-12)


# ---- fronts ------------------------------------------------------------------------------
@pytest.mark.parametrize("k, shape", [(1, "sq"), (2, "sqrt"), (3, "sq"), (4, "sqrt")])
def test_lircmop1_4_fronts_are_platemos_closed_forms(k, shape):
    F = pareto_front(f"lircmop{k}", 2, 400)
    t = F[:, 0] - 0.5
    np.testing.assert_allclose(F[:, 1], 1.5 - (t ** 2 if shape == "sq" else np.sqrt(t)),
                               atol=1e-15)
    if k >= 3:  # PlatEMO: the points with sin(20 pi t) < 0.5 removed
        assert np.all(np.sin(20 * np.pi * t) >= 0.5 - 1e-12)
        assert len(np.unique(np.round(t * 10, 0))) == 10  # one piece in each tenth
    else:
        assert t.min() == 0.0 and t.max() == 1.0


@pytest.mark.parametrize("k, radius", [(13, 1.7057), (14, 1.75)])
def test_lircmop13_14_fronts_are_spheres(k, radius):
    F = pareto_front(f"lircmop{k}", 3, 300)
    np.testing.assert_allclose(np.linalg.norm(F, axis=1), radius)
    # PlatEMO's LIR-CMOP14 front has radius sqrt(3.0625) = 1.75: the band 1.6..1.75 is
    # infeasible and 1.75 is its upper edge
    assert lir.objective_constraints(k, F).max() <= 1e-12
    assert lir.objective_constraints(k, F * (1 - 1e-6)).max() > 0 or k == 13


def _platemo_curve_front(k, n=1000):
    """PlatEMO's GetOptimum of LIR-CMOP5, 6, 9, 10: the unconstrained curve, infeasible
    points removed (9, 10: plus the listed end points)."""
    t = np.linspace(0, 1, n)
    shape = t ** 2 if k in (6, 9) else np.sqrt(t)
    if k <= 6:
        R = np.column_stack([t, 1 - shape]) + 0.7057
    else:
        R = 1.7057 * np.column_stack([t, 1 - shape])
    R = R[_platemo_constraint_rows(k, R).max(1) <= 0]
    extra = {9: [[0, 2.182], [1.856, 0]], 10: [[1.747, 0]]}.get(k, [])
    return np.vstack([R, *extra]) if extra else R


def _platemo_constraint_rows(k, F):
    return np.array([_platemo_constraint(k, f) for f in F])


_PLATEMO_POINTS = {
    11: [[1.3965, 0.1591], [1.0430, 0.5127], [0.6894, 0.8662], [0.3359, 1.2198],
         [0.0106, 1.6016], [0, 2.1910], [1.8730, 0]],
    12: [[1.6794, 0.4419], [1.3258, 0.7955], [0.9723, 1.1490], [2.0320, 0.0990],
         [0.6187, 1.5026], [0.2652, 1.8562], [0, 2.2580], [2.5690, 0]],
}


@pytest.mark.parametrize("k", [5, 6, 7, 8, 9, 10, 11, 12])
def test_lircmop5_12_fronts_against_platemos_points(k):
    """PlatEMO's points are feasible and lie on, or just behind, our front: none of them
    dominates a point of ours, and each is within 0.01 of it (PlatEMO walks outwards in
    0.1 % steps (7, 8) and lists rounded end points (9-12))."""
    ours = pareto_front(f"lircmop{k}", 2, 2000)
    if k in (7, 8):
        # PlatEMO's LIR-CMOP8 GetOptimum uses LIR-CMOP7's sqrt curve, although its
        # objectives use x1^2; the walk is restated here on LIR-CMOP8's own curve
        t = np.linspace(0, 1, 400)
        shape = np.sqrt(t) if k == 7 else t ** 2
        R = np.column_stack([t, 1 - shape]) + 0.7057
        c1 = lambda R: _platemo_constraint(k, R.T)[0]  # noqa: E731
        while np.any(c1(R) > 0):
            bad = c1(R) > 0
            R[bad] = (R[bad] - 0.7057) * 1.001 + 0.7057
        theirs = R[_platemo_constraint_rows(k, R).max(1) <= 0]
    elif k in (11, 12):
        theirs = np.array(_PLATEMO_POINTS[k])
    else:
        theirs = _platemo_curve_front(k)
    # PlatEMO's 4-decimal points can sit up to 5e-5 inside a boundary
    assert _platemo_constraint_rows(k, theirs).max() <= (1e-3 if k in (11, 12) else 0.0)
    both = np.vstack([ours, theirs])
    nd = nondominated(both)
    assert _max_dist(ours, nd) < 1e-12 or k in (11, 12), "a PlatEMO point dominates ours"
    assert _max_dist(theirs, ours) < 0.01


@pytest.mark.parametrize("k", range(5, 13))
def test_lircmop5_12_fronts_agree_with_brute_force_over_designs(k):
    """Objective vectors of a grid of (x1, g1, g2), i.e. of real designs: no feasible one
    dominates the front, and those the front does not dominate lie next to it."""
    grid = nondominated(flir.design_grid(k))
    front = pareto_front(f"lircmop{k}", 2, 2000)
    _brute_force_check(front, grid, 0.03)


@pytest.mark.parametrize("k", range(1, 15))
def test_front_is_attained_with_the_fewest_variables(k):
    """The front is the same for every n_var >= MIN_N_VAR: at the minimum too, a real
    design reaches each point and is feasible."""
    from tmopt.problems.fronts import front_designs, front_sample

    n = lir.MIN_N_VAR[k]
    p = PymooBenchmark(f"lircmop{k}", n_var=n)
    sample = front_sample(f"lircmop{k}", p.n_obj, 300)
    out = p.evaluate(front_designs(f"lircmop{k}", n, p.n_obj, 1.0, sample),
                     return_as_dictionary=True)
    np.testing.assert_allclose(out["F"], sample.F, atol=1e-9)
    assert out["G"].max() <= 1e-9


def test_bad_sizes_are_refused_with_the_range():
    with pytest.raises(ValueError, match="lircmop3: n_var must be an integer >= 5, got 4"):
        PymooBenchmark("lircmop3", n_var=4)
    with pytest.raises(ValueError, match=r"must be an integer in 1..14, got 15"):
        LIRCMOP(15)


@pytest.mark.parametrize("k", range(5, 13))
def test_fronts_hold_no_point_outside_the_attainable_region(k):
    # a point 1e-12 left of the smallest attainable f1 (an ellipse's end on the vertical
    # ray) was non-dominated only by that error and stretched LIR-CMOP6's nadir to 3.46
    F = pareto_front(f"lircmop{k}", 2, 2000)
    assert flir.in_region(k, F, tol=0.0).all()
    if k in (5, 6):  # the ellipses leave the unconstrained curve whole (PlatEMO's front)
        np.testing.assert_allclose([F.min(0), F.max(0)], [[0.7057] * 2, [1.7057] * 2])
