"""qLogNEHVI: targets and reference point by hand, Sobol start, BO steps, seeds, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.qlognehvi import QLogNEHVI, reference_nadir
from tmopt.evaluation.evaluator import EvaluatedBatch, Evaluator
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark
from tmopt.run.runner import run_optimisation

from .contract import algorithm_from_yaml, cli_metrics, drive_to_budget, run

#: Small settings so one BO iteration takes a few seconds on two cores.
FAST = dict(q=2, num_restarts=2, raw_samples=32, acq_maxiter=20, mc_samples=16, gp_max_iter=50)


def test_reference_nadir_over_the_feasible_designs_their_front_or_everything():
    Fn = np.array([[0.0, 1.0], [0.2, 0.4], [0.5, 0.5], [1.0, 0.0], [0.9, 0.3]])
    G = np.array([[1.0], [-1.0], [-1.0], [2.0], [-0.5]])
    # the default: every design, feasible or not
    assert np.allclose(reference_nadir(Fn, G), [1.0, 1.0])
    # feasible rows 1, 2, 4: worst of each objective over them
    assert np.allclose(reference_nadir(Fn, G, "feasible"), [0.9, 0.5])
    # their front {(0.2, 0.4), (0.9, 0.3)}: worst over it
    assert np.allclose(reference_nadir(Fn, G, "front"), [0.9, 0.4])
    # every design, feasible or not
    assert np.allclose(reference_nadir(Fn, G, "all"), [1.0, 1.0])
    # nothing feasible: over all rows (front: {(0,1), (0.2,0.4), (1,0), (0.9,0.3)})
    for rule in ("feasible", "front", "all"):
        assert np.allclose(reference_nadir(Fn, np.ones((5, 1)), rule), [1.0, 1.0])
        assert np.allclose(reference_nadir(Fn, np.zeros((5, 0)), rule), [1.0, 1.0])


def test_training_targets_normalise_negate_and_keep_feasibility():
    alg = QLogNEHVI(ref_offset=0.1)
    alg.setup(PymooBenchmark("mw3", n_var=4), budget=100, seed=0)
    alg.F = np.array([[1.0, 30.0], [3.0, 10.0], [2.0, 20.0]])
    alg.G = np.array([[-4.0, 0.5], [2.0, -1.0], [-1.0, -0.25]])
    Y, ref = alg._training_targets()
    assert np.allclose(Y[:, :2], -np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 0.5]]))
    assert np.allclose(Y[:, 2:], [[-1.0, 0.5], [0.5, -1.0], [-0.25, -0.25]])
    assert np.array_equal(Y[:, 2:] <= 0, alg.G <= 0)
    # default rule: ref = -(1 + 0.1) whatever is feasible
    assert np.allclose(ref, [-1.1, -1.1])
    # rule "feasible": only row 2 is feasible, ref = -(its normalised objectives + 0.1)
    alg.ref_point = "feasible"
    assert np.allclose(alg._training_targets()[1], [-0.6, -0.6])


@pytest.mark.filterwarnings("ignore:The balance properties")
def test_initial_sample_is_a_scrambled_sobol_design_of_2_d_plus_1():
    problem = PymooBenchmark("mw3", n_var=4)
    alg = QLogNEHVI()
    assert alg.initial_sample_size(problem) == 10
    alg.setup(problem, budget=100, seed=3)
    X = alg.ask()
    assert X.shape == (10, 4) and np.all((X >= problem.xl) & (X <= problem.xu))
    expected = qmc.Sobol(4, scramble=True, seed=np.random.default_rng(3)).random(10)
    assert np.allclose(X, problem.xl + expected * (problem.xu - problem.xl))


# a 26 s study (CI's 15 min; `make test-slow`): test_cli_run keeps BO iterations by default
@pytest.mark.slow
def test_bo_iterations_propose_q_new_points_and_count_every_evaluation():
    problem = PymooBenchmark("mw3", n_var=4)
    res = run(QLogNEHVI(n_init=8, **FAST), problem, budget=12, seed=1)
    assert len(res.archive) == 12
    assert np.bincount(res.archive.batch).tolist() == [8, 2, 2]
    new = res.archive.X[8:]
    assert np.all((new >= problem.xl) & (new <= problem.xu))
    assert len(np.unique(res.archive.X, axis=0)) == 12
    again = run(QLogNEHVI(n_init=8, **FAST), problem, budget=12, seed=1)
    assert np.array_equal(res.archive.X, again.archive.X)  # same seed, same archive


def test_three_objectives():
    problem = PymooBenchmark("c2dtlz2", n_var=5)
    alg = QLogNEHVI(n_init=8, **FAST)
    alg.setup(problem, budget=10, seed=0)
    ev = Evaluator(problem, 10)
    while ev.remaining:
        alg.tell(ev.evaluate(alg.ask()[: ev.remaining]))
    assert alg.n_evals == 10 and alg.iteration == 2


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem, alg = PymooBenchmark(name), QLogNEHVI(**FAST)
    drive_to_budget(alg, problem, alg.initial_sample_size(problem) + 2)


def test_max_iter_stops_the_run_before_the_budget():
    res = run(QLogNEHVI(n_init=6, max_iter=1, **FAST), PymooBenchmark("mw3", n_var=4),
              budget=50)
    assert len(res.archive) == 6 + 2  # the initial sample and one iteration of q = 2


def test_another_seed_gives_another_run():
    problem = PymooBenchmark("mw3", n_var=4)
    a, b = QLogNEHVI(), QLogNEHVI()
    a.setup(problem, budget=100, seed=1)
    b.setup(problem, budget=100, seed=2)
    assert not np.array_equal(a.ask(), b.ask())


def test_failed_designs_are_left_out_of_the_models():
    problem = PymooBenchmark("mw3", n_var=4)
    alg = QLogNEHVI(n_init=4, **FAST)
    alg.setup(problem, budget=20, seed=0)
    X = alg.ask()
    alg.tell(EvaluatedBatch(X=X, F=np.ones((4, 2)), G=np.ones((4, 2)),
                            failed=np.array([False, True, False, False]),
                            reason=["", "diverged", "", ""]))
    assert len(alg.U) == 3 and np.allclose(alg.U, X[[0, 2, 3]])  # bounds are [0, 1]


@pytest.mark.slow
def test_finds_feasible_designs_far_more_often_than_sobol_sampling():
    problem = PymooBenchmark("mw3", n_var=4)
    res = run(QLogNEHVI(num_restarts=2, raw_samples=64, mc_samples=32, acq_maxiter=50),
              problem, budget=60, seed=0)
    sobol = qmc.Sobol(4, seed=0).random(64)[:60]
    feasible_sobol = np.all(problem.evaluate(sobol, return_as_dictionary=True)["G"] <= 0, 1)
    # measured: seeds 0/1 give 0.40/0.38 feasible with BO, 0.02/0.03 with Sobol points
    assert res.metrics["feasible_ratio"] > 0.2 > 5 * feasible_sobol.mean()


@pytest.mark.slow
def test_seconds_per_iteration_at_300_points_d18():
    """The timing quoted in docs/algorithms-baselines.md (prints; asserts only success)."""
    import time

    from tmopt.problems.base import ExpensiveProblem

    class Synthetic(ExpensiveProblem):
        def __init__(self):
            super().__init__(n_var=18, n_obj=2, n_ieq_constr=4, name="synthetic")

        def _evaluate(self, X, out, *args, **kwargs):
            g = 1.0 + 9.0 * X[:, 1:].mean(axis=1)
            out["F"] = np.column_stack([X[:, 0], g * (1.0 - np.sqrt(X[:, 0] / g))])
            out["G"] = np.column_stack([0.3 * np.sin(6 * X[:, i]) + X[:, i + 4] - 0.9
                                        for i in range(4)])

    problem, alg = Synthetic(), QLogNEHVI()
    alg.setup(problem, budget=310, seed=0)
    ev = Evaluator(problem, 310)
    alg.tell(ev.evaluate(np.random.default_rng(0).random((300, 18))))
    alg.iteration = 1
    start = time.process_time()
    X = alg.ask()
    print(f"CPU {time.process_time() - start:.1f} s, {alg.timing}")
    assert X.shape == (5, 18)


@pytest.mark.parametrize("kwargs, text", [
    ({"q": 0}, "q must be an integer >= 1, got 0"),
    ({"n_init": 1}, "n_init must be an integer >= 2, got 1"),
    ({"raw_samples": 0}, "raw_samples must be an integer >= 1, got 0"),
    ({"eta": 0.0}, r"eta must be a finite number in \(0.0, inf\), got 0.0"),
    ({"kernel": "linear"}, "kernel must be one of rbf, matern52, got 'linear'"),
    ({"threads": 0}, "threads must be an integer >= 1, got 0"),
    ({"max_iter": -1}, "max_iter must be an integer >= 0, got -1"),
    ({"max_baseline": 0}, "max_baseline must be an integer >= 1, got 0"),
    ({"refit_every": 0}, "refit_every must be an integer >= 1, got 0"),
    ({"init_batch_limit": 0}, "init_batch_limit must be an integer >= 1, got 0"),
    ({"prune_samples": 0}, "prune_samples must be an integer >= 1, got 0"),
    ({"refit_guard": 0.0}, r"refit_guard must be a finite number in \(0.0, inf\), got 0.0"),
    ({"acq_ftol": 0.0}, r"acq_ftol must be a finite number in \(0.0, 1.0\], got 0.0"),
    ({"ref_point": "ideal"},
     "ref_point must be one of feasible, front, all, got 'ideal'"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="qlognehvi: " + text):
        QLogNEHVI(**kwargs)


def test_budget_below_the_initial_sample_is_refused():
    with pytest.raises(AlgorithmConfigError, match="qlognehvi: budget=20 .* initial sample "
                                                   "of 32 .* mw3"):
        run(QLogNEHVI(), PymooBenchmark("mw3"), budget=20)  # D = 15: 2 (15 + 1) = 32


def test_all_initial_designs_failing_is_a_clear_error():
    problem = PymooBenchmark("mw3", n_var=4)
    alg = QLogNEHVI(n_init=3)
    alg.setup(problem, budget=20, seed=0)
    X = alg.ask()
    with pytest.raises(AlgorithmConfigError, match="qlognehvi: only 0 of 3 designs"):
        alg.tell(EvaluatedBatch(X=X, F=np.ones((3, 2)), G=np.ones((3, 2)),
                                failed=np.ones(3, bool), reason=["x"] * 3))


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("qlognehvi")


def test_cli_run(tmp_path):
    fast = [f"algorithm.{k}={v}" for k, v in FAST.items()]
    metrics = cli_metrics(tmp_path, "problem=mw3", "problem.n_var=4", "algorithm=qlognehvi",
                          "budget=12", "algorithm.n_init=10", *fast)
    assert metrics["algorithm"] == "qlognehvi" and metrics["n_evals"] == 12


def _go(outdir, budget, seed=2):
    return run_optimisation(PymooBenchmark("mw3", n_var=4), QLogNEHVI(n_init=8, **FAST),
                            budget=budget, seed=seed, outdir=outdir, config_hash="h",
                            resume=True, progress=False, plots=False)


def _count_calls(monkeypatch, owner, name):
    calls = []
    real = getattr(owner, name)
    monkeypatch.setattr(owner, name, lambda *a, **k: calls.append(1) or real(*a, **k))
    return calls


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The uninterrupted run that every resumed one must equal: 8 + 5 iterations of 2."""
    return _go(tmp_path_factory.mktemp("whole"), 18)


