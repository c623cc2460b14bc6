"""Seed 000 as a study: the 4-parameter VPPTD model identified per underpressure by seed 000's "PINN".

Model (seed 000, eq. 1): M = c·φ̇ + k·φ + k₂·φ³ + M_s·sgn(φ̇), φ [deg], φ̇ [rad/s] (docs/units.md),
M [Nm]; ``hybridhyst.physics.compositions.vpptd_algebraic``. Data: 1:3-mixture loops (±10°, 0.79 Hz) of
the seed 001 modified Bouc–Wen model (``load_vpptd``), so the 4-parameter model has a model-error floor.

The "PINN" is seed 000's recipe on ``training.PhysicsModule``: the four parameters are softplus of raw
values (eq. 2), re-initialised at max(N(0, 0.1), 1e-6) (``init_noise``), and trained full batch with Adam
at lr 0.01 on the raw values for 2000 epochs on MAE + 0.01·Σ|p − p_init| (eq. 3; ``conf/loss/seed000``).
Each pressure is trained on its own (its own random initialisation), in a plain loop over the module's own
``training_step``: the Lightning optimiser scales the nominal step by max(|raw|, 1), which is not seed 000's
Adam. ``identify.identify`` (CMA-ES + batched Levenberg–Marquardt, least squares) fits the same model to
the same records for comparison; its RMSE is the model-error floor.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import replace

import numpy as np
import pandas as pd
import torch

from ..analysis import mae, r2, rmse
from ..data.datamodule import RecordDataModule
from ..identify import identify
from ..physics.compositions.seed000 import SEED000_QUOTED, vpptd_algebraic
from ..physics.parameters import Constant
from ..progress import progress as progress_bar
from ..report.figures import draw_loops
from ..simulate import simulate
from ..synth import load_vpptd
from ..training.modules import PhysicsModule
from . import resolve_options
from .output import StudyOutput

__all__ = ["PARAMS", "pinn_identification", "softplus_model"]

# seed 000's symbol -> (effect, parameter) of vpptd_algebraic, and its unit (φ̇ in rad/s)
PARAMS = {"c": ("viscous", "c"), "k": ("stiffness", "k"), "k2": ("cubic", "k3"), "Ms": ("friction", "Fc")}
UNITS = {"c": "Nm·s/rad", "k": "Nm/deg", "k2": "Nm/deg³", "Ms": "Nm"}
LABELS = {"c": "c [Nm·s/rad]", "k": "k [Nm/deg]", "k2": "k₂ [Nm/deg³]", "Ms": "M_s [Nm]"}
# Seed 000's text (Results, Fig. 8 discussion): (parameter, underpressure [MPa], value). c is printed in
# Nm·s/deg and read in Nm·s/rad (docs/units.md); M_s is "over 15 Nm" at 0.08 MPa. SEED000_QUOTED (the
# composition) files the upper-end values under 0.09 MPa and k₂ = 0.0055 at both ends.
TEXT_QUOTES = [("c", 0.01, 6.7), ("c", 0.07, 8.3), ("k", 0.01, 0.65), ("k", 0.08, 1.65), ("k2", 0.08, 0.0055),
               ("k2", 0.09, 0.0145), ("Ms", 0.01, 9.5), ("Ms", 0.08, 15.0)]
REQUIRED = ("loss", "mixture", "pressures", "cycles", "samples_per_cycle", "epochs", "lr", "snapshot_epochs",
            "loop_pressures", "identify")


def softplus_model() -> torch.nn.Module:
    """``vpptd_algebraic`` with seed 000's softplus on all four parameters (eq. 2).

    The composition stores c, k, M_s unconstrained (``nonnegative``, projected) and k₂ as ``real``; seed 000
    maps every raw value through softplus, so each is replaced by a ``Positive`` constant and declared
    positive (which also lets ``PhysicsModule(init_noise=...)`` re-initialise all four).
    """
    model = vpptd_algebraic().double()
    for effect, pname in PARAMS.values():
        e = model.effects[effect]
        spec = replace(e.param_specs[pname], constraint="positive", bounds=(0.0, e.param_specs[pname].bounds[1]))
        e.param_specs[pname] = spec
        e.params[pname] = Constant(float(e.params[pname].value.detach()), spec).double()
    return model


def _options(options: dict) -> dict:
    opts = resolve_options(options, REQUIRED, "vpptd_pinn_identification")
    if int(opts["epochs"]) < 1 or float(opts["lr"]) <= 0:
        raise ValueError(f"seed000 study: need epochs >= 1 and lr > 0, got {opts['epochs']} and {opts['lr']}")
    bad = [e for e in opts["snapshot_epochs"] if not 1 <= int(e) <= int(opts["epochs"])]
    if bad:
        raise ValueError(f"seed000 study: snapshot_epochs {bad} outside 1..{opts['epochs']}")
    if not set(opts["loop_pressures"]) & set(opts["pressures"]):
        raise ValueError(f"seed000 study: loop_pressures {opts['loop_pressures']} has none of the pressures "
                         f"{opts['pressures']}")
    if set(opts["identify"]["bounds"]) != set(PARAMS):
        raise ValueError(f"seed000 study: identify.bounds must give {sorted(PARAMS)}, got "
                         f"{sorted(opts['identify']['bounds'])}")
    return opts


def _values(model) -> list[float]:
    P = model.evaluate(None, 1)
    return [float(P[e][p][0].detach()) for e, p in PARAMS.values()]


def _predict(model, record) -> np.ndarray:
    """Torque [Nm] of ``model`` along the record's angle (the same ``simulate`` call for both methods)."""
    with torch.no_grad():
        y = simulate(model, torch.as_tensor(record.x)[None], t=torch.as_tensor(record.t))
    return y[0, :, 0].numpy()


