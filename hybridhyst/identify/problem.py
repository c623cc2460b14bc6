"""``RecordsProblem``: records grouped by time grid, with batched predictions, costs and exact Jacobians of a
``SearchSpace``'s population (what every search and refinement of ``identify`` evaluates)."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from ..data.batch import record_batches
from ..data.records import Record
from ..physics.effects.base import signals
from ..physics.parameters import Constant
from ..simulate import Prepared, SimulationSettings, jacobian_covers, row_jacobian
from ..simulate.inputs import with_rates
from .search import safe_costs
from .space import SearchSpace

__all__ = ["RecordsProblem", "culprits"]


class RecordsProblem:
    """Records grouped by length (``data.batch``: every record on its own time grid), with batched
    predictions and costs for a ``SearchSpace``.

    Parameters
    ----------
    space : the model's search space; records : the data (each record's first ``warmup`` samples simulated, not
        scored); input_channels : channels driving the model.
    settings : how the model is simulated (default ``SimulationSettings()``: compiled, RK4, one sub-step);
        ``method``, ``substeps``, ``backend`` where given override it.
    """

    def __init__(self, space: SearchSpace, records: Sequence[Record], input_channels=("x",),
                 settings: SimulationSettings | None = None, *, method: str | None = None,
                 substeps: int | None = None, backend: str | None = None):
        self.space, self.records = space, list(records)
        self.sim = SimulationSettings.of(settings, method=method, substeps=substeps, backend=backend)
        dtype = next(iter(space.model.parameters()), torch.zeros((), dtype=torch.float64)).dtype
        # the input rates once (finite differences), not at every cost evaluation
        # a group's records on one grid keep one (time,) row of it: the simulator would find that again at every
        # call (rates are taken on the grid as given, as before)
        self.groups = [(b.index, b.t[0] if bool((b.t == b.t[:1]).all()) else b.t, with_rates(b.inputs, b.t), b.y,
                        b.conditions) for b in record_batches(self.records, input_channels, dtype)]
        # each record's first ``warmup`` samples are simulated, not scored: per group, which samples are scored
        # ``(R, T)`` and their flat indices (record-major); None where every sample is (no copy)
        self._masks = [_scored_mask([self.records[j].warmup for j in g[0]], g[3].shape[1]) for g in self.groups]
        self._scored = [None if m is None else m.reshape(-1).nonzero().reshape(-1) for m in self._masks]
        self.n_samples = sum(len(r) - r.warmup for r in self.records)  # the scored samples
        self.y_flat = torch.cat([_select(g[3].reshape(1, -1), keep)[0] for g, keep in zip(self.groups, self._scored)])
        self._prepared: dict[int, Prepared] = {}  # per group: its inputs for the largest population yet

    def _batch(self, X: torch.Tensor, i: int) -> tuple[Prepared, dict]:
        """Time-grid group ``i``'s inputs prepared for the population ``X (N, D)`` (``simulate.Prepared``) and each
        row's parameter values: member n at record r is batch row n·R + r, with its values at record r's
        conditions."""
        _, t, U, _, cond = self.groups[i]
        N, R = X.shape[0], U.shape[0]
        # the inputs repeated and prepared once for the largest population yet (every LM iteration asks again):
        # a smaller one's are a leading slice of them
        prepared = self._prepared.get(i)
        if prepared is None or prepared.batch < N * R:
            prepared = self._prepared[i] = Prepared(
                self.space.model, U.repeat(N, 1, 1), t.repeat(N, 1) if t.ndim == 2 else t,
                conditions={k: v.repeat(N, *[1] * (v.ndim - 1)) for k, v in cond.items()} or None,  # networks,
                settings=self.sim)  # controls
        if prepared.batch > N * R:
            prepared = prepared.rows(N * R)
        return prepared, self.space.values(X.to(U.dtype), cond, R)

    def predict_groups(self, X: torch.Tensor) -> list[torch.Tensor]:
        """Responses ``(N, R_g, T_g)`` of each time-grid group for the population ``X (N, D)``."""
        out = []
        for i, group in enumerate(self.groups):
            prepared, values = self._batch(X, i)
            y = prepared.simulate(values)
            out.append(y[..., 0].reshape(X.shape[0], group[2].shape[0], -1))
        return out

    def predict(self, X: torch.Tensor) -> torch.Tensor:
        """The scored responses flattened, ``(N, M)`` with M the number of scored samples (``n_samples``: each
        record's samples after its ``warmup``)."""
        return torch.cat([_select(p.reshape(p.shape[0], -1), keep) for p, keep in
                          zip(self.predict_groups(X), self._scored)], dim=1)

    def record_mse(self, X: torch.Tensor) -> torch.Tensor:
        """Mean squared error over each record's scored samples ``(N, records)``, columns in the records' order."""
        out = torch.empty(X.shape[0], len(self.records), dtype=torch.float64)
        for (idx, _, _, Y, _), pred, mask in zip(self.groups, self.predict_groups(X), self._masks):
            sq = (pred - Y[None]).square()
            if mask is None:
                out[:, idx] = sq.mean(dim=2).to(torch.float64)
            else:
                mask = mask.to(sq.device)
                out[:, idx] = (sq.where(mask, 0.0).sum(dim=2) / mask.sum(dim=1)).to(torch.float64)
        return out

    def residuals(self, X: torch.Tensor) -> torch.Tensor:
        """Model minus measured response at the scored samples, flattened, ``(N, M)``."""
        return self.predict(X) - self.y_flat.to(X.dtype)[None]

    @property
    def jacobian_rows(self):
        """``(X (N, D), free (D,) booleans) -> (residuals (N, M), Jacobian (N, M, F))`` w.r.t. the F free
        coordinates, exact: the compiled loop's forward sensitivities w.r.t. the parameter values
        (``simulate_jacobian``, one pass where finite differences take one simulation per coordinate) times
        the parameter functions' derivatives w.r.t. the coordinates (reverse mode). None where the
        sensitivities do not cover the model (the reference backend, networks): then
        Levenberg–Marquardt takes finite differences."""
        if self.sim.backend != "fast" or not jacobian_covers(self.space.model):
            return None
        return self._jacobian

    def _value_jacobian(self, X: torch.Tensor, idx: list[int], cond, R: int) -> dict:
        """``{effect: {parameter: (N·R, F)}}``: each row's parameter values differentiated w.r.t. the free
        coordinates ``idx``: a constant's is its coordinate's unit column (written directly), the other functions'
        come from reverse mode (``simulate.api.row_jacobian``)."""
        N, F = X.shape[0], len(idx)
        out: dict[str, dict] = {}
        follow = signals(cond)
        rest, names, columns = [], [], []  # the other functions; their values (effect, name) and the coordinates
        # each reads (a function of a control gives one value per coordinate)
        for (k, n), fn in self.space.functions.items():
            cols = self.space.columns[(k, n)]
            if not cols:  # no coordinates (a fixed value): no derivatives
                out.setdefault(k, {})[n] = X.new_zeros(N * R, F)
            elif type(fn).evaluate_batch is Constant.evaluate_batch and fn.condition not in follow:
                # a constant (constrained ones are parametrized subclasses): its value is its coordinate, a unit column
                out.setdefault(k, {})[n] = d = X.new_zeros(N * R, F)
                if cols[0] in idx:
                    d[:, idx.index(cols[0])] = 1.0
            elif fn.condition in follow:
                rest.append((k, n))
                names += [(k, n + s) for s in fn.suffixes()]
                columns += [[j] if j is not None else [] for j in cols]
            else:
                rest.append((k, n))
                names.append((k, n))
                columns.append([j for j in cols if j is not None])
        if not rest:
            return out
        # member n's row repeated for each record (row m = n·R + r), every row evaluated at every record's condition
        # and the value at its own record kept (flat index m·R + r): it depends on that row alone, as
        # ``row_jacobian`` needs; each coordinate is one value's, so one pass gives all
        m = torch.arange(N * R)
        own = m * R + m % R

        def kept(x: torch.Tensor) -> list[torch.Tensor]:
            values = self.space.values(x, cond, R, only=rest)
            return [values[k][n].reshape(-1)[own] for k, n in names]

        _, jac = row_jacobian(kept, X.repeat_interleave(R, 0), columns)  # (N·R, values, D)
        for i, (k, n) in enumerate(names):
            out.setdefault(k, {})[n] = jac[:, i, idx]
        return out

    def _jacobian(self, X: torch.Tensor, free: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        idx = torch.nonzero(torch.as_tensor(free, dtype=torch.bool)).reshape(-1).tolist()
        res, jac = [], []
        for i, (_, _, U, Y, cond) in enumerate(self.groups):
            N, R = X.shape[0], U.shape[0]
            Xd = X.detach().to(U.dtype)
            dvalues = self._value_jacobian(Xd, idx, cond, R)
            prepared, values = self._batch(Xd, i)
            # only the parameters a free coordinate moves (not a held or fixed one's) go through the loop's tangent
            needed = {(k, n) for k, d in dvalues.items() for n, v in d.items() if bool(v.ne(0).any())}
            y, dy, keys = prepared.jacobian(values, needed=needed)
            dvdx = torch.stack([dvalues[k][n] for k, n in keys], dim=1)  # (N·R, parameters, F)
            res.append(_select((y[..., 0].reshape(N, R, -1) - Y[None]).reshape(N, -1), self._scored[i]))
            jac.append(_select(_chain(dy[..., 0, :], dvdx).reshape(N, -1, len(idx)), self._scored[i]))
        if len(self.groups) == 1:  # no copy of the Jacobian to join the groups
            return res[0].to(torch.float64), jac[0].to(torch.float64)
        return torch.cat(res, dim=1).to(torch.float64), torch.cat(jac, dim=1).to(torch.float64)

    def cost(self, X: torch.Tensor) -> torch.Tensor:
        """Pooled MSE over the scored samples of every record, ``(N,)`` (differentiable)."""
        sse = 0.0
        for (_, _, _, Y, _), pred, keep in zip(self.groups, self.predict_groups(X), self._scored):
            sse = sse + _select((pred - Y[None]).reshape(pred.shape[0], -1), keep).square().sum(dim=1)
        return sse / self.n_samples


def _scored_mask(warmups: list[int], T: int) -> torch.Tensor | None:
    """``(records, T)``: true at the samples after each record's warm-up; None where no record has one."""
    if not any(warmups):
        return None
    return torch.arange(T)[None, :] >= torch.tensor(warmups)[:, None]


def _select(x: torch.Tensor, keep: torch.Tensor | None) -> torch.Tensor:
    """``x (N, M, ...)``'s samples ``keep`` along dimension 1 (all of them, uncopied, for None)."""
    return x if keep is None else x.index_select(1, keep.to(x.device))


def _chain(dy: torch.Tensor, dvdx: torch.Tensor) -> torch.Tensor:
    """``dy @ dvdx``: responses' derivatives ``(B, T, P)`` w.r.t. the parameter values, times the values'
    derivatives ``(B, P, F)`` w.r.t. the free coordinates. Where every free coordinate is one parameter's value (the
    same 0/1 selection in every row: constants only) and every derivative is finite, the product is those columns
    of ``dy``, taken as they are (the same values, up to the sign of a zero; half the time of the batched product).
    A non-finite derivative takes the product, which spreads it as NaN over its sample's other columns
    (inf · 0), as the fits' and the Fisher analysis's checks expect; the columns of parameters no free coordinate
    moves are not computed (``Prepared.jacobian(needed=)``: exactly 0), so only a needed one can spread."""
    first = dvdx[0]
    if (bool(((first == 0) | (first == 1)).all()) and bool((first.sum(dim=0) == 1).all())
            and torch.equal(dvdx, first.expand_as(dvdx)) and bool(torch.isfinite(dy.sum()))):
        pick = first.argmax(dim=0)
        if pick.shape[0] == dy.shape[-1] and torch.equal(pick, torch.arange(pick.shape[0], device=pick.device)):
            return dy  # every parameter's own column, in order
        return dy.index_select(-1, pick)
    return dy @ dvdx


def culprits(problem: RecordsProblem, x: torch.Tensor) -> list[str]:
    """Coordinates whose reset alone (to the starting value or the box centre) makes a non-finite fit finite.

    One batched evaluation of 2 D rows; if no single reset helps, every coordinate is named.
    """
    space = problem.space
    centre = space.from_unit(torch.full((1, space.dim), 0.5, dtype=torch.float64))[0]
    start = torch.tensor([c.value for c in space.coordinates], dtype=torch.float64)
    diag = torch.arange(space.dim)
    X = x.expand(2 * space.dim, -1).clone()
    X[diag, diag] = start
    X[space.dim + diag, diag] = centre
    finite = torch.isfinite(safe_costs(problem.cost, X)).reshape(2, space.dim).any(dim=0)
    names = [n for n, ok in zip(space.names, finite.tolist()) if ok]
    return names or space.names