def _assert_same_archive(a, b):
    for field in ("X", "F", "G"):
        assert np.array_equal(getattr(a.archive, field), getattr(b.archive, field))


def test_a_resume_takes_archived_designs_and_checkpointed_gps_and_ends_identical(
        tmp_path, monkeypatch, whole):
    import tmopt.algorithms.qlognehvi as module
    from tmopt.surrogates.gp import GPSurrogate

    _go(tmp_path / "killed", 14)  # the same run stopped after 3 iterations ...
    (tmp_path / "killed" / "metrics.json").unlink()  # ... as if killed before its end
    acq = _count_calls(monkeypatch, module, "optimize_acqf")
    fits = _count_calls(monkeypatch, GPSurrogate, "fit")
    restores = _count_calls(monkeypatch, GPSurrogate, "restore")
    resumed = _go(tmp_path / "killed", 18)
    # only the 2 new iterations optimise and fit; iteration 3's GPs come from the checkpoint
    assert resumed.resumed_from == 14 and len(acq) == 2 and len(fits) == 2
    assert len(restores) == 1
    _assert_same_archive(resumed, whole)


def test_a_run_killed_between_its_fit_and_the_evaluations_resumes_identical(
        tmp_path, monkeypatch, whole):
    from tmopt.evaluation.evaluator import Evaluator
    from tmopt.surrogates.gp import GPSurrogate

    real = Evaluator.evaluate
    batches = []

    def killed_at_the_fifth_batch(self, X):
        batches.append(1)
        if len(batches) == 5:  # iteration 4 fitted (and checkpointed), not evaluated
            raise KeyboardInterrupt
        return real(self, X)

    monkeypatch.setattr(Evaluator, "evaluate", killed_at_the_fifth_batch)
    with pytest.raises(KeyboardInterrupt):
        _go(tmp_path / "killed", 18)
    monkeypatch.setattr(Evaluator, "evaluate", real)
    fits = _count_calls(monkeypatch, GPSurrogate, "fit")
    resumed = _go(tmp_path / "killed", 18)
    assert resumed.resumed_from == 14 and len(fits) == 1  # iteration 5 only
    _assert_same_archive(resumed, whole)


