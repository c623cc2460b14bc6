"""Seed 003's Lightning runs: Hydra multiruns of ``hybridhyst-train``, read back with ``hybridhyst.report.collect``.

Every run is ``hybridhyst-train`` with ``conf/experiment/piezo_hybrid_pinn_training.yaml``, a baseline
preset and one of ``conf/sweep/*.yaml`` (``lambda_phys``, ``architectures``, ``data_fraction``), the swept values
and the training settings coming from the study's options. The study launches each multirun as a process of its
own (``python -m hybridhyst.cli.train -m ...``; studies do not import the apps) into one sweep folder, where a
run's folder is named by what tells the runs apart (baseline, network, λ_phys, seed, fraction): a run two tables
share is trained once, and a finished run of the same config is kept when the study runs again
(``skip_finished``), so an interrupted study resumes. Each multirun's output goes to ``<sweep folder>/<name>.log``.
"""

from __future__ import annotations

import hashlib
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from ..data import RecordSet
from ..files import atomic_write
from ..nets import parse_hidden
from ..report.collect import collect_runs

__all__ = ["EXPERIMENT", "TrainingRuns", "sweep_values", "write_sweeps"]

EXPERIMENT = "piezo_hybrid_pinn_training"
# the study's model kinds: the baseline preset (conf/baseline) each is trained with, and its name in metrics.json
BASELINES = {"hybrid": "hybrid_mlp", "mlp": "mlp", "lstm": "lstm", "std_pinn": "std_pinn",
             "hybrid_dynamics": "hybrid_dynamics"}
NAMES = {"hybrid": "hybrid-mlp", "mlp": "mlp", "lstm": "lstm", "std_pinn": "std-pinn",
         "hybrid_dynamics": "hybrid-dynamics"}


def write_sweeps(records: RecordSet, folder: Path) -> Path:
    """The sweeps as one long table (``RecordSet.to_frame``) that ``data=table`` reads back, named by a hash of
    its contents: a run's config then changes with the data, and ``skip_finished`` never keeps a run of other
    data."""
    frame = records.to_frame()
    digest = pd.util.hash_pandas_object(frame, index=False).to_numpy()
    path = Path(folder) / f"sweeps-{hashlib.sha1(digest.tobytes()).hexdigest()[:12]}.parquet"
    return atomic_write(path, lambda p: frame.to_parquet(p, index=False))