def _train_pinn(record, opts: dict, seed: int) -> dict:
    """Seed 000's recipe at one pressure: parameter values per epoch (epoch 0 = initial), loss per epoch,
    torque after each snapshot epoch, final model and wall time [s]."""
    loss = opts["loss"]
    dm = RecordDataModule([record], window=None, batch_size=1)
    batch = next(iter(dm.train_dataloader()))
    torch.manual_seed(seed)  # PhysicsModule draws its initial values from the torch seed
    module = PhysicsModule(softplus_model(), dm.normaliser.to_dict(), init_noise=loss["init_noise"],
                           prior_weight=loss["prior_weight"], prior_kind=loss["prior_kind"], loss=loss["kind"],
                           normalise_loss=loss["normalise"], units=dm.units)
    optimiser = torch.optim.Adam(module.nominal.parameters(), lr=float(opts["lr"]))
    values, losses, loops = [_values(module.nominal)], [], {}
    snapshots = {int(e) for e in opts["snapshot_epochs"]}
    start = time.perf_counter()
    with warnings.catch_warnings():  # training_step logs; there is no Trainer to log to here
        warnings.filterwarnings("ignore", message=".*self.trainer.*")
        for epoch in range(1, int(opts["epochs"]) + 1):
            optimiser.zero_grad()
            step_loss = module.training_step(batch, 0)
            step_loss.backward()
            optimiser.step()
            losses.append(float(step_loss.detach()))
            values.append(_values(module.nominal))
            if epoch in snapshots:
                loops[epoch] = _predict(module.nominal, record)
    wall = time.perf_counter() - start
    return {"values": np.array(values), "loss": np.array(losses), "loops": loops, "model": module.nominal,
            "wall_s": wall, "simulated": int(opts["epochs"])}


def _identify(record, opts: dict, seed: int) -> dict:
    """``identify.identify`` of the same model on the same record (least squares)."""
    cfg = opts["identify"]
    bounds = {f"{e}.{p}": tuple(cfg["bounds"][name]) for name, (e, p) in PARAMS.items()}
    model = softplus_model()
    res = identify(model, record, search=cfg["search"], pop=int(cfg["pop"]), generations=int(cfg["generations"]),
                   rounds=int(cfg["rounds"]), bounds=bounds, fisher=False, seed=seed, progress=False)
    return {"model": model, "wall_s": res.wall_s, "simulated": res.evaluations}


