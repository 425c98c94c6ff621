"""The evaluator: budget, failure isolation, archiving as it goes, resume by replay."""

import logging

import numpy as np
import pytest

from tmopt.evaluation.archive import ArchiveError, EvaluationArchive, read_archive
from tmopt.evaluation.evaluator import FAILED_CONSTRAINT_VIOLATION, BudgetExhausted, Evaluator
from tmopt.problems.base import ExpensiveProblem


class Toy(ExpensiveProblem):
    """f = (x0, 1 - x0 + sum x_rest^2), g = 0.5 - x0 - x1; raises for x0 > 0.9 and
    returns NaN for x0 < 0.1, so tests can place failures where they want them."""

    def __init__(self):
        super().__init__(n_var=3, n_obj=2, n_ieq_constr=1, name="toy")
        self.calls = 0
        self.designs_seen = 0

    def _evaluate(self, X, out, *args, **kwargs):
        self.calls += 1
        self.designs_seen += len(X)
        if np.any(X[:, 0] > 0.9):
            raise RuntimeError("solver diverged")
        f1 = 1 - X[:, 0] + np.sum(X[:, 1:] ** 2, axis=1)
        F = np.column_stack([X[:, 0], f1])
        F[X[:, 0] < 0.1, 1] = np.nan
        out["F"] = F
        out["G"] = (0.5 - X[:, 0] - X[:, 1])[:, None]


def _designs(x0):
    x0 = np.asarray(x0, dtype=float)
    return np.column_stack([x0, np.full(len(x0), 0.3), np.full(len(x0), 0.2)])


def test_budget_is_counted_and_enforced():
    ev = Evaluator(Toy(), budget=5)
    ev.evaluate(_designs([0.5, 0.6, 0.7]))
    assert (ev.n_evals, ev.remaining) == (3, 2)
    with pytest.raises(BudgetExhausted, match="toy: 3 evaluations asked, only 2"):
        ev.evaluate(_designs([0.5, 0.6, 0.7]))
    ev.evaluate(_designs([0.5, 0.6]))
    with pytest.raises(BudgetExhausted):
        ev.evaluate(_designs([0.5]))


@pytest.mark.parametrize("budget", [0, -3, 2.5, True, "10"])
def test_invalid_budget_is_refused(budget):
    with pytest.raises(ValueError, match="budget"):
        Evaluator(Toy(), budget=budget)


def test_wrong_design_shapes_are_refused_naming_the_problem():
    ev = Evaluator(Toy(), budget=10)
    with pytest.raises(ValueError, match=r"toy: designs must have shape \(n >= 1, 3\)"):
        ev.evaluate(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="toy"):
        ev.evaluate(np.zeros(3))
    with pytest.raises(ValueError, match="NaN or inf"):
        ev.evaluate(np.array([[np.nan, 0.0, 0.0]]))
    assert ev.n_evals == 0


def test_one_raising_design_fails_alone(caplog):
    problem = Toy()
    ev = Evaluator(problem, budget=10)
    with caplog.at_level(logging.WARNING):
        batch = ev.evaluate(_designs([0.5, 0.95, 0.6]))
    assert batch.failed.tolist() == [False, True, False]
    assert "RuntimeError: solver diverged" in batch.reason[1]
    assert batch.reason[0] == batch.reason[2] == ""
    # the good designs keep their true values
    np.testing.assert_allclose(batch.F[[0, 2], 0], [0.5, 0.6])
    # the failed one is infeasible with a finite penalty
    assert batch.G[1, 0] == FAILED_CONSTRAINT_VIOLATION and np.all(np.isfinite(batch.F))
    assert "design 1 failed" in caplog.text and "toy" in caplog.text
    assert problem.calls == 1 + 3  # the batch, then one design at a time


def test_nan_objective_marks_design_failed_logs_and_run_continues(caplog):
    ev = Evaluator(Toy(), budget=10)
    with caplog.at_level(logging.WARNING):
        batch = ev.evaluate(_designs([0.05, 0.5]))
    assert batch.failed.tolist() == [True, False]
    assert batch.reason[0] == "non-finite objective or constraint value"
    assert "toy" in caplog.text and "non-finite" in caplog.text
    assert np.all(np.isfinite(batch.F)) and batch.G[0, 0] == FAILED_CONSTRAINT_VIOLATION
    # the penalty ranks the failed design below every good one in each objective
    assert np.all(batch.F[0] > batch.F[1])
    # the raw archive keeps NaN for the failed design and the run goes on
    assert np.isnan(ev.archive.data.F[0]).all()
    later = ev.evaluate(_designs([0.4]))
    assert not later.failed.any() and ev.n_evals == 3


def test_each_batch_is_on_disk_before_it_is_returned(tmp_path):
    path = tmp_path / "archive.h5"
    problem = Toy()
    ev = Evaluator(problem, 10, EvaluationArchive(path, 3, 2, 1), seed=4)
    ev.evaluate(_designs([0.2, 0.3]))
    assert len(read_archive(path)) == 2
    ev.evaluate(_designs([0.95]))
    data = read_archive(path)
    assert len(data) == 3 and data.failed.tolist() == [False, False, True]
    assert data.batch.tolist() == [0, 0, 1] and data.seed.tolist() == [4, 4, 4]
    assert np.all(data.wall_time >= 0)


