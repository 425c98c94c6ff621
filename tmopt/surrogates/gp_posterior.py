"""Exact joint GP posterior that reuses the rows of points it has seen (for qLogNEHVI).

BoTorch's noisy hypervolume acquisitions (qLogNEHVI) evaluate the *joint* posterior over
``(X_baseline, X)`` at every call, although only the rows of the ``q`` new points change
between calls (BoTorch's own TODO in ``NoisyExpectedHypervolumeMixin.
_compute_posterior_samples_and_concat_pending``). Through GPyTorch that costs
O((r + q) n^2) per output and call (r baseline points, n training points), forwards and
backwards; at n = 300, r = 57, q = 1 it was ~75 % of an iteration's acquisition time
(profile in docs/benchmarks-speed.md).

:class:`CachedJointGP` is a BoTorch model over a fitted :class:`GPSurrogate` whose
``posterior(X)`` computes the same exact posterior (Rasmussen & Williams 2006, Eqs.
2.23-2.24, from the Cholesky factor that :class:`GPSurrogate` caches at fit time), but
remembers the points of its last plain call (2-D, no gradient: BoTorch's calls over the
baseline, with pending points appended) together with ``V = L^-1 K(X_train, Z)``, their
posterior mean and covariance. A later call whose leading rows are those points (every
acquisition call: ``[X_baseline, X]``) computes only the new rows:

    V_r   = L^-1 K(X_train, X_r)  (triangular solve)               O(n^2 q)
    C_rz  = K(X_r, Z) - V_r^T V_z,  C_rr = K(X_r, X_r) - V_r^T V_r   O(n r q)

and the covariance is returned as :class:`JointCovariance`, a linear operator whose rows
of the new points (all that BoTorch's cached-Cholesky sampler reads) cost nothing more.
Any other call (other leading rows, ``observation_noise``, ``output_indices``, a
posterior transform) goes to the fitted BoTorch model itself.
"""

from __future__ import annotations

import torch
from botorch.models.gpytorch import GPyTorchModel
from botorch.posteriors.gpytorch import GPyTorchPosterior
from gpytorch.distributions import MultitaskMultivariateNormal
from linear_operator.operators import (
    BlockDiagLinearOperator,
    DenseLinearOperator,
    LinearOperator,
)

from tmopt.surrogates.base import SurrogateError