def _fit_row(p, method, record, fit, per_cycle: int) -> dict:
    """Final parameters, RMSE/MAE over the record and peak torque over its last cycle."""
    y = _predict(fit["model"], record)
    last = slice(-per_cycle - 1, None)
    return {"p [MPa]": p, "method": method, **dict(zip(PARAMS, _values(fit["model"]))),
            "RMSE [Nm]": rmse(y, record.y), "MAE [Nm]": mae(y, record.y),
            "peak model [Nm]": float(np.abs(y[last]).max()), "peak data [Nm]": float(np.abs(record.y[last]).max()),
            "wall [s]": fit["wall_s"], "loops simulated": fit["simulated"]}


def _linear_fits(final: pd.DataFrame) -> pd.DataFrame:
    """Least-squares line p ↦ slope·p + intercept of each final parameter against pressure, with R²."""
    rows = []
    for method, group in final.groupby("method", sort=False):
        p = group["p [MPa]"].to_numpy()
        for name in PARAMS:
            v = group[name].to_numpy()
            slope, intercept = np.polyfit(p, v, 1) if len(p) > 1 else (math.nan, float(v[0]))
            rows.append({"method": method, "parameter": name, "unit": UNITS[name], "slope [unit/MPa]": slope,
                         "intercept [unit]": intercept,
                         "R²": r2(slope * p + intercept, v) if len(p) > 2 else math.nan})
    return pd.DataFrame(rows)


def _quoted(final: pd.DataFrame) -> pd.DataFrame:
    """Seed 000's quoted values beside both fits at the pressure each is quoted at (— where not run)."""
    rows = []
    for name, p, value in TEXT_QUOTES:
        at = final[np.isclose(final["p [MPa]"], p)].set_index("method")
        rows.append({"parameter": name, "unit": UNITS[name], "p [MPa]": p, "seed 000 text": value,
                     **{m: (at.loc[m, name] if m in at.index else math.nan) for m in ("PINN", "identify")}})
    return pd.DataFrame(rows)


def _units_check() -> pd.DataFrame:
    """Peak torque of seed 000's quoted parameters on a ±10°, 0.8 Hz loop under both velocity readings."""
    t = np.arange(2 * 1000 + 1) / (1000 * 0.8)
    rec_x = torch.as_tensor(10.0 * np.sin(2 * math.pi * 0.8 * t))[None]
    rows = []
    for q, vals in SEED000_QUOTED.items():
        row = {"p [MPa]": q, "seed 000 text [Nm]": "just over 20" if q < 0.05 else "about 40"}
        for unit in ("rad/s", "deg/s"):
            model = vpptd_algebraic(**vals, velocity_unit=unit).double()
            with torch.no_grad():
                y = simulate(model, rec_x, t=torch.as_tensor(t))
            row[f"peak, φ̇ in {unit} [Nm]"] = float(y.abs().max())
        rows.append(row)
    return pd.DataFrame(rows)


def _milestones(pressures, pinn, epochs) -> pd.DataFrame:
    """PINN parameters at epoch 0 (initial) and after each snapshot epoch, with that epoch's loss."""
    rows = []
    for p, run in zip(pressures, pinn):
        for e in [0, *epochs]:
            loss = run["loss"][e - 1] if e > 0 else math.nan
            rows.append({"p [MPa]": p, "epoch": e, **dict(zip(PARAMS, run["values"][e])), "loss [Nm]": loss})
    return pd.DataFrame(rows)


