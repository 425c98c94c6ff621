"""DRL-SAEA: MGSAEA whose constraint-modelling granularity a double DQN chooses.

Tags: expensive, constrained, multi-objective, surrogate-assisted (real-valued variables).

Implements
    S. Shao, Y. Tian, Y. Zhang, "Deep reinforcement learning assisted surrogate model
    management for expensive constrained multi-objective optimization", Swarm and
    Evolutionary Computation 92: 101817, 2025 (reference code: PlatEMO
    ``Algorithms/Multi-objective optimization/DRL-SAEA``, written from, not translated);
    double DQN: H. van Hasselt, A. Guez, D. Silver, AAAI 2016.

DRL-SAEA is MGSAEA (:mod:`tmopt.algorithms.mgsaea`) without stage one and without the
stage switch: every iteration an agent picks one of MGSAEA's three stage-two granularities
-- the action -- and the iteration runs as MGSAEA's stage two with it (models, ``wmax``
surrogate generations, ``mu`` real evaluations, population and elite-set updates):

    action 0 "coarse":     objectives + one model of the total scaled violation, CDP;
    action 1 "fine":       objectives + one model per not fully satisfied constraint;
    action 2 "objectives": objective models only.

State (of the elite set of size N, PlatEMO's ``Archive``): [sum over objectives of the
variance of the objective values, sum of all objective values, total violation, share of
the budget spent]. Reward (GenerateSample.m): the relative change of the hypervolume of
the elite set's feasible non-dominated designs plus the relative decrease of its total
violation. The agent: a 4-5-5-3 tanh network (the Q-values of the three actions) and a
target copy; each step's (state, action, reward, next state) goes into a replay buffer of
100; every ``replay_every`` steps a batch of 16 trains the network towards
r + gamma Q_target(s', argmax_a Q(s', a)) (double DQN), every ``copy_every`` steps the
target takes the network's weights. The action is greedy with probability
(n_actions + 1) / (2 n_actions) = 2/3, else uniform (PlatEMO's ``datasample`` of the best
action repeated n_actions times and every action once).

Parameters: MGSAEA's (``gap``, ``threshold`` and ``sigma`` are unused: there is no stage
switch) and those of :class:`DRLSAEA`'s signature.

Deviations from PlatEMO (docs/algorithms-frontier.md, "DRL-SAEA"): the network is trained
by Adam for ``train_epochs`` full-batch epochs on the mean squared error (MATLAB's
``train``: Levenberg-Marquardt with early stopping on a random validation split); states
are min-max scaled to [-1, 1] over the replay buffer (PlatEMO configures the input scaling
once on random numbers, so the raw sums -- hundreds -- saturate the tanh units); the
state's budget share is the one at the time of the state (PlatEMO gives both states the
current share); the hypervolume of both elite sets uses one normalisation (PlatEMO's
lower bound differs between the two); a reward with no feasible design before is 0 for
the hypervolume part (PlatEMO: NaN -> 0, x / 0 -> inf); MGSAEA's documented fixes
(violation scaling, no re-evaluation, failed designs) hold here too.
"""

from __future__ import annotations

import logging

import numpy as np
import torch

from tmopt.algorithms.base import AlgorithmConfigError, check_choice, check_int, check_number
from tmopt.algorithms.mgsaea import MGSAEA, ModelPlan, granularity_plan
from tmopt.algorithms.operators.constraints import choose_granularity, dominance_matrix
from tmopt.metrics.indicators import constraint_violation, hypervolume

log = logging.getLogger(__name__)

#: The agent's actions, MGSAEA's stage-two granularities.
ACTIONS = ("coarse", "fine", "objectives")
#: How states reach the network: "buffer" (min-max to [-1, 1] over the states in the
#: replay buffer) or "configured" (PlatEMO's ``configure(net, rand(4, 5), -rand(3, 5))``:
#: mapminmax fixed once from 5 uniform draws per input, and the outputs likewise from
#: 5 draws of -U(0, 1) per action).
INPUT_SCALINGS = ("buffer", "configured")
#: What ``reference="platemo"`` sets besides MGSAEA's PLATEMO_SETTINGS.
PLATEMO_SETTINGS = {"input_scaling": "configured", "same_budget_share": True,
                    "per_set_reward": True}