def _interrupted_run(path):
    ev = Evaluator(Toy(), 10, EvaluationArchive(path, 3, 2, 1))
    first = ev.evaluate(_designs([0.2, 0.3]))
    second = ev.evaluate(_designs([0.95, 0.4]))
    return first, second


def test_replay_answers_from_the_archive_without_calling_the_problem(tmp_path):
    path = tmp_path / "archive.h5"
    first, second = _interrupted_run(path)
    problem = Toy()
    ev = Evaluator(problem, 10, EvaluationArchive(tmp_path / "resumed.h5", 3, 2, 1),
                   replay=read_archive(path))
    assert ev.n_replayed_left == 4
    again1, again2 = ev.evaluate(_designs([0.2, 0.3])), ev.evaluate(_designs([0.95, 0.4]))
    assert problem.calls == 0
    np.testing.assert_array_equal(again1.F, first.F)
    np.testing.assert_array_equal(again2.F, second.F)
    assert again2.failed.tolist() == [True, False]
    # past the archive the problem is evaluated for real
    ev.evaluate(_designs([0.6]))
    assert problem.designs_seen == 1 and ev.n_evals == 5


def test_replay_with_different_designs_is_an_error(tmp_path):
    path = tmp_path / "archive.h5"
    _interrupted_run(path)
    ev = Evaluator(Toy(), 10, replay=read_archive(path))
    with pytest.raises(ArchiveError, match="differ from the archived ones"):
        ev.evaluate(_designs([0.2, 0.31]))


def test_replay_mid_batch_and_oversized_archives_are_errors(tmp_path):
    path = tmp_path / "archive.h5"
    _interrupted_run(path)
    ev = Evaluator(Toy(), 10, replay=read_archive(path))
    ev.evaluate(_designs([0.2, 0.3]))
    with pytest.raises(ArchiveError, match="mid-batch"):
        ev.evaluate(_designs([0.95, 0.4, 0.5]))
    with pytest.raises(ArchiveError, match="more than budget=3"):
        Evaluator(Toy(), 3, replay=read_archive(path))


def test_a_resume_killed_while_replaying_leaves_the_whole_archive_on_disk(tmp_path):
    path = tmp_path / "archive.h5"
    _interrupted_run(path)  # 4 evaluations on disk
    ev = Evaluator(Toy(), 10, EvaluationArchive(path, 3, 2, 1), replay=read_archive(path))
    ev.evaluate(_designs([0.2, 0.3]))  # replayed; a kill here must not shrink the file
    assert len(read_archive(path)) == 4
    ev.evaluate(_designs([0.95, 0.4]))
    ev.evaluate(_designs([0.6]))  # the first real batch writes replayed + new rows
    data = read_archive(path)
    assert len(data) == 5 and np.array_equal(data.X[4:], _designs([0.6]))


class Noisy(Toy):
    """Reports the context the evaluator gives (rows, run seed) as its 'noise seeds'."""

    def __init__(self):
        super().__init__()
        self.requires_kwargs = True
        self.seeds_per_evaluation = 2

    def _evaluate(self, X, out, *args, rows=None, run_seed=0, **kwargs):
        super()._evaluate(X, out)
        out["noise_seeds"] = np.column_stack([rows, np.full(len(X), 100 + run_seed)])


def test_the_problem_learns_its_rows_and_run_seed_and_the_archive_its_noise_seeds(tmp_path):
    path = tmp_path / "archive.h5"
    ev = Evaluator(Noisy(), 10, EvaluationArchive(path, 3, 2, 1), seed=7)
    ev.evaluate(_designs([0.2, 0.3]))
    ev.evaluate(_designs([0.95, 0.4, 0.5]))  # raises as a batch: evaluated one by one
    data = read_archive(path)
    assert data.noise_seeds.tolist() == [[0, 107], [1, 107], [-1, -1], [3, 107], [4, 107]]
    # resumed by replay: the archived seeds come back with the rows
    again = Evaluator(Noisy(), 10, replay=data, seed=7)
    again.evaluate(_designs([0.2, 0.3]))
    again.evaluate(_designs([0.95, 0.4, 0.5]))
    assert again.archive.data.noise_seeds.tolist() == data.noise_seeds.tolist()
    # a problem without noise records none
    plain = Evaluator(Toy(), 10)
    plain.evaluate(_designs([0.2]))
    assert plain.archive.data.noise_seeds.shape == (1, 0)


def test_the_isolated_worker_passes_the_context_too():
    ev = Evaluator(Noisy(), 10, seed=3, time_limit=120.0)
    try:
        ev.evaluate(_designs([0.2, 0.3]))
    finally:
        ev.close()
    assert ev.archive.data.noise_seeds.tolist() == [[0, 103], [1, 103]]