@pytest.mark.parametrize("damage", ["another seed", "garbage"])
def test_a_checkpoint_of_another_run_or_damaged_is_ignored_and_refitted(
        tmp_path, monkeypatch, caplog, whole, damage):
    from tmopt.algorithms.base import CHECKPOINT_FILE
    from tmopt.surrogates.gp import GPSurrogate

    _go(tmp_path / "killed", 14)
    (tmp_path / "killed" / "metrics.json").unlink()
    state = tmp_path / "killed" / CHECKPOINT_FILE
    if damage == "garbage":
        state.write_bytes(b"not a checkpoint")
    else:
        _go(tmp_path / "other", 10, seed=3)
        state.write_bytes((tmp_path / "other" / CHECKPOINT_FILE).read_bytes())
    fits = _count_calls(monkeypatch, GPSurrogate, "fit")
    resumed = _go(tmp_path / "killed", 18)
    assert len(fits) == 5  # 3 replayed iterations refitted, then 2 new ones
    assert "ignoring" in caplog.text and str(state) in caplog.text
    _assert_same_archive(resumed, whole)


def test_max_baseline_caps_the_designs_the_acquisition_integrates_over(monkeypatch):
    import tmopt.algorithms.qlognehvi as module

    seen = []
    real = module.qLogNoisyExpectedHypervolumeImprovement

    def spy(**kwargs):
        acq = real(**kwargs)
        seen.append((kwargs["prune_baseline"], len(kwargs["X_baseline"]),
                     len(acq.X_baseline)))
        return acq

    monkeypatch.setattr(module, "qLogNoisyExpectedHypervolumeImprovement", spy)
    problem = PymooBenchmark("mw3", n_var=4)
    run(QLogNEHVI(n_init=10, max_baseline=3, **FAST), problem, budget=14, seed=1)
    # 10 and 12 designs observed: pruned by BoTorch to those with a positive probability
    # of being Pareto optimal, at most the 3 most probable; the cap binds at least once
    assert len(seen) == 2 and all(not p and n <= 3 for p, n, _ in seen)
    assert max(n for _, n, _ in seen) == 3
    seen.clear()
    run(QLogNEHVI(n_init=10, max_baseline=50, prune_samples=None, **FAST), problem,
        budget=12, seed=1)
    assert [(p, n) for p, n, _ in seen] == [(True, 10)]  # below the cap: BoTorch's pruning
    seen.clear()
    run(QLogNEHVI(n_init=10, **FAST), problem, budget=12, seed=1)  # prune_samples=512
    assert len(seen) == 1 and not seen[0][0] and seen[0][1] <= 10  # pruned here