class CachedJointGP(GPyTorchModel):
    """BoTorch model: the exact posterior of a fitted batched GP, reusing known rows.

    Args:
        gp: A fitted :class:`tmopt.surrogates.gp.GPSurrogate` with one batched BoTorch
            ``SingleTaskGP`` (``fit_mode`` "per_output" or "batched"), at least 2 outputs.
    """

    def __init__(self, gp) -> None:
        super().__init__()
        base = gp.model
        caches = gp._caches
        if len(caches) != 1 or caches[0].Xn.shape[0] < 2:
            raise SurrogateError("CachedJointGP needs one batched GP of >= 2 outputs "
                                 "(fit_mode 'per_output' or 'batched')")
        c = caches[0]
        self._base = base
        self._kernel = c.part.covar_module
        self._transform = c.part.input_transform
        # (b, n, d), (b, n, n), (b, n, 1): normalised inputs, Cholesky factor L of
        # K + s^2 I, (K + s^2 I)^-1 (y - c)
        self._Xt, self._L, self._alpha = c.Xn, c.L, c.alpha
        self._const, self._y_mean, self._y_std = c.const, c.y_mean, c.y_std  # (b, 1) each
        self._num_outputs = c.Xn.shape[0]
        self._known: tuple[torch.Tensor, ...] | None = None  # Z, Zn, V, mean, cov

    @property
    def batch_shape(self) -> torch.Size:
        return torch.Size()

    @property
    def num_outputs(self) -> int:
        return self._num_outputs

    def posterior(self, X: torch.Tensor, output_indices=None, observation_noise=False,
                  posterior_transform=None, **kwargs) -> GPyTorchPosterior:
        if output_indices is not None or observation_noise is not False \
                or posterior_transform is not None or kwargs:
            return self._base.posterior(X, output_indices=output_indices,
                                        observation_noise=observation_noise,
                                        posterior_transform=posterior_transform, **kwargs)
        known = self._prefix(X)
        mean, cov = self._joint(X, known)
        std = self._y_std.unsqueeze(-1)                                  # (b, 1, 1)
        mean = mean * self._y_std + self._y_mean                         # (..., b, N)
        if isinstance(cov, JointCovariance):
            cov = cov.scaled(std * std)
        else:
            cov = DenseLinearOperator(cov * (std * std))
        mvn = MultitaskMultivariateNormal(
            mean=mean.transpose(-1, -2),
            covariance_matrix=BlockDiagLinearOperator(cov, block_dim=-3),
            interleaved=False)
        return GPyTorchPosterior(distribution=mvn)

    # ---- the algebra (standardised units, batch dim b = outputs) -----------------------
    def _prefix(self, X: torch.Tensor) -> int:
        """Number of leading rows of X that are the remembered points (0 if none)."""
        if self._known is None:
            return 0
        Z = self._known[0]
        c = Z.shape[0]
        if X.shape[-2] <= c or X.shape[-1] != Z.shape[-1]:
            return 0
        lead = X[..., :c, :]
        return c if torch.equal(lead, Z.expand_as(lead)) else 0

    def _joint(self, X: torch.Tensor, c: int):
        """Mean ``(..., b, N)`` and covariance ``(..., b, N, N)`` of f at X (standardised).

        The t-batch of X is folded into the columns (one triangular solve per output,
        not one per batch element: torch would copy L for every element).
        """
        b, batch = self._num_outputs, X.shape[:-2]
        Xn = self._transform(X)                                          # (..., N, d)
        rows = Xn[..., c:, :]
        r, d = rows.shape[-2], rows.shape[-1]
        flat = rows.reshape(-1, d)                                       # (B r, d)
        K = self._kernel.forward(self._Xt, flat.expand(b, -1, -1))        # (b, n, B r)
        # L^-1 K by a triangular solve: it reads half of what L^-1 @ K reads (the
        # product is memory-bound), 2-3.6x faster forwards + backwards at n = 300-697
        V = torch.linalg.solve_triangular(self._L, K, upper=False)        # (b, n, B r)
        mean = self._const + (K.mT @ self._alpha).squeeze(-1)            # (b, B r)
        n, B = V.shape[1], batch.numel()                                 # B = 1 if no batch
        Vb = V.reshape(b, n, B, r).permute(2, 0, 3, 1)                   # (B, b, r, n)
        rows_b = rows.reshape(-1, 1, r, d).expand(-1, b, r, d)           # (B, b, r, d)
        C_rr = self._kernel.forward(rows_b, rows_b) - Vb @ Vb.mT         # (B, b, r, r)
        mean = mean.reshape(b, -1, r).transpose(0, 1)                    # (B, b, r)
        unfold = (*batch, b)
        if c == 0:
            mean, C_rr = mean.reshape(*unfold, r), C_rr.reshape(*unfold, r, r)
            if X.dim() == 2 and not X.requires_grad:
                self._known = (X.detach().clone(), Xn.detach(), V.detach(),
                               mean.detach(), C_rr.detach())
            return mean, C_rr
        Z, Zn, Vz, mean_z, C_zz = self._known
        Kz = self._kernel.forward(Zn.expand(b, -1, -1), flat.expand(b, -1, -1))  # (b, c, B r)
        C_zr = Kz - Vz.mT @ V                                            # (b, c, B r)
        C_rz = C_zr.reshape(b, c, -1, r).permute(2, 0, 3, 1)             # (B, b, r, c)
        mean = torch.cat([mean_z.reshape(1, b, c).expand(B, -1, -1), mean], dim=-1)
        mean = mean.reshape(*unfold, c + r)
        C_rz, C_rr = C_rz.reshape(*unfold, r, c), C_rr.reshape(*unfold, r, r)
        if X.dim() == 2 and not X.requires_grad:  # extend the remembered points
            cov = torch.cat([torch.cat([C_zz, C_rz.mT], -1), torch.cat([C_rz, C_rr], -1)], -2)
            self._known = (X.detach().clone(), Xn.detach(), torch.cat([Vz, V], -1).detach(),
                           mean.detach(), cov.detach())
            return mean, cov
        return mean, JointCovariance(C_zz.expand(*unfold, c, c), C_rz, C_rr)


class JointCovariance(LinearOperator):
    """Symmetric ``[[C_zz, C_rz^T], [C_rz, C_rr]]`` whose trailing rows are cheap to read.

    ``self[..., -k:, :]`` with k <= r returns those rows of ``[C_rz, C_rr]`` without
    assembling the matrix; everything else works on the assembled dense matrix.
    """

    def __init__(self, C_zz: torch.Tensor, C_rz: torch.Tensor, C_rr: torch.Tensor) -> None:
        super().__init__(C_zz, C_rz, C_rr)
        self.C_zz, self.C_rz, self.C_rr = C_zz, C_rz, C_rr

    def scaled(self, s: torch.Tensor) -> JointCovariance:
        return JointCovariance(self.C_zz * s, self.C_rz * s, self.C_rr * s)

    def _size(self) -> torch.Size:
        n = self.C_zz.shape[-1] + self.C_rr.shape[-1]
        return torch.Size((*self.C_rr.shape[:-2], n, n))

    def _transpose_nonbatch(self) -> JointCovariance:
        return self

    def to_dense(self) -> torch.Tensor:
        top = torch.cat([self.C_zz, self.C_rz.mT], dim=-1)
        bottom = torch.cat([self.C_rz, self.C_rr], dim=-1)
        return torch.cat([top, bottom], dim=-2)

    def _matmul(self, rhs: torch.Tensor) -> torch.Tensor:
        return self.to_dense() @ rhs

    def _getitem(self, row_index, col_index, *batch_indices):
        c, n = self.C_zz.shape[-1], self._size()[-1]
        noop = slice(None, None, None)
        if isinstance(row_index, slice) and col_index == noop and row_index.step is None \
                and all(i == noop for i in batch_indices):
            start = row_index.start or 0
            start = start + n if start < 0 else start
            stop = n if row_index.stop is None else row_index.stop
            stop = stop + n if stop < 0 else stop
            if c <= start <= stop <= n:
                rows = torch.cat([self.C_rz, self.C_rr], dim=-1)
                return DenseLinearOperator(rows[..., start - c:stop - c, :])
        return DenseLinearOperator(self.to_dense())._getitem(row_index, col_index,
                                                             *batch_indices)
