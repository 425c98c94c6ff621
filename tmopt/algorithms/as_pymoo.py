"""Every tmopt algorithm as a pymoo algorithm: ``minimize(problem, MGSAEAIPC(), ...)``.

pymoo's :func:`~pymoo.optimize.minimize` copies the algorithm, calls
``algorithm.setup(problem, termination=..., seed=..., **kwargs)`` and returns
``algorithm.run()``. :meth:`tmopt.algorithms.base.Algorithm.setup` accepts those
arguments (the problem may be any pymoo problem, see
:mod:`tmopt.problems.pymoo_problem`) and :meth:`~tmopt.algorithms.base.Algorithm.run`
spends the budget through :func:`tmopt.run.runner.run_optimisation` — the same runner,
evaluator and archive as the command line, so the same seed gives the same archive — and
returns a pymoo :class:`~pymoo.core.result.Result`:

- ``X, F, G, CV`` and ``opt``: the final set, i.e. the feasible non-dominated designs of
  all real evaluations (none feasible: the least violating design), as pymoo's ``opt``;
- ``archive``: a pymoo :class:`~pymoo.core.population.Population` of every real
  evaluation in order (failed designs carry NaN objectives and ``CV = inf``);
- ``chosen``: the design chosen from the final set by paper Eq. 21 (``best.json`` of a
  run folder: index into the archive, feasible, X, F, G);
- ``metrics``: what ``metrics.json`` holds (IGD/HV where a front is known, counts);
- ``pf``: the problem's Pareto front where known; ``exec_time`` in seconds.

The budget comes from ``termination``: ``("n_evals", N)`` (or ``"n_eval"``) or pymoo's
:class:`~pymoo.termination.max_eval.MaximumFunctionCallTermination`; every other
criterion is refused with one line, since tmopt algorithms spend a budget of real
evaluations. Keyword arguments besides ``seed``: ``verbose`` (the progress bar) and
``outdir`` (write a run folder as the command line does, resumable).
"""

from __future__ import annotations

import time

import numpy as np
from pymoo.core.population import Population
from pymoo.core.result import Result

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.metrics import constraint_violation

#: ``minimize``/``setup`` keyword arguments tmopt algorithms understand besides the seed.
RUN_OPTIONS = ("verbose", "outdir")
EVAL_TERMINATIONS = ("n_evals", "n_eval")


def budget_from(algorithm: str, budget, termination) -> int:
    """The real-evaluation budget of ``budget=`` or of a pymoo ``termination``."""
    if budget is not None:
        if termination is not None:
            raise AlgorithmConfigError(f"algorithm {algorithm}: give budget= or "
                                       "termination=, not both")
        return budget
    if isinstance(termination, tuple) and len(termination) == 2 \
            and termination[0] in EVAL_TERMINATIONS:
        return termination[1]
    n_max = getattr(termination, "n_max_evals", None)
    if n_max is not None:
        return n_max
    raise AlgorithmConfigError(
        f"algorithm {algorithm}: needs a budget of real evaluations: budget=N, or in "
        f"pymoo's minimize the termination ('n_evals', N); got {termination!r}")


def run_options(algorithm: str, options: dict) -> dict:
    """``options`` checked against :data:`RUN_OPTIONS` (one line naming the unknown one)."""
    unknown = sorted(set(options) - set(RUN_OPTIONS))
    if unknown:
        raise AlgorithmConfigError(
            f"algorithm {algorithm}: option {unknown[0]!r} is not supported when a tmopt "
            f"algorithm runs under pymoo's minimize; supported: seed, termination, "
            f"{', '.join(RUN_OPTIONS)}")
    return {"verbose": bool(options.get("verbose", False)), "outdir": options.get("outdir")}


def archive_population(data) -> Population:
    """Every real evaluation of ``data`` (an :class:`ArchiveData`) as a pymoo population."""
    cv = constraint_violation(np.nan_to_num(data.G, nan=np.inf))
    cv[data.failed] = np.inf
    return Population.new(X=data.X, F=data.F, G=data.G, CV=cv[:, None])


def run_algorithm(algorithm) -> Result:
    """Run a set-up tmopt ``algorithm`` with :func:`tmopt.run.runner.run_optimisation`.

    The one import of the ``run`` layer from below it (docs/decisions.md, "The house"):
    pymoo's contract makes the algorithm object run itself, and it must run through the
    same runner as the command line to give the same archive.
    """
    from tmopt.run.runner import run_optimisation

    if algorithm.problem is None:
        raise AlgorithmConfigError(f"algorithm {algorithm.name}: call setup(problem, ...) "
                                   "(or pymoo's minimize) before run()")
    user, problem, options = algorithm.user_problem, algorithm.problem, algorithm.run_options
    started = time.time()
    done = run_optimisation(problem, algorithm, budget=algorithm.budget, seed=algorithm.seed,
                            outdir=options["outdir"], progress=options["verbose"],
                            plots=options["outdir"] is not None)
    return to_result(user, problem, done, started)


def to_result(problem, expensive, run, started: float) -> Result:
    """The pymoo :class:`Result` of a finished :class:`~tmopt.run.runner.RunResult`;
    ``problem`` is the user's, ``expensive`` the tmopt problem that was run."""
    from tmopt.run.outputs import final_choice, reference_front

    archive = archive_population(run.archive)
    pareto, best = final_choice(run.archive)
    opt = archive[pareto] if len(pareto) else archive[[best]] if best >= 0 else archive[[]]
    res = Result()
    res.problem, res.archive, res.opt, res.pop = problem, archive, opt, archive
    res.X, res.F, res.G, res.CV = opt.get("X"), opt.get("F"), opt.get("G"), opt.get("CV")
    res.chosen = run.metrics["chosen"]
    res.metrics = run.metrics
    res.pf = reference_front(expensive)
    res.success = bool(len(pareto))
    res.message = None if res.success else "no feasible design was found"
    res.start_time, res.end_time = started, time.time()
    res.exec_time = res.end_time - started
    return res