def pinn_identification(options: dict, out: StudyOutput) -> dict:
    """Run the study (options: ``conf/experiment/vpptd_pinn_identification.yaml``); returns the summary."""
    opts = _options(options)
    pressures = [float(p) for p in opts["pressures"]]
    records = load_vpptd(mixtures=[opts["mixture"]], pressures=pressures, cycles=int(opts["cycles"]),
                         samples_per_cycle=int(opts["samples_per_cycle"]))
    seeds = [int(opts["seed"]) * 1000 + round(p * 100) for p in pressures]  # a pressure's init never changes
    bar = progress_bar(list(zip(records, seeds)), "seed 000 PINN", enabled=opts["progress"])
    pinn = [_train_pinn(r, opts, s) for r, s in bar]
    ident = [_identify(r, opts, s) for r, s in zip(records, seeds)]
    per_cycle = int(opts["samples_per_cycle"])
    final = pd.DataFrame([_fit_row(p, m, r, f, per_cycle) for p, r, a, b in zip(pressures, records, pinn, ident)
                          for m, f in (("PINN", a), ("identify", b))])
    return _report(out, opts, pressures, records, pinn, ident, final)


def _report(out, opts, pressures, records, pinn, ident, final) -> dict:
    epochs = sorted(int(e) for e in opts["snapshot_epochs"])
    fits, quoted = _linear_fits(final), _quoted(final)
    floor = final[final["method"] == "identify"]
    out.text(f"Data: {len(records)} loops of the {opts['mixture']} mixture from the seed 001 model "
             f"({len(records[0])} samples each); PINN: {opts['epochs']} full-batch epochs of Adam "
             f"(lr {opts['lr']}), MAE + {opts['loss']['prior_weight']}·Σ|p − p_init|, "
             f"init max(N(0, {opts['loss']['init_noise']}), 1e-6). Parameter units: c [Nm·s/rad] (φ̇ in rad/s), "
             "k [Nm/deg], k2 [Nm/deg³], Ms [Nm].")
    out.table("fits", final, "Final parameters, error and cost per pressure: seed 000's PINN recipe vs "
              "hybridhyst.identify (peak torque over the last cycle; loops simulated: epochs, resp. population "
              "rows of the search and refinement)")
    out.text(f"Model-error floor (least-squares optimum of the 4-parameter model on Bouc–Wen data, "
             f"identify): RMSE {floor['RMSE [Nm]'].min():.3g}–{floor['RMSE [Nm]'].max():.3g} Nm, "
             f"{100 * (floor['RMSE [Nm]'] / floor['peak data [Nm]']).max():.2g} % of the peak torque at most.")
    out.table("linear_fits", fits, "Final parameters against pressure: least-squares lines")
    out.table("quoted", quoted, "Seed 000's quoted values (text, Fig. 8 discussion) beside both fits at the "
              "same pressure")
    out.table("units_check", _units_check(), "Units reading: seed 000's quoted parameters on a ±10°, 0.8 Hz loop")
    out.table("milestones", _milestones(pressures, pinn, epochs), "PINN parameters and loss at the snapshot "
              "epochs (epoch 0: the random initial values)")
    out.figure("trajectories", _fig_trajectories(pressures, pinn), "Parameters and loss per epoch (PINN)")
    out.figure("loop_evolution", _fig_loop_evolution(pressures, records, pinn, opts["loop_pressures"], epochs),
               "Loops after the snapshot epochs (PINN) against the data")
    out.figure("parameters_vs_pressure", _fig_parameters(final, fits),
               "Final parameters against pressure with linear fits; crosses: seed 000's quoted values")
    out.figure("final_loops", _fig_final_loops(pressures, records, pinn, ident, int(opts["samples_per_cycle"])),
               "Last cycle of each loop: data, PINN after the last epoch, identify")
    return _summary(final, fits, floor)


def _summary(final, fits, floor) -> dict:
    summary = {"model_error_floor_rmse_nm": [float(floor["RMSE [Nm]"].min()), float(floor["RMSE [Nm]"].max())]}
    for method, group in final.groupby("method", sort=False):
        summary[method] = {col: [float(v) for v in group[col]] for col in
                           ["p [MPa]", *PARAMS, "RMSE [Nm]", "MAE [Nm]", "peak model [Nm]", "peak data [Nm]",
                            "wall [s]"]}
        summary[method]["linear_fits"] = {r["parameter"]: {"slope": float(r["slope [unit/MPa]"]),
                                                           "intercept": float(r["intercept [unit]"]),
                                                           "r2": float(r["R²"])}
                                          for _, r in fits[fits["method"] == method].iterrows()}
    return summary


