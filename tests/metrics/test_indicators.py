"""IGD, IGD+, HV, feasibility, final set and the Eq. 21 choice on hand-worked cases."""

import numpy as np
import pytest

from tmopt.metrics import (
    best_compromise,
    constraint_violation,
    feasible_ratio,
    hypervolume,
    igd,
    igd_plus,
    non_dominated_feasible,
)

PF = np.array([[0.0, 1.0], [1.0, 0.0]])


def test_igd_hand_worked():
    # distances from the two front points to the single solution (0, 1): 0 and sqrt(2)
    assert igd([[0.0, 1.0]], PF) == pytest.approx(np.sqrt(2) / 2)
    assert igd(PF, PF) == 0.0


def test_igd_plus_counts_only_the_inferior_part():
    # IGD+ distance from z=(1,0) to a=(0,1) is sqrt(max(0-1,0)^2 + max(1-0,0)^2) = 1
    assert igd_plus([[0.0, 1.0]], PF) == pytest.approx(0.5)
    # a solution dominating the front has IGD+ 0 but IGD > 0
    assert igd_plus([[-1.0, -1.0]], PF) == 0.0
    assert igd([[-1.0, -1.0]], PF) > 0.0


def test_igd_of_empty_set_is_nan_and_shapes_are_checked():
    assert np.isnan(igd(np.zeros((0, 2)), PF))
    with pytest.raises(ValueError, match="2-D"):
        igd([1.0, 2.0], PF)


def test_hypervolume_hand_worked():
    # boxes [1,3]x[2,3] and [2,3]x[1,3], overlap [2,3]x[2,3]: 2 + 2 - 1 = 3
    F = np.array([[1.0, 2.0], [2.0, 1.0]])
    assert hypervolume(F, [3.0, 3.0]) == pytest.approx(3.0)
    # a point beyond the reference point adds nothing
    assert hypervolume(np.vstack([F, [[4.0, 0.0]]]), [3.0, 3.0]) == pytest.approx(3.0)
    assert hypervolume(np.array([[5.0, 5.0]]), [3.0, 3.0]) == 0.0


def test_hypervolume_normalised():
    # ideal (0,0), nadir (2,2): (1,1) -> (0.5,0.5); box to (1,1) has area 0.25
    assert hypervolume([[1.0, 1.0]], [1.0, 1.0], ideal=[0, 0], nadir=[2, 2]) == \
        pytest.approx(0.25)
    with pytest.raises(ValueError, match="ref_point"):
        hypervolume([[1.0, 1.0]], [1.0, 1.0, 1.0])


def test_feasible_ratio_and_violation():
    G = np.array([[-1.0, 0.0], [1.0, -1.0], [0.0, 0.0]])
    assert feasible_ratio(G) == pytest.approx(2 / 3)
    assert constraint_violation(G).tolist() == [0.0, 1.0, 0.0]
    assert feasible_ratio(np.zeros((4, 0))) == 1.0
    assert np.isnan(feasible_ratio(np.zeros((0, 2))))


def test_non_dominated_feasible_skips_infeasible_failed_and_duplicates():
    F = np.array([[1.0, 1.0], [0.0, 0.0], [2.0, 0.5], [1.0, 1.0], [0.5, 3.0], [3.0, 3.0]])
    G = np.array([[0.0], [1.0], [-1.0], [-1.0], [-1.0], [-1.0]])
    failed = np.array([False, False, False, False, True, False])
    # row 1 dominates all but is infeasible; row 4 failed; row 3 duplicates row 0
    assert non_dominated_feasible(F, G, failed).tolist() == [0, 2]
    assert non_dominated_feasible(F, np.ones((6, 1))).size == 0


def test_best_compromise_eq21_hand_worked():
    # f_min = (1, 4): distances 1.5, sqrt(1 + 1/16), 3 -> row 1
    F = np.array([[1.0, 10.0], [2.0, 5.0], [4.0, 4.0]])
    assert best_compromise(F) == 1


def test_best_compromise_non_positive_minimum_uses_range():
    # objective 1 has minimum 0: normalised by its range 4 -> distances 1.25, ~0.56, 1.0
    F = np.array([[0.0, 2.0], [1.0, 1.5], [4.0, 1.0]])
    assert best_compromise(F) == 1
    with pytest.raises(ValueError, match="non-empty"):
        best_compromise(np.zeros((0, 2)))