def test_max_baseline_left_at_null_keeps_the_hash_of_configs_without_it():
    from omegaconf import OmegaConf

    from tmopt.run.config import config_hash

    base = {"seed": 0, "budget": 697, "problem": {"_target_": "x.Problem"},
            "algorithm": {"_target_": "tmopt.algorithms.qlognehvi.QLogNEHVI", "q": 5}}
    old = config_hash(OmegaConf.create(base))
    at_null = {**base, "algorithm": {**base["algorithm"], "max_baseline": None}}
    capped = {**base, "algorithm": {**base["algorithm"], "max_baseline": 64}}
    assert config_hash(OmegaConf.create(at_null)) == old  # earlier archives still resume
    assert config_hash(OmegaConf.create(capped)) != old
    other = {**base, "algorithm": {"_target_": "x.Other", "max_baseline": None}}
    assert config_hash(OmegaConf.create(other)) != config_hash(OmegaConf.create(
        {**base, "algorithm": {"_target_": "x.Other"}}))  # only the listed algorithm


def test_the_reference_yaml_pins_the_earlier_settings_and_keeps_their_config_hash():
    """algorithm=qlognehvi_reference: the settings before docs/speed.md; its config hash
    equals that of the same node without the arguments added since (earlier runs)."""
    from omegaconf import OmegaConf

    from tmopt.run.cli import option_config
    from tmopt.run.config import config_hash

    node = OmegaConf.to_container(option_config("algorithm", "qlognehvi_reference"))
    alg = QLogNEHVI(**{k: v for k, v in node.items() if not k.startswith("_")})
    assert (alg.cached_posterior, alg.init_batch_limit, alg.refit_every, alg.refit_guard,
            alg.prune_samples, alg.gp_guard_max_iter) == (False, None, 1, None, None, None)
    assert (alg.raw_samples, alg.acq_maxiter, alg.gp_max_iter) == (128, 100, 200)
    added = ("cached_posterior", "init_batch_limit", "refit_every", "refit_guard",
             "prune_samples", "max_baseline", "gp_guard_max_iter", "sequential", "acq_ftol")
    earlier = {k: v for k, v in node.items() if k not in added}
    # the default surrogate group (unused by qLogNEHVI) as earlier runs had it
    gp = OmegaConf.to_container(option_config("surrogate", "gp"))
    gp_before = {**{k: v for k, v in gp.items() if k != "refit_guard"}, "refit_every": 1}
    run = {"seed": 0, "budget": 300, "problem": {"_target_": "x.Problem"}}
    assert config_hash(OmegaConf.create({**run, "algorithm": node, "surrogate": gp})) \
        == config_hash(OmegaConf.create({**run, "algorithm": earlier, "surrogate": gp_before}))
    assert config_hash(OmegaConf.create({**run, "algorithm": node})) \
        == config_hash(OmegaConf.create({**run, "algorithm": earlier}))
    ipc = {"_target_": "tmopt.algorithms.mgsaea.MGSAEAIPC"}  # uses the GP: numbers change
    assert config_hash(OmegaConf.create({**run, "algorithm": ipc, "surrogate": gp})) \
        != config_hash(OmegaConf.create({**run, "algorithm": ipc, "surrogate": gp_before}))
    default = OmegaConf.to_container(option_config("algorithm", "qlognehvi"))
    assert config_hash(OmegaConf.create({**run, "algorithm": default})) \
        != config_hash(OmegaConf.create({**run, "algorithm": earlier}))