# -- figures -----------------------------------------------------------------------------------------------
def _colours(n: int):
    import matplotlib.pyplot as plt

    return plt.cm.viridis(np.linspace(0.0, 0.9, n))


def _fig_trajectories(pressures, pinn):
    """c, k, k₂, M_s and the loss per epoch, one line per pressure (seed 000 Figs. 5, 9-13)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(9.5, 5), constrained_layout=True)
    for p, run, colour in zip(pressures, pinn, _colours(len(pressures))):
        for j in range(len(PARAMS)):
            axes.flat[j].plot(run["values"][:, j], color=colour, lw=1.2, label=f"{p:g} MPa")
        axes.flat[4].semilogy(np.arange(1, len(run["loss"]) + 1), run["loss"], color=colour, lw=1.2)
    for j, name in enumerate(PARAMS):
        axes.flat[j].set(xlabel="epoch", ylabel=LABELS[name])
    axes.flat[4].set(xlabel="epoch", ylabel="loss [Nm]")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    axes.flat[5].axis("off")
    axes.flat[5].legend(handles, labels, loc="center", title="underpressure", ncol=2)
    return fig


def _fig_loop_evolution(pressures, records, pinn, loop_pressures, epochs):
    """Torque–angle loops after the snapshot epochs against the data (seed 000 Fig. 4)."""
    import matplotlib.pyplot as plt

    chosen = [i for i, p in enumerate(pressures) if any(math.isclose(p, q) for q in loop_pressures)]
    fig, axes = plt.subplots(1, len(chosen), figsize=(5 * len(chosen), 4), constrained_layout=True, squeeze=False)
    for ax, i in zip(axes[0], chosen):
        r = records[i]
        ax.plot(r.x, r.y, color="k", lw=2.5, alpha=0.35, label="data (seed 001 model)")
        for e, colour in zip(epochs, plt.cm.plasma(np.linspace(0.0, 0.8, len(epochs)))):
            ax.plot(r.x, pinn[i]["loops"][e], color=colour, lw=1.0, label=f"epoch {e}")
        ax.set(title=f"{pressures[i]:g} MPa", xlabel="φ [deg]", ylabel="M [Nm]")
    axes[0, 0].legend(fontsize=8)
    return fig


def _fig_parameters(final, fits):
    """Final parameters against pressure, both methods, with their lines and seed 000's quoted values."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(9, 6.5), constrained_layout=True)
    styles = {"PINN": ("o", "C0"), "identify": ("s", "C1")}
    for ax, name in zip(axes.flat, PARAMS):
        for method, group in final.groupby("method", sort=False):
            marker, colour = styles[method]
            p = group["p [MPa]"].to_numpy()
            ax.plot(p, group[name], marker, color=colour, label=method)
            line = fits[(fits["method"] == method) & (fits["parameter"] == name)].iloc[0]
            if np.isfinite(line["slope [unit/MPa]"]):
                ax.plot(p, line["slope [unit/MPa]"] * p + line["intercept [unit]"], "-", color=colour, lw=1)
        quotes = [(p, v) for n, p, v in TEXT_QUOTES if n == name]
        ax.plot(*zip(*quotes), "x", color="k", ms=8, mew=2, label="seed 000 (text)")
        ax.set(xlabel="underpressure p [MPa]", ylabel=LABELS[name])
    axes.flat[0].legend(fontsize=8)
    return fig


def _fig_final_loops(pressures, records, pinn, ident, per_cycle: int):
    """Last cycle at every pressure: data, the PINN's and identify's final models (seed 000 Fig. 7)."""
    last = [r.slice(-per_cycle - 1) for r in records]
    predictions = {name: [_predict(m["model"], r)[-per_cycle - 1:] for m, r in zip(models, records)]
                   for name, models in (("PINN", pinn), ("identify", ident))}
    return draw_loops(last, predictions, measured="data", styles={"identify": {"ls": "--"}})
