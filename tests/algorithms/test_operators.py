"""Shared selection parts against hand-worked cases (SPEA2, CDP, mc, Eq. 21, granularity)."""

from __future__ import annotations

import numpy as np
import pytest

from tmopt.algorithms.operators.constraints import cdp_sort, choose_granularity, dominance_matrix
from tmopt.algorithms.operators.stage import change_rate
from tmopt.algorithms.operators.survival import environmental_selection, spea2_fitness, truncation
from tmopt.algorithms.operators.variation import tournament, unique_rows
from tmopt.metrics.indicators import constraint_violation
from tmopt.metrics.selection import best_compromise

# Four points: 0 and 1 non-dominated, 2 dominated by both, 3 dominated by all.
F4 = np.array([[1.0, 2.0], [2.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
R2, R5 = np.sqrt(2.0), np.sqrt(5.0)


def test_pareto_dominance_matrix():
    expected = np.array([[0, 0, 1, 1],
                         [0, 0, 1, 1],
                         [0, 0, 0, 1],
                         [0, 0, 0, 0]], dtype=bool)
    assert np.array_equal(dominance_matrix(F4), expected)


def test_constrained_dominance_prefers_lower_violation_then_pareto():
    # point 0 is infeasible: every feasible point dominates it, whatever its objectives
    expected = np.array([[0, 0, 0, 0],
                         [1, 0, 1, 1],
                         [1, 0, 0, 1],
                         [1, 0, 0, 0]], dtype=bool)
    assert np.array_equal(dominance_matrix(F4, cv=[0.5, 0, 0, 0]), expected)
    # two infeasible points: the smaller violation wins even with worse objectives
    dom = dominance_matrix(np.array([[0.0, 0.0], [5.0, 5.0]]), cv=[2.0, 1.0])
    assert dom[1, 0] and not dom[0, 1]


def test_spea2_fitness_hand_worked():
    # S = [2, 2, 1, 0]; R = [0, 0, S0+S1, S0+S1+S2] = [0, 0, 4, 5]; k = floor(sqrt(4)) = 2,
    # second-nearest distances: sqrt2, sqrt2, 1, sqrt5; D = 1 / (sigma + 2)
    expected = np.array([1 / (R2 + 2), 1 / (R2 + 2), 4 + 1 / 3, 5 + 1 / (R5 + 2)])
    assert np.allclose(spea2_fitness(F4, normalise=False), expected)
    assert np.all(spea2_fitness(F4, normalise=False)[:2] < 1.0)  # non-dominated: F < 1


def test_spea2_fitness_with_constraints_hand_worked():
    # CDP dominance (see above): S = [0, 3, 2, 1]; R = [S1+S2+S3, 0, S1, S1+S2] = [6, 0, 3, 5]
    expected = np.array([6 + 1 / (R2 + 2), 1 / (R2 + 2), 3 + 1 / 3, 5 + 1 / (R5 + 2)])
    assert np.allclose(spea2_fitness(F4, cv=[0.5, 0, 0, 0], normalise=False), expected)


def test_normalised_density_is_invariant_to_objective_scale():
    rng = np.random.default_rng(3)
    F = rng.random((30, 2))
    scaled = F * np.array([100.0, 1e-10])  # seconds vs s^-2, as in the stiffness problem
    assert np.allclose(spea2_fitness(F), spea2_fitness(scaled))
    assert not np.allclose(spea2_fitness(F, normalise=False),
                           spea2_fitness(scaled, normalise=False))


def test_truncation_removes_the_more_crowded_of_the_closest_pair():
    # 1 and 2 are the closest pair (0.141); the next neighbour of 1 (0 at 1.414) is closer
    # than that of 2 (0 at 1.556), so 1 goes first
    F = np.array([[0.0, 3.0], [1.0, 2.0], [1.1, 1.9], [3.0, 0.0]])
    assert np.flatnonzero(truncation(F, 1, normalise=False)).tolist() == [1]
    assert truncation(F, 0).sum() == 0


def _naive_truncation(F: np.ndarray, k: int) -> np.ndarray:
    """SPEA2 truncation as written in the paper: sort all distance rows every step."""
    dist = np.linalg.norm(F[:, None] - F[None], axis=2)
    np.fill_diagonal(dist, np.inf)
    deleted = np.zeros(len(F), dtype=bool)
    while deleted.sum() < k:
        remain = np.flatnonzero(~deleted)
        rows = np.sort(dist[np.ix_(remain, remain)], axis=1)
        order = sorted(range(len(remain)), key=lambda i: tuple(rows[i]))
        deleted[remain[order[0]]] = True
    return deleted


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fast_truncation_equals_the_naive_definition(seed):
    F = np.random.default_rng(seed).random((40, 3))
    assert np.array_equal(truncation(F, 25, normalise=False), _naive_truncation(F, 25))


def test_environmental_selection_fills_by_fitness_or_truncates():
    fit = spea2_fitness(F4, normalise=False)
    # two non-dominated < 3 wanted: fill with the best dominated one (index 2)
    assert environmental_selection(fit, F4, 3, normalise=False).tolist() == [0, 1, 2]
    # more non-dominated than wanted: truncation keeps the spread ones
    F = np.array([[0.0, 3.0], [1.0, 2.0], [1.1, 1.9], [3.0, 0.0]])
    fit = spea2_fitness(F, normalise=False)
    assert environmental_selection(fit, F, 3, normalise=False).tolist() == [0, 2, 3]
    assert environmental_selection(fit, F, 10).tolist() == [0, 1, 2, 3]


def test_cdp_sort_puts_feasible_fronts_first_then_violation_order():
    F = np.array([[1.0, 2.0], [2.0, 1.0], [2.0, 2.0], [0.0, 0.0], [0.0, 0.0], [9.0, 9.0]])
    cv = np.array([0.0, 0.0, 0.0, 0.3, 0.1, 0.1])
    assert cdp_sort(F, cv).tolist() == [0, 0, 1, 3, 2, 2]


def test_change_rate_eq20_hand_worked():
    # |0.9 - 1.0| / 1.0 = 0.1 and |-2 - (-1)| / max(|-1|, sigma) = 1.0 -> mc = 1.0
    assert change_rate([0.9, -2.0], [1.0, -1.0], sigma=1e-3) == pytest.approx(1.0)
    # a zero ideal component: the denominator is sigma
    assert change_rate([1e-4], [0.0], sigma=1e-3) == pytest.approx(0.1)
    # negative ideal values use |z| (PlatEMO's max(z, delta) would divide by delta)
    assert change_rate([-1.001], [-1.0], sigma=1e-3) == pytest.approx(1e-3)
    with pytest.raises(ValueError, match="sigma"):
        change_rate([1.0], [1.0], sigma=0.0)
    with pytest.raises(ValueError, match="same length"):
        change_rate([1.0, 2.0], [1.0], sigma=1e-3)


def test_granularity_follows_constraint_satisfaction_of_the_population():
    # every constraint violated by someone -> coarse
    G = np.array([[0.5, -1.0], [-1.0, 0.2]])
    name, idx = choose_granularity(G)
    assert name == "coarse" and idx.tolist() == [0, 1]
    # constraint 1 satisfied by everyone -> fine, model only constraint 0
    name, idx = choose_granularity(np.array([[0.5, -1.0], [-1.0, -0.2]]))
    assert name == "fine" and idx.tolist() == [0]
    # all satisfied (g = 0 counts as satisfied) -> objectives only
    name, idx = choose_granularity(np.array([[0.0, -1.0], [-1.0, -0.2]]))
    assert name == "objectives" and idx.size == 0
    assert choose_granularity(np.zeros((3, 0)))[0] == "objectives"


def test_eq21_best_compromise_hand_worked():
    # minima (1, 1): normalised points (0, 3), (1, 1), (3, 0): the middle one is nearest
    assert best_compromise(np.array([[1.0, 4.0], [2.0, 2.0], [4.0, 1.0]])) == 1


def test_tournament_returns_the_better_of_each_random_pair():
    fit = np.array([3.0, 1.0, 2.0, 0.5, 4.0])
    cand = np.random.default_rng(7).integers(0, 5, size=(200, 2))
    expected = cand[np.arange(200), np.argmin(fit[cand], axis=1)]
    assert np.array_equal(tournament(fit, 200, np.random.default_rng(7)), expected)
    # ties go to the lower index, as PlatEMO's TournamentSelection
    won = tournament(np.zeros(2), 100, np.random.default_rng(0))
    cand = np.random.default_rng(0).integers(0, 2, size=(100, 2))
    assert np.array_equal(won, cand.min(axis=1))


def test_constraint_violation_and_unique_rows():
    assert constraint_violation(np.array([[0.5, -1.0], [-2.0, -1.0]])).tolist() == [0.5, 0.0]
    assert constraint_violation(np.zeros((2, 0))).tolist() == [0.0, 0.0]
    assert unique_rows(np.array([[2.0], [1.0], [2.0], [0.0]])).tolist() == [0, 1, 3]


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="NaN"):
        spea2_fitness(np.array([[np.nan, 1.0]]))
    with pytest.raises(ValueError, match="one value per solution"):
        dominance_matrix(F4, cv=[0.0])
    with pytest.raises(ValueError, match="n_remove"):
        truncation(F4, 5)


def test_ga_offspring_two_children_per_pair_within_bounds_and_reproducible():
    from tmopt.algorithms.operators.variation import ga_offspring

    rng = np.random.default_rng(0)
    X = rng.random((10, 6))
    xl, xu = np.zeros(6), np.ones(6)
    mates = np.array([[0, 1], [2, 3], [4, 5]])
    a = ga_offspring(X, mates, xl, xu, np.random.default_rng(1), crossover_eta=20.0,
                     mutation_eta=20.0)
    b = ga_offspring(X, mates, xl, xu, np.random.default_rng(1), crossover_eta=20.0,
                     mutation_eta=20.0)
    assert a.shape == (6, 6) and np.array_equal(a, b)
    assert np.all((a >= xl) & (a <= xu))
    # identical parents are not crossed (SBX) and mutation changes ~1/n_var of the variables
    same = ga_offspring(np.tile(X[:1], (2, 1)), np.array([[0, 1]] * 200), xl, xu,
                        np.random.default_rng(2), crossover_eta=20.0, mutation_eta=20.0)
    changed = np.mean(same != X[0])
    assert 0.05 < changed < 0.35