class DoubleDQN:
    """The agent: Q-network, target network, replay buffer (van Hasselt et al. 2016).

    Args:
        n_states, n_actions: Sizes of the state and of the action set.
        hidden: Sizes of the tanh hidden layers.
        buffer_size: Experiences kept (a ring buffer; the oldest is overwritten).
        discount: gamma of the target r + gamma Q_target(s', argmax_a Q(s', a)).
        train_epochs, learning_rate: Adam on the batch's mean squared error.
        seed: Seeds the network weights and the replay sampling.
        configured: the "configured" input scaling of :data:`INPUT_SCALINGS` (else
            "buffer").
    """

    def __init__(self, n_states: int, n_actions: int, *, hidden: tuple[int, ...],
                 buffer_size: int, discount: float, train_epochs: int, learning_rate: float,
                 seed: int, configured: bool = False) -> None:
        self.n_actions = n_actions
        self.discount = discount
        self.train_epochs = train_epochs
        self.learning_rate = learning_rate
        self.rng = np.random.default_rng(seed)
        self.input_scaling = "configured" if configured else "buffer"
        if configured:  # DDQN.m: configure(net, rand(nS, 5), -rand(nA, 5))
            draws = self.rng.random((5, n_states))
            self.in_lo, self.in_hi = draws.min(axis=0), draws.max(axis=0)
            targets = -self.rng.random((5, n_actions))
            self.out_lo, self.out_hi = targets.min(axis=0), targets.max(axis=0)
        with torch.random.fork_rng():
            torch.manual_seed(seed)
            self.agent = _network(n_states, hidden, n_actions)
            self.target = _network(n_states, hidden, n_actions)
        self.copy_to_target()
        self.buffer_size = buffer_size
        self.S = np.zeros((0, n_states))
        self.A = np.zeros(0, dtype=int)
        self.R = np.zeros(0)
        self.S1 = np.zeros((0, n_states))
        self._next = 0  # ring-buffer position once full

    def copy_to_target(self) -> None:
        self.target.load_state_dict(self.agent.state_dict())

    def _scaled(self, S: np.ndarray) -> torch.Tensor:
        """States min-max scaled to [-1, 1] over every state in the buffer (and ``S``), or
        by the fixed configured ranges (MATLAB's mapminmax: 2 (s - lo) / (hi - lo) - 1)."""
        if self.input_scaling == "configured":
            lo, span = self.in_lo, self.in_hi - self.in_lo
        else:
            seen = np.vstack([self.S, self.S1, S])
            lo, hi = seen.min(axis=0), seen.max(axis=0)
            span = np.where(hi > lo, hi - lo, 1.0)
        return torch.as_tensor(2.0 * (S - lo) / span - 1.0, dtype=torch.float64)

    def _q(self, net: torch.nn.Module, S: torch.Tensor) -> torch.Tensor:
        """Q-values; with the configured scaling the network's outputs live in [-1, 1] of
        the configured output ranges (mapminmax's reverse)."""
        out = net(S)
        if self.input_scaling != "configured":
            return out
        lo = torch.as_tensor(self.out_lo)
        return lo + (out + 1.0) * torch.as_tensor(self.out_hi - self.out_lo) / 2.0

    def q_values(self, state: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return self._q(self.agent, self._scaled(np.atleast_2d(state)))[0].numpy()

    def act(self, state: np.ndarray, rng: np.random.Generator) -> int:
        """The greedy action (ties: any of them) with probability (n+1)/(2n), else uniform."""
        q = self.q_values(state)
        best = np.flatnonzero(q == q.max())
        pool = np.concatenate([np.tile(best, self.n_actions), np.arange(self.n_actions)])
        return int(pool[rng.integers(len(pool))])

    def store(self, s: np.ndarray, a: int, r: float, s1: np.ndarray) -> None:
        if len(self.S) < self.buffer_size:
            self.S, self.S1 = np.vstack([self.S, s]), np.vstack([self.S1, s1])
            self.A, self.R = np.append(self.A, a), np.append(self.R, r)
            return
        i = self._next
        self.S[i], self.A[i], self.R[i], self.S1[i] = s, a, r, s1
        self._next = (i + 1) % self.buffer_size

    def targets(self, S: np.ndarray, A: np.ndarray, R: np.ndarray,
                S1: np.ndarray) -> torch.Tensor:
        """Training targets (batch, n_actions): the network's own Q-values, except
        Q(s, a) <- r + gamma Q_target(s', argmax_b Q(s', b)) (double DQN)."""
        with torch.no_grad():
            target = self._q(self.agent, self._scaled(S)).clone()
            next_in = self._scaled(S1)
            best_next = self._q(self.agent, next_in).argmax(dim=1)
            next_q = self._q(self.target, next_in).gather(1, best_next[:, None])[:, 0]
            rows = torch.arange(len(S))
            target[rows, torch.as_tensor(A)] = torch.as_tensor(R) + self.discount * next_q
        return target

    def replay(self, batch_size: int) -> float:
        """One double-DQN update on a batch drawn with replacement; the final loss."""
        idx = self.rng.integers(len(self.S), size=batch_size)
        S = self._scaled(self.S[idx])
        target = self.targets(self.S[idx], self.A[idx], self.R[idx], self.S1[idx])
        opt = torch.optim.Adam(self.agent.parameters(), lr=self.learning_rate)
        loss = torch.zeros(())
        for _ in range(self.train_epochs):
            opt.zero_grad()
            loss = torch.mean((self._q(self.agent, S) - target) ** 2)
            loss.backward()
            opt.step()
        return float(loss.item())


def _network(n_in: int, hidden: tuple[int, ...], n_out: int) -> torch.nn.Sequential:
    layers: list[torch.nn.Module] = []
    for width in hidden:
        layers += [torch.nn.Linear(n_in, width), torch.nn.Tanh()]
        n_in = width
    layers.append(torch.nn.Linear(n_in, n_out))
    return torch.nn.Sequential(*layers).double()


def elite_state(F: np.ndarray, G: np.ndarray, spent: float) -> np.ndarray:
    """[sum of the objectives' variances (ddof 1, as MATLAB's var), sum of all objective
    values, total violation, budget share spent] of a set (GenerateSample.m)."""
    var = F.var(axis=0, ddof=1).sum() if len(F) > 1 else 0.0
    return np.array([var, F.sum(), np.maximum(G, 0.0).sum(), spent])


def reward(F0: np.ndarray, G0: np.ndarray, F1: np.ndarray, G1: np.ndarray,
           per_set: bool = False) -> float:
    """Relative hypervolume change of the feasible non-dominated designs plus the relative
    decrease of the total violation, from set 0 to set 1 (GenerateSample.m).

    The hypervolume of both is taken in one normalisation: lower bound min(0, the
    smallest objective value of either feasible set), upper bound the largest objective
    values of both whole sets, reference point 1.1 (PlatEMO's ``HV`` with the largest
    values as its "optimum"). ``per_set``: PlatEMO's ``HV`` as GenerateSample.m calls it:
    each set's own lower bound min(0, its feasible set's minimum); a set without feasible
    designs has HV NaN, and a NaN relative change counts 0 (x / 0 stays inf).
    """
    upper = np.vstack([F0, F1]).max(axis=0)
    fronts = [_feasible_front(F, G) for F, G in ((F0, G0), (F1, G1))]
    ref = np.full(F0.shape[1], 1.1)
    if per_set:
        hv0, hv1 = (hypervolume(f, ref, np.minimum(f.min(axis=0), 0.0), upper) if len(f)
                    else np.nan for f in fronts)
        with np.errstate(divide="ignore", invalid="ignore"):
            r_hv = np.float64(hv1 - hv0) / np.float64(hv0)
        r_hv = 0.0 if np.isnan(r_hv) else float(r_hv)
    else:
        lower = np.minimum(np.vstack([np.zeros((1, F0.shape[1])), *fronts]).min(axis=0), 0.0)
        hv0, hv1 = (hypervolume(f, ref, lower, upper) if len(f) else 0.0 for f in fronts)
        r_hv = (hv1 - hv0) / hv0 if hv0 > 0 else 0.0
    cv0, cv1 = np.maximum(G0, 0.0).sum(), np.maximum(G1, 0.0).sum()
    r_cv = 0.0 if cv0 == 0 else (cv0 - cv1) / cv0
    return float(r_hv + r_cv)


def _feasible_front(F: np.ndarray, G: np.ndarray) -> np.ndarray:
    F = F[constraint_violation(G) <= 0]
    return F[~dominance_matrix(F).any(axis=0)] if len(F) else F


class DRLSAEA(MGSAEA):
    """DRL-SAEA (see the module docstring)."""

    name = "drlsaea"

    def __init__(self, *, hidden: tuple[int, ...] | list[int] = (5, 5), buffer_size: int = 100,
                 batch_size: int = 16, replay_every: int = 8, copy_every: int = 11,
                 discount: float = 0.999, train_epochs: int = 100,
                 learning_rate: float = 0.01, input_scaling: str = "buffer",
                 same_budget_share: bool = False, per_set_reward: bool = False,
                 **kwargs) -> None:
        """Args: the agent's settings (GenerateSample.m, DDQN.m, DRLSAEA.m; ``train_epochs``
        and ``learning_rate`` are this implementation's, see the module docstring), the
        PlatEMO-parity switches (module docstring) and MGSAEA's keyword arguments
        (``reference="platemo"`` sets both groups)."""
        super().__init__(**kwargs)
        name = self.name
        check_choice(name, "input_scaling", input_scaling, INPUT_SCALINGS)
        if self.reference == "platemo":  # every documented fix undone (PLATEMO_SETTINGS)
            input_scaling, same_budget_share, per_set_reward = "configured", True, True
        self.input_scaling = input_scaling
        self.same_budget_share = bool(same_budget_share)
        self.per_set_reward = bool(per_set_reward)
        if isinstance(hidden, (str, bytes)) or not all(
                isinstance(w, int) and not isinstance(w, bool) and w >= 1 for w in hidden):
            raise AlgorithmConfigError(f"algorithm {name}: hidden must be a list of integers >= 1, "
                             f"got {hidden!r}")
        self.hidden = tuple(int(w) for w in hidden)
        self.buffer_size = check_int(name, "buffer_size", buffer_size, 1)
        self.batch_size = check_int(name, "batch_size", batch_size, 1)
        self.replay_every = check_int(name, "replay_every", replay_every, 1)
        self.copy_every = check_int(name, "copy_every", copy_every, 1)
        self.discount = check_number(name, "discount", discount, 0.0, 1.0)
        self.train_epochs = check_int(name, "train_epochs", train_epochs, 1)
        self.learning_rate = check_number(name, "learning_rate", learning_rate, 0.0,
                                          low_open=True)

    def _setup(self) -> None:
        super()._setup()
        self.stage = 2  # no stage one: every iteration is a stage-two iteration
        self.agent = DoubleDQN(4, len(ACTIONS), hidden=self.hidden,
                               buffer_size=self.buffer_size, discount=self.discount,
                               train_epochs=self.train_epochs,
                               learning_rate=self.learning_rate,
                               seed=int(self.rng.integers(2**31)),
                               configured=self.input_scaling == "configured")
        self.action: int | None = None
        self._state: np.ndarray | None = None
        self._before: tuple[np.ndarray, np.ndarray] | None = None
        self._steps = 0
        self._rewards: list[float] = []
        self._actions: list[int] = []

    def _update_stage(self) -> None:
        """Learn from the last action's outcome, then choose this iteration's action."""
        elite = self._elite
        state = elite_state(elite.F, elite.G, self.n_evals / self.budget)
        if self.action is not None:
            r = reward(*self._before, elite.F, elite.G, per_set=self.per_set_reward)
            before = self._state.copy()
            if self.same_budget_share:  # GenerateSample.m: both states get the current share
                before[3] = state[3]
            self.agent.store(before, self.action, r, state)
            self._rewards.append(r)
            self._steps += 1
            if self._steps % self.replay_every == 0:
                self.agent.replay(self.batch_size)
            if self._steps % self.copy_every == 0:
                self.agent.copy_to_target()
        self.action = self.agent.act(state, self.rng)
        self._actions.append(self.action)
        self._state, self._before = state, (elite.F.copy(), elite.G.copy())

    def _make_plan(self) -> ModelPlan:
        G = self._pop.G
        return granularity_plan(ACTIONS[self.action], choose_granularity(G)[1], G,
                                minmax=self.violation_scaling == "minmax")

    def info(self) -> dict:
        out = super().info()
        out.pop("stage", None)
        if self.action is not None:
            out["action"] = ACTIONS[self.action]
        return out

    def summary(self) -> dict:
        """Iterations per action, and the rewards' sum and last value."""
        counts = np.bincount(np.asarray(self._actions, dtype=int), minlength=len(ACTIONS))
        return {"actions": {a: int(c) for a, c in zip(ACTIONS, counts)},
                "iterations": len(self._actions),
                "reward_sum": float(np.sum(self._rewards)) if self._rewards else None,
                "replays": self._steps // self.replay_every}
