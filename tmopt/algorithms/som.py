"""The self-organising map that SSDE uses as its surrogate.

A one-dimensional Kohonen map (Kohonen, Biol. Cybern. 43, 1982) whose weight vectors live
in the joint space [normalised decision vector, output vector] (outputs: the objectives,
and in tmopt's optional extension of SSDE also the constraints). The best-matching unit
(BMU) of a design is found from the decision part only; the output part of the BMU is
the prediction. Training and the memory-based re-initialisation of nodes that won no
design follow PlatEMO's ``SSDE/Training.m`` (written by an author of the SSDE paper):

* initial weights a * N(0, 1) + b with a = 0.001, b = 0.5;
* per epoch (``epochs`` passes over the shuffled samples), every node j has its own
  radius sigma_j = sigma0 exp(-c_j / n) and rate eta_j = eta0 exp(-c_j / n), where c_j
  counts the epochs in which node j has won so far (at most one per epoch) and n is the
  number of samples;
* for a sample s with BMU u: the first time u wins it is set to s; then every node j with
  |u - j| < sigma_j (distance on the 1-D lattice) moves as
  w_j <- w_j + eta_j exp(-|u - j|) (s - w_j);
* before training, nodes that won no offspring since the last training are re-seeded as
  the mean of two winning nodes plus N(0, 0.001^2) noise, the two drawn with replacement
  with probability proportional to their crowding-distance rank (non-dominated sorting
  and crowding distance on the output part; larger crowding distance, larger weight),
  decision part clipped to [0, 1].

Deviation (docs/algorithms-baselines.md, "SSDE"): PlatEMO draws the two parents' indices
from 1..(number of winners) and then uses them as indices of the whole map, i.e. the
first nodes, winners or not; here they index the winning nodes, as the comment there
says was intended (``reseed_first_nodes=True`` restores PlatEMO's indexing).
"""

from __future__ import annotations

import numpy as np

from tmopt.algorithms.operators.constraints import cdp_sort
from tmopt.algorithms.operators.survival import crowding_per_front


class SelfOrganisingMap:
    """1-D SOM over [decision (normalised to [0, 1]), outputs] with BMU on decisions.

    Args:
        n_nodes: Number of neurons on the 1-D lattice.
        n_var: Number of decision variables (the first ``n_var`` weight columns).
        n_out: Number of predicted outputs (the last ``n_out`` weight columns).
        eta0: Initial learning rate.
        sigma0: Initial neighbourhood radius (lattice units).
        epochs: Passes over the samples per training.
        rng: Random generator (initial weights, shuffling, re-seeding).
        reseed_first_nodes: PlatEMO's Training.m: the two parents of a re-seeded node are
            nodes ``k`` of the whole map for ``k`` drawn among 0..(winners - 1) with the
            k-th winner's weight, i.e. the first nodes, winners or not.
    """

    def __init__(self, n_nodes: int, n_var: int, n_out: int, eta0: float, sigma0: float,
                 epochs: int, rng: np.random.Generator,
                 reseed_first_nodes: bool = False) -> None:
        self.n_var, self.n_out = n_var, n_out
        self.reseed_first_nodes = reseed_first_nodes
        self.eta0, self.sigma0, self.epochs = eta0, sigma0, epochs
        self.rng = rng
        self.W = 0.001 * rng.standard_normal((n_nodes, n_var + n_out)) + 0.5
        lattice = np.arange(n_nodes, dtype=float)
        self.lattice_distance = np.abs(lattice[:, None] - lattice[None, :])
        #: Nodes that were the BMU of some offspring since the last training.
        self.won = np.zeros(n_nodes, dtype=bool)

    def bmu(self, Xn: np.ndarray) -> np.ndarray:
        """Index of the nearest node (decision part, Euclidean) for each normalised row."""
        d2 = ((Xn[:, None, :] - self.W[None, :, : self.n_var]) ** 2).sum(axis=2)
        return np.argmin(d2, axis=1)

    def predict(self, Xn: np.ndarray) -> np.ndarray:
        """Output part of each row's BMU; marks those nodes as winners."""
        units = self.bmu(Xn)
        self.won[units] = True
        return self.W[units, self.n_var:].copy()

    def train(self, samples: np.ndarray) -> None:
        """Re-seed idle nodes, then ``epochs`` passes of Kohonen updates over ``samples``.

        Args:
            samples: Rows [normalised decision vector, outputs].
        """
        self._reseed_idle_nodes()
        self.won[:] = False
        n = len(samples)
        wins = np.zeros(len(self.W))
        for epoch in range(1, self.epochs + 1):
            sigma = self.sigma0 * np.exp(-wins / n)
            eta = self.eta0 * np.exp(-wins / n)
            for s in samples[self.rng.permutation(n)]:
                self._update(s, sigma, eta, wins, epoch)

    def _update(self, s: np.ndarray, sigma: np.ndarray, eta: np.ndarray, wins: np.ndarray,
                epoch: int) -> None:
        u = int(np.argmin(((self.W[:, : self.n_var] - s[: self.n_var]) ** 2).sum(axis=1)))
        if wins[u] == 0:
            self.W[u] = s  # a node's first win copies the sample (Training.m)
        if wins[u] < epoch:
            wins[u] += 1  # at most one counted win per epoch
        dist = self.lattice_distance[u]
        hood = dist < sigma
        step = (eta[hood] * np.exp(-dist[hood]))[:, None]
        self.W[hood] += step * (s - self.W[hood])

    def _reseed_idle_nodes(self) -> None:
        winners = np.flatnonzero(self.won)
        idle = np.flatnonzero(~self.won)
        if winners.size == 0 or idle.size == 0:
            return
        Fw = self.W[winners, self.n_var:]
        crowd = crowding_per_front(Fw, cdp_sort(Fw, np.zeros(len(Fw))))
        weight = np.empty(len(Fw))
        weight[np.argsort(crowd, kind="stable")] = np.arange(1, len(Fw) + 1)
        parents = np.arange(len(winners)) if self.reseed_first_nodes else winners
        pick = self.rng.choice(parents, size=(idle.size, 2), p=weight / weight.sum())
        noise = 0.001 * self.rng.standard_normal((idle.size, self.W.shape[1]))
        self.W[idle] = 0.5 * (self.W[pick[:, 0]] + self.W[pick[:, 1]]) + noise
        self.W[:, : self.n_var] = np.clip(self.W[:, : self.n_var], 0.0, 1.0)
