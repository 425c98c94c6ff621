"""From a diagnosis to the next excitation: targets, noise, the solve and the choice.

:func:`plan_from_diagnosis` collects what the recording could not identify (the
diagnosis' "not excited" / "aliased" list, and the names it reported ambiguous with a
rival a planned run can hold: :func:`ambiguous_targets`), the noise level it measured and
the model it identified, builds the :class:`~tmopt.design.problem.DesignProblem`, solves it (any
algorithm of the registry, MGSAEA with the GP by default, or any pymoo algorithm) and
picks one design:

* among the feasible designs (Eq. 20 on every axis of the realised run), those that make
  every target detectable (``z sigma <= plausible``, the diagnosis' own criterion) if
  any, else all feasible designs; of those, the ones whose k1xx standard error is not
  worse than the recorded excitation's, if any (the flagship must not pay for the
  effects);
* of those, the one nearest the ideal point after Eq. 21's normalisation
  ``(f - f_min) / f_min``: over ``se_k1xx`` and the duration once every target is
  detectable (detectability is a threshold), else over all objectives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from tmopt.design.information import (
    NoiseLevel,
    Prediction,
    Rival,
    Target,
    candidate_for,
    predict,
    regressor_data,
    rival_candidate,
)
from tmopt.design.problem import DesignProblem, DesignSpace
from tmopt.mismatch.effects import EFFECTS
from tmopt.mismatch.fit import Data

__all__ = ["Plan", "targets_from", "ambiguous_targets", "plan_from_diagnosis", "plan",
           "choose"]

REASONS = ("not excited", "aliased")


@dataclass
class Plan:
    """The chosen design and what it is predicted to do."""

    problem: DesignProblem
    x: np.ndarray
    spec: str
    duration: float
    before: Prediction
    after: Prediction
    constraints: np.ndarray
    objectives: np.ndarray
    feasible: bool
    all_detectable: bool
    n_evaluated: int
    run: object  # the noise-free SimulationResult of the chosen design

    @property
    def z(self) -> float:
        return self.problem.z


def targets_from(entries: list[dict], data: Data, basis: np.ndarray,
                 effects: list[str] | None = None) -> list[Target]:  # fmt: skip
    """Targets from the diagnosis' ``not_identifiable`` entries: "not excited" or
    "aliased", with a plausible size, of an effect whose regressors need no residual
    (profiled effects are searched, not designed for) and that a planned run can show
    without witness channels (the design moves the test masses, not the spacecraft),
    optionally only ``effects``."""
    probe = regressor_data(replace(data, omega=None, omega_dot=None))
    cache: dict = {}
    out = []
    for r in entries:
        name = r.get("name")
        if r.get("reason") not in REASONS or r.get("plausible") is None or name not in EFFECTS:
            continue
        if not wanted(name, r["channel"], effects):
            continue
        if EFFECTS[name].profiled:
            continue
        t = Target(name, r["channel"], float(r["plausible"]), r["reason"], r.get("aliased_with"))
        try:
            candidate_for(t, probe, basis, cache)
        except ValueError:
            continue
        out.append(t)
    return out


def wanted(name: str, channel: str, effects: list[str] | None) -> bool:
    """Is ``name[channel]`` asked for: ``effects`` (None: all) lists names, or names with
    a channel, ``name[channel]`` (one flagged channel of an effect flagged on several)."""
    return effects is None or name in effects or f"{name}[{channel}]" in effects


#: Why no design is made (one line).
NOTHING = ("the diagnosis flags no effect parameter as not identifiable and no name as "
           "ambiguous with a rival a planned run can separate: nothing to design for")


def ambiguous_of(dg) -> list[dict]:
    """The report's ``ambiguous`` entries of a diagnosis (a report's own list when ``dg``
    was read from a report.json), and one for each catalogue name within the band of a
    selected unnamed feature (:func:`feature_rivalries`)."""
    from tmopt.mismatch.diagnose import Diagnosis
    from tmopt.mismatch.report import design_entries

    if isinstance(dg, Diagnosis):
        rep = design_entries(dg)
    else:
        rep = {"ambiguous": getattr(dg, "ambiguous", []), "features": getattr(dg, "features", [])}
    return list(rep["ambiguous"]) + feature_rivalries(rep["features"], dg)


def feature_rivalries(features: list[dict], dg) -> list[dict]:
    """Ambiguous entries for the catalogue names within the band of a selected unnamed
    feature (report ``features[i].alternatives``): the name, its rival the feature, and
    its size as the recording shows it -- the name fitted alone with the nominal model
    (the feature took its place in the diagnosis, so it has no fitted value there)."""
    from tmopt.mismatch.diagnose import effect_parameters, fit_state
    from tmopt.mismatch.generic import GENERIC

    out = []
    for f in features:
        for a in f.get("alternatives", []):
            if a.get("name") not in EFFECTS or f.get("feature") is None:
                continue
            try:
                cand = candidate_for(Target(a["name"], a["channel"], 1.0), dg.data, dg.basis)
            except ValueError:
                continue
            if cand.group != "equation":
                continue
            state = fit_state(dg.data, dg.basis, cand.columns, [], False, dg.settings)
            params = {k: v for k, (v, _) in effect_parameters(state, cand).items()}
            out.append({"name": a["name"], "channel": a["channel"], "parameters": params,
                        "rivals": [{"name": GENERIC, "channel": f["channel"],
                                    "feature": f["feature"]}]})  # fmt: skip
    return out


def ambiguous_targets(entries: list[dict], data: Data, basis: np.ndarray,
                      effects: list[str] | None = None) -> list[Target]:  # fmt: skip
    """Targets from the report's ``ambiguous`` entries (docs/mismatch-report-schema.md):
    the name and the rivals within its ambiguity band that a planned run can hold -- a
    catalogue effect (not profiled) or an unnamed feature whose column the motion fixes
    (:func:`tmopt.design.information.rival_candidate`) -- in the name's own residual group
    (one regression profiles them; two groups are compared by delta BIC only).  The
    target size is the size the recording showed, ``|value|`` of its one coefficient: the
    design makes that value detectable with the rivals in the model, which is also the
    expected delta-BIC gap between the name and each rival (docs/design.md, "Ambiguous
    names").  Names of several coefficients (a delay's taps) are left out."""
    probe = regressor_data(replace(data, omega=None, omega_dot=None))
    cache: dict = {}
    out = []
    for e in entries:
        name = e.get("name")
        if name not in EFFECTS or EFFECTS[name].profiled:
            continue
        if not wanted(name, e.get("channel", ""), effects):
            continue
        try:
            cand = candidate_for(Target(name, e["channel"], 1.0), probe, basis, cache)
        except ValueError:
            continue
        size = _coefficient(cand, (e.get("parameters") or {}).get(cand.params[0]))
        if len(cand.columns) != 1 or size is None:
            continue
        rivals = []
        for r in e.get("rivals", []):
            rv = Rival(r.get("name", ""), r.get("channel", ""), r.get("feature"))
            if rv.feature is None and (rv.effect not in EFFECTS or EFFECTS[rv.effect].profiled):
                continue  # a shape misfit, a weak name, structure left: no column
            try:
                if rival_candidate(rv, probe, basis, cache).group != cand.group:
                    continue
            except ValueError:
                continue
            rivals.append(rv)
        if rivals:
            out.append(Target(name, e["channel"], size, "ambiguous",
                              " or ".join(r.key for r in rivals), tuple(rivals)))  # fmt: skip
    return out


def _coefficient(cand, value) -> float | None:
    """|coefficient| of a one-column candidate from its reported parameter (a readout
    scale is reported as ``e = b / (1 - b)`` of its coefficient b), None if unusable."""
    if value is None or not math.isfinite(float(value)) or value == 0:
        return None
    kind = next(iter(cand.derived.values()))[0] if cand.derived else None
    if kind == "ratio":
        value = value / (1.0 + value)
    elif kind is not None:
        return None
    return abs(float(value))


def threshold(n_tests: int, alpha: float) -> float:
    """The diagnosis' detection threshold z (Bonferroni chi^2_1 quantile, square root)."""
    return math.sqrt(float(stats.chi2.isf(alpha / max(n_tests, 1), 1)))


def choose(problem: DesignProblem, x: np.ndarray, f: np.ndarray, g: np.ndarray,
           k_before: float | None = None) -> tuple[int, bool, bool]:  # fmt: skip
    """Index of the chosen design, whether it is feasible and makes every target
    detectable (see the module docstring).  ``k_before``: k1xx's standard error with the
    recorded excitation; designs that do not make it worse are preferred."""
    feasible = np.all(g <= 0, axis=1)
    n_eff = len(problem.effects)
    ratios = f[:, 1 : 1 + n_eff] if n_eff else np.zeros((f.shape[0], 0))
    detect = feasible & np.all(ratios * problem.z <= 1.0, axis=1)
    pool = np.flatnonzero(detect) if detect.any() else np.flatnonzero(feasible)
    if pool.size == 0:  # nothing feasible: the least violation
        return int(np.argmin(np.sum(np.maximum(g, 0), axis=1))), False, False
    if k_before is not None and np.any(f[pool, 0] <= k_before):
        pool = pool[f[pool, 0] <= k_before]
    # detectability reached: it is a threshold, so Eq. 21 weighs k1xx and the time only
    cols = [0, f.shape[1] - 1] if detect.any() else list(range(f.shape[1]))
    fp = f[np.ix_(pool, cols)]
    fmin = np.maximum(fp.min(axis=0), 1e-300)
    dist = np.sqrt(np.sum(((fp - fmin) / fmin) ** 2, axis=1))  # Eq. 21
    return int(pool[np.argmin(dist)]), True, bool(detect.any())


def initial_designs(problem: DesignProblem, n: int, seed: int) -> np.ndarray:
    """Latin-hypercube start with amplitudes in the lower 60 % of their a-priori range:
    the realised run needs more force than ``sum A w^2`` at the end of the start ramp
    (the loop's transient), so the top of the range is often infeasible."""
    from scipy.stats import qmc

    u = qmc.LatinHypercube(d=problem.n_var, seed=seed).random(n)
    u[:, :-1:3] *= 0.6  # amplitude fractions (every third variable, from the first)
    return problem.xl + u * (problem.xu - problem.xl)


#: The solver when none is named: MGSAEA with the GP (docs/design.md, "Which solver").
DEFAULT_ALGORITHM = "mgsaea"
#: Real evaluations after a surrogate algorithm's initial sample when no budget is given
#: (MGSAEA: 25 iterations of mu = 5).
ITERATION_BUDGET = 125


def solve(problem: DesignProblem, algorithm=None, budget: int | None = None, seed: int = 0,
          pop_size: int | None = None, progress: bool = False) -> tuple[np.ndarray, ...]:
    """Every design ``algorithm`` evaluates on ``problem`` within ``budget`` evaluations:
    X (n, D), F (n, M) physical objectives (``10**`` what the optimiser saw), G (n, C).

    ``algorithm``: a name of the algorithm registry (``tmopt/conf/algorithm``, built as
    ``python -m tmopt algorithm=NAME`` builds it, surrogate ``gp``; ``None``:
    :data:`DEFAULT_ALGORITHM`), run through the framework's runner; or any pymoo
    algorithm object.  ``budget``: real evaluations (None: the algorithm's initial sample
    plus :data:`ITERATION_BUDGET`; NSGA-II: 30 generations).  ``pop_size``: the population
    of ``nsga2`` (which then starts from :func:`initial_designs`); ``progress``: the
    runner's line per generation."""
    name = DEFAULT_ALGORITHM if algorithm is None else algorithm
    if isinstance(name, str):
        from tmopt.run.cli import algorithm_from_registry
        from tmopt.run.runner import run_optimisation

        algo = algorithm_from_registry(name)
        if name == "nsga2":  # its operators, this population, started low (initial_designs)
            from pymoo.algorithms.moo.nsga2 import NSGA2

            size = algo.pop_size if pop_size is None else pop_size
            algo = NSGA2(pop_size=size, sampling=initial_designs(problem, size, seed),
                         crossover=algo.crossover, mutation=algo.mutation,
                         eliminate_duplicates=True)  # fmt: skip
            budget = 30 * size if budget is None else budget
        elif budget is None:
            budget = algo.initial_sample_size(problem) + ITERATION_BUDGET
        run = run_optimisation(problem, algo, budget=budget, seed=seed, outdir=None,
                               progress=bool(progress), plots=False)  # fmt: skip
        a = run.archive
        ok = ~a.failed
        return a.X[ok], 10.0 ** a.F[ok], a.G[ok]
    from pymoo.optimize import minimize

    xs, fs, gs = [], [], []

    def keep(alg):
        xs.append(alg.pop.get("X"))
        fs.append(alg.pop.get("F"))
        gs.append(alg.pop.get("G"))

    minimize(problem, name, ("n_evals", 1200 if budget is None else budget), seed=seed,
             callback=keep, verbose=False)  # fmt: skip
    return np.vstack(xs), 10.0 ** np.vstack(fs), np.vstack(gs)


def plan(problem: DesignProblem, data: Data, algorithm=None, budget: int | None = None,
         seed: int = 0,
         pop_size: int | None = None, progress: bool = False) -> Plan:  # fmt: skip
    """Solve ``problem`` (:func:`solve`) and choose; ``data`` is the recording (for the
    "before")."""
    x, f, g = solve(problem, algorithm, budget, seed, pop_size, progress)
    before = recorded_prediction(problem, data)
    i, feasible, detect = choose(problem, x, f, g, before.se["k1xx"])
    duration = problem.space.duration_of(x[i])
    spec = problem.spec(x[i])
    run = problem.simulate([spec], duration)
    after = problem.predictions(run, [spec])[0]
    return Plan(problem, x[i], spec, duration, before, after,
                problem.constraints(run, [spec])[0],
                problem.objectives(after, duration), feasible, detect, x.shape[0], run)


def recorded_prediction(problem: DesignProblem, data: Data) -> Prediction:
    """The same prediction for the recorded excitation: a noise-free rerun of the recorded
    references (``ref_x1``/``ref_x2``; y held at zero, as the nominal loop does), so that
    before and after differ only by the motion.  Without recorded references, the
    recording's own regressors (noisy: an unexcited axis' noise then counts as motion)."""
    if data.ref is None:
        return predict(data, problem.basis, problem.targets, problem.noise)
    refs = np.zeros((1, 4, data.n))
    refs[0, :2] = data.ref
    return problem.predictions(problem.simulate_refs(refs))[0]


def plan_from_diagnosis(dg, space: DesignSpace | None = None, effects: list[str] | None = None,
                        **solve) -> Plan:  # fmt: skip
    """The next excitation for a :class:`~tmopt.mismatch.diagnose.Diagnosis`."""
    data, basis = dg.data, dg.basis
    amb = list({t.key: t for t in ambiguous_targets(ambiguous_of(dg), data, basis,
                                                   effects)}.values())  # one per key
    keys = {t.key for t in amb}  # an ambiguous name's target replaces any other of its key
    targets = [t for t in targets_from(dg.not_identifiable, data, basis, effects)
               if t.key not in keys] + amb  # fmt: skip
    if not targets:
        raise ValueError(NOTHING)
    noise = NoiseLevel(dg.after.eq_noise, dg.after.kin_noise)
    n_tests = len(dg.steps[0]) if dg.steps else 1
    problem = DesignProblem(targets, noise, data.fs, data.geometry, identified_stiffness(dg),
                            space=space, z=threshold(n_tests, dg.settings.alpha))  # fmt: skip
    return plan(problem, data, **solve)


def identified_stiffness(dg) -> tuple[float, float, float, float]:
    """The diagnosis' stiffness estimates, the paper's 1e-7 s^-2 where one is not
    determined (standard error above its magnitude, e.g. an unexcited y axis)."""
    fit = dg.after.eq_fit
    out = []
    for k in ("k1xx", "k2xx", "k1yy", "k2yy"):
        v, s = fit.value(k), fit.sigma(k)
        out.append(v if math.isfinite(v) and s < abs(v) else 1e-7)
    return tuple(out)