def test_runs_before_gp_guard_max_iter_keep_their_hash_with_it_at_null():
    """gp_guard_max_iter's default became 5 (docs/speed.md): runs made before the
    argument existed (no key) and runs made while its default was null (null named) hash
    alike, as what they ran with (null), and unlike the new default's runs; collect reads
    their missing key as null."""
    from omegaconf import OmegaConf

    from tmopt.run.cli import option_config
    from tmopt.run.config import config_hash, earlier_value

    default = OmegaConf.to_container(option_config("algorithm", "qlognehvi"))
    assert default["gp_guard_max_iter"] == 5 == QLogNEHVI().gp_guard_max_iter
    before = {k: v for k, v in default.items() if k != "gp_guard_max_iter"}
    run = {"seed": 0, "budget": 697, "problem": {"_target_": "x.Problem"}}
    old = config_hash(OmegaConf.create({**run, "algorithm": before}))
    at_null = {**default, "gp_guard_max_iter": None}
    assert config_hash(OmegaConf.create({**run, "algorithm": at_null})) == old
    assert config_hash(OmegaConf.create({**run, "algorithm": default})) != old
    assert config_hash(OmegaConf.create(
        {**run, "algorithm": {**default, "gp_guard_max_iter": 10}})) != old
    assert earlier_value("algorithm", before, "gp_guard_max_iter") is None
    # the GP surrogate's own guard_max_iter (null by default) leaves every run's hash alone
    gp = OmegaConf.to_container(option_config("surrogate", "gp"))
    assert "guard_max_iter" in gp and gp["guard_max_iter"] is None
    without = {k: v for k, v in gp.items() if k != "guard_max_iter"}
    assert config_hash(OmegaConf.create({**run, "algorithm": before, "surrogate": gp})) \
        == config_hash(OmegaConf.create({**run, "algorithm": before, "surrogate": without}))


def test_gp_guard_max_iter_reaches_the_gp_and_is_checked():
    alg = QLogNEHVI(gp_guard_max_iter=7, **FAST)
    alg.setup(PymooBenchmark("mw3", n_var=4), budget=20, seed=0)
    assert alg.gp.guard_max_iter == 7 and alg.gp.max_iter == alg.gp_max_iter
    with pytest.raises(AlgorithmConfigError, match="gp_guard_max_iter"):
        QLogNEHVI(gp_guard_max_iter=0)