def _hydra(value) -> str:
    """``value`` in Hydra's override grammar (floats exactly, as ``repr``; strings quoted)."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_hydra(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_hydra(v) for v in value) + "]"
    if isinstance(value, bool) or value is None:
        return {True: "true", False: "false", None: "null"}[value]
    if isinstance(value, (int, float)):
        return repr(value)
    return "'" + str(value).replace("\\", "\\\\").replace("'", "\\'") + "'"


def sweep_values(values) -> str:
    """A sweep over ``values`` on the command line (``0.0,0.0001,0.001``); one value is a plain override."""
    return ",".join(_hydra(v) for v in values)


def _base_overrides(data_path: Path, nominal: dict, split: dict, t: dict) -> list[str]:
    """The overrides every run of the study shares: its data, identified nominal, split and training settings
    (``t``: the study's ``train:`` options)."""
    window = int(t["window"])
    params = [f"++model.params.{k}={_hydra(v)}" for k, v in nominal.items()]  # into the preset's empty params
    return [f"experiment={EXPERIMENT}", f"data.path={_hydra(str(data_path))}", *params,
            f"split.held_out={_hydra(split['test'])}", f"split.val={_hydra(split['val'])}",
            f"datamodule.window={window}", f"datamodule.stride={window}", f"datamodule.warmup={int(t['warmup'])}",
            f"datamodule.batch_size={int(t['batch_size'])}", f"simulation.substeps={int(t['substeps'])}",
            f"trainer.max_epochs={int(t['epochs'])}", f"trainer.lr={float(t['lr'])!r}"]


class TrainingRuns:
    """The study's runs in one sweep folder: ``launch`` a multirun, ``get`` a run's results for the tables.

    Parameters
    ----------
    folder : the sweep folder (``hydra.sweep.dir``).
    data_path : the sweeps written by ``write_sweeps``.
    nominal : the identified nominal as ``piezo_attenuation`` params (``model.params``).
    split : ``{"test": [queries], "val": [queries]}`` (``split.held_out``, ``split.val``).
    train : the study's ``train:`` options (epochs, batch_size, lr, window, warmup, substeps).
    """

    def __init__(self, folder: Path, data_path: Path, nominal: dict, split: dict, train: dict):
        self.folder = Path(folder)
        self.base = _base_overrides(data_path, nominal, split, train)
        self.table: pd.DataFrame | None = None
        self.used: dict[tuple, dict] = {}  # the runs the tables read, by (kind, hidden, λ_phys, seed, fraction)

    def launch(self, name: str, kind: str, *overrides: str, runs: list[tuple] | None = None) -> None:
        """Run ``hybridhyst-train -m`` with ``baseline=<kind's preset>`` (a comma-separated list of kinds sweeps
        them), the shared overrides and ``overrides`` (a sweep config and the swept values); then collect the
        folder. A failed run is a ``RuntimeError`` naming it and its error (the other runs are kept). ``runs``:
        the multirun's runs as ``get``'s keys (kind, hidden, λ_phys, seed, fraction); where the folder holds each
        of them already (an earlier multirun trained it), no process is started."""
        if runs and all(self._finished(*key) for key in runs):
            return
        baseline = ",".join(BASELINES[k] for k in kind.split(","))
        cmd = [sys.executable, "-m", "hybridhyst.cli.train", "-m", *self.base, f"baseline={baseline}", *overrides,
               f"hydra.sweep.dir={_hydra(str(self.folder))}"]
        log = self.folder / f"{name}.log"
        with open(log, "w", encoding="utf-8") as out:
            proc = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, text=True)
        try:
            self.table = collect_runs(self.folder)
        except ValueError:  # no run directory at all: the multirun failed before its first job
            self.table = None
        if proc.returncode or self.table is None:
            failed = self.table[self.table["status"] != "ok"] if self.table is not None else pd.DataFrame()
            errors = "; ".join(f"{Path(p).name}: {e}" for p, e in zip(failed.get("path", []), failed.get("error", [])))
            tail = log.read_text(encoding="utf-8")[-2000:]
            raise RuntimeError(f"seed003 training sweep {name!r} failed (exit {proc.returncode}, log {log}): "
                               f"{errors or tail}")

    def launch_hybrid(self, name: str, sweep: str, *, hidden, lambdas, seeds, fractions=(1.0,)) -> None:
        """``launch`` of the hybrid over the grid ``hidden`` × ``lambdas`` × ``seeds`` × ``fractions``: the
        command's swept values and the runs' keys come from the same lists (a run the folder holds already,
        trained by an earlier multirun, starts no process). Every list is given on the command line: a sweep
        config sweeps its own values of what it leaves out (``sweep=data_fraction``: five fractions)."""
        hidden, lambdas = list(hidden), [float(x) for x in lambdas]
        seeds, fractions = [int(x) for x in seeds], [float(x) for x in fractions]
        overrides = [f"sweep={sweep}", f"residual.hidden={sweep_values(hidden)}",
                     f"loss.lambda_phys={sweep_values(lambdas)}", f"seed={sweep_values(seeds)}",
                     f"datamodule.train_fraction={sweep_values(fractions)}"]
        self.launch(name, "hybrid", *overrides,
                    runs=[("hybrid", h, x, s, f) for h in hidden for x in lambdas for s in seeds for f in fractions])

    def get(self, kind: str, hidden=None, lambda_phys=None, seed: int = 0, fraction: float = 1.0) -> dict:
        """One run's results: held-out predictions (``test``: one dict per record with t, x, y, y_pred,
        y_nominal), validation RMSE, training time, size, windows and the last epoch's physics loss. ``hidden``
        and ``lambda_phys`` None: the preset's."""
        key = (kind, hidden, None if lambda_phys is None else float(lambda_phys), int(seed), float(fraction))
        if key not in self.used:
            self.used[key] = _result(self._row(*key))
        return self.used[key]

    def _finished(self, kind, hidden, lambda_phys, seed, fraction) -> bool:
        if self.table is None:
            return False
        try:
            self._row(kind, hidden, float(lambda_phys), int(seed), float(fraction))
        except RuntimeError:
            return False
        return True

    def _row(self, kind, hidden, lambda_phys, seed, fraction) -> pd.Series:
        t = self.table if self.table is not None else collect_runs(self.folder)
        match = (t["status"] == "ok") & (t["name"] == NAMES[kind]) & (t["seed"] == seed) & \
            np.isclose(t["train_fraction"].astype(float), fraction)
        if hidden is not None:
            match &= t["hidden"].map(lambda h: h == tuple(parse_hidden(hidden)))
        if lambda_phys is not None:
            match &= t["lambda_phys"].astype(float) == lambda_phys
        rows = t[match]
        if len(rows) != 1:
            raise RuntimeError(f"seed003: {len(rows)} finished runs of {NAMES[kind]} (hidden {hidden}, λ_phys "
                               f"{lambda_phys}, seed {seed}, fraction {fraction}) under {self.folder}; expected one "
                               f"(found: {list(rows['path'])})")
        return rows.iloc[0]


def _result(row: pd.Series) -> dict:
    """A collected run as the tables read it (predictions from its ``predictions.parquet``)."""
    frame = pd.read_parquet(row["predictions"])
    test = [{"record": str(name), **{c: g[c].to_numpy() for c in ("t", "x", "y", "y_pred", "y_nominal")}}
            for name, g in frame[frame["split"] == "test"].groupby("record", sort=False)]
    phys = row["logged"].get("train/phys_loss", math.nan)
    return {"test": test, "val": {"rmse": float(row["val_rmse"])}, "train_s": float(row["train_time_s"]),
            "n_windows": int(row["train_windows"]), "n_parameters": int(row["n_parameters"]),
            "hidden": row["hidden"], "phys_loss": float(phys) if phys is not None else math.nan}