def test_refit_every_keeps_the_gps_between_optimisations_and_checkpoints_them(tmp_path):
    """Default settings: kept GPs between re-fits, and every fit (kept or not) is what
    the checkpoint holds, so a resume can restore it."""
    import torch

    from tmopt.algorithms.base import CHECKPOINT_FILE

    alg = QLogNEHVI(n_init=8, refit_every=3, refit_guard=None, **FAST)
    stages = []
    problem = PymooBenchmark("mw3", n_var=4)
    alg.setup(problem, budget=18, seed=0)
    alg.attach_checkpoint(tmp_path / CHECKPOINT_FILE)
    ev = Evaluator(problem, 18)
    while ev.remaining:
        alg.tell(ev.evaluate(alg.ask()[: ev.remaining]))
        if alg.iteration > 1:
            stages.append(alg.gp.fit_info["stage"])
            saved = torch.load(tmp_path / CHECKPOINT_FILE, weights_only=False)["payload"]
            assert saved["iteration"] == alg.iteration - 1
            assert saved["gp"]["fit_info"]["stage"] == stages[-1]
    assert stages == ["mll", "kept_hypers", "kept_hypers", "mll", "kept_hypers"]


def _acquisition_calls(monkeypatch, **kwargs) -> tuple[list[tuple[int, ...]], dict]:
    """Shapes of every qLogNEHVI evaluation of one BO iteration (MW3, D = 4, n_init 8)
    and the options ``optimize_acqf`` got."""
    import tmopt.algorithms.qlognehvi as module

    shapes, seen = [], {}
    real = module.optimize_acqf

    def spy(acq, **kw):
        forward = acq.forward

        def counting(X):
            shapes.append(tuple(X.shape))
            return forward(X)

        acq.forward = counting
        seen.update(kw)
        return real(acq, **kw)

    monkeypatch.setattr(module, "optimize_acqf", spy)
    run(QLogNEHVI(n_init=8, **{**FAST, **kwargs}), PymooBenchmark("mw3", n_var=4),
        budget=10, seed=2)
    return shapes, seen


def test_acq_ftol_stops_the_acquisitions_lbfgsb_early(monkeypatch):
    """acq_ftol: L-BFGS-B stops once the log-acquisition improves by less than that
    fraction, so a loose tolerance takes fewer gradient evaluations than the default,
    which runs (nearly) all acq_maxiter iterations."""
    full, seen = _acquisition_calls(monkeypatch, acq_maxiter=40)
    assert "ftol" not in seen["options"]
    early, seen = _acquisition_calls(monkeypatch, acq_maxiter=40, acq_ftol=0.05)
    assert seen["options"]["ftol"] == 0.05
    lbfgsb = [s for s in early if s[0] == FAST["num_restarts"]]  # not the raw samples
    assert len(lbfgsb) < len([s for s in full if s[0] == FAST["num_restarts"]])


def test_sequential_false_optimises_the_whole_batch_jointly(monkeypatch):
    """sequential=True (default): each design alone (q = 1 per evaluation, the earlier
    ones pending); False: L-BFGS-B over all q designs at once."""
    q = FAST["q"]
    shapes, seen = _acquisition_calls(monkeypatch)
    assert seen["sequential"] is True and {s[-2] for s in shapes} == {1}
    shapes, seen = _acquisition_calls(monkeypatch, sequential=False)
    assert seen["sequential"] is False and {s[-2] for s in shapes} == {q}


def test_sequential_and_acq_ftol_at_their_defaults_keep_the_hash_of_runs_before_them():
    from omegaconf import OmegaConf

    from tmopt.run.cli import option_config
    from tmopt.run.config import config_hash

    default = OmegaConf.to_container(option_config("algorithm", "qlognehvi"))
    assert default["sequential"] is True and default["acq_ftol"] is None
    before = {k: v for k, v in default.items() if k not in ("sequential", "acq_ftol")}
    run = {"seed": 0, "budget": 300, "problem": {"_target_": "x.Problem"}}
    old = config_hash(OmegaConf.create({**run, "algorithm": before}))
    assert config_hash(OmegaConf.create({**run, "algorithm": default})) == old
    for change in ({"sequential": False}, {"acq_ftol": 1e-4}):
        assert config_hash(OmegaConf.create(
            {**run, "algorithm": {**default, **change}})) != old
