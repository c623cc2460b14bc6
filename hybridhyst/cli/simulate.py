"""``hybridhyst-simulate``: run a model config on an input and write its predictions and a summary.

Inputs (``input.kind``): ``sine`` (x = A sin 2πft), ``free_vibration`` (an oscillator released from
``input.initial_state`` with no drive) or ``data`` (the records of the ``data`` config). Seed-paper
studies (e.g. seed 001's Table 2) are run by ``hybridhyst-study`` (``hybridhyst.studies``).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import hydra
import numpy as np
import pandas as pd
import torch
from omegaconf import DictConfig

from ..analysis.finite import check_finite
from ..data.decimate import decimate
from ..data.records import Record
from ..physics.effects.base import ControlEffect
from ..simulate import simulate, simulate_resolved
from ..simulate.api import RESOLVED
from .common import (
    CONF_DIR,
    atomic_write,
    check_app,
    guarded,
    hydra_entry,
    instantiate,
    load_records,
    mark_complete,
    prepare_run_dir,
    say,
    to_plain,
    torch_settings,
    write_json,
)
from .settings import simulation_settings

__all__ = ["main", "run"]


def _output_names(model) -> list[str]:
    return list(getattr(model, "outputs", None) or ["force"])


def _sine(inp) -> tuple[np.ndarray, np.ndarray]:
    f, n = float(inp.frequency_hz), int(inp.samples_per_cycle)
    if f <= 0 or n < 4 or int(inp.cycles) < 1:
        raise ValueError(f"sine input needs frequency_hz > 0, samples_per_cycle >= 4 and cycles >= 1, got "
                         f"{f}, {n}, {inp.cycles}")
    t = np.arange(int(inp.cycles) * n + 1) / (f * n)
    return t, float(inp.amplitude) * np.sin(2 * np.pi * f * t)


def _signal_run(model, cfg) -> tuple[list[pd.DataFrame], dict]:
    """Simulate a generated signal (sine or free vibration); one record named after the input kind."""
    inp, kind = cfg.input, cfg.input.kind
    initial = None
    if kind == "sine":
        t, u = _sine(inp)
    else:
        if model.base_state_dim == 0:
            raise ValueError(f"free_vibration needs an oscillator model (structure: oscillator); "
                             f"{cfg.model.get('name', 'this model')!r} is constitutive: use input.kind=sine")
        n = round(float(inp.duration_s) / float(inp.dt)) + 1
        t, u = np.arange(n) * float(inp.dt), np.zeros(n)
        initial = torch.tensor([list(inp.initial_state)], dtype=torch.get_default_dtype())
    conditions = dict(to_plain(cfg.conditions) or {})
    for effect in model.effects.values():  # what acts on a control (a lag, a saturation) reads a signal: a level
        if isinstance(effect, ControlEffect) and effect.control in conditions:  # given in `conditions` is held
            conditions[effect.control] = np.full((1, len(t)), float(conditions[effect.control]))  # over the input
    signal = Record(name=kind, t=t, x=u, y=np.zeros_like(u), controls={k: v[0] for k, v in conditions.items()
                                                                       if np.ndim(v) == 2},
                    conditions={k: v for k, v in conditions.items() if np.ndim(v) != 2})
    (y,), resolution = _resolved(model, [signal], cfg, initial)
    y = y.cpu().numpy()
    frame = pd.DataFrame({"record": kind, "t": t, "input": u})
    for i, name in enumerate(_output_names(model)):
        frame[name] = y[:, i]
    info = {"samples": len(t), **resolution}
    if kind == "free_vibration" and "x" in frame:
        from ..analysis import free_vibration_frequency

        info["frequency_hz"] = free_vibration_frequency(frame["x"].to_numpy(), float(inp.dt))
    return [frame], {kind: info}


def _data_run(model, cfg) -> tuple[list[pd.DataFrame], dict]:
    """Simulate the records of ``cfg.data`` (decimated by ``input.downsample``); RMSE against y."""
    from ..analysis import rmse

    select = to_plain(cfg.input.select)  # a mapping {condition: value or [values]}, as split.select elsewhere
    downsample = int(cfg.input.downsample)
    records = [decimate(r, downsample) for r in load_records(cfg, select, where="input.select")]
    preds, resolution = _resolved(model, records, cfg)
    frames, info = [], {}
    for r, p in zip(records, preds):
        y = p.cpu().numpy()
        frame = pd.DataFrame({"record": r.name, "t": r.t, "input": r.x, **r.controls, "y": r.y})
        for i, name in enumerate(_output_names(model)):
            frame[name] = y[:, i]
        frames.append(frame)
        info[r.name] = {"samples": len(r), "rmse": rmse(r.scored(y[:, 0]), r.scored(r.y)), "unit": r.units.get("y"),
                        **resolution}
    return frames, info


def _resolved(model, records, cfg, initial=None) -> tuple[list, dict]:
    """``records`` simulated at the fewest sub-steps, from ``simulation.substeps`` up to ``max_substeps``, at
    which halving the step changes the response by at most 0.1 % (``resolve``: the check every app makes,
    ``simulate.simulate_resolved``), and ``{"substeps", "change"}``. A response no sub-step count resolves is an
    error naming the sub-steps tried (with ``keep_going`` a warning): a coarse grid can give a finite response that
    is the integrator's, not the model's; one that diverged at every count is left to ``_check_finite``."""
    sim = simulation_settings(cfg, "simulate")
    if not bool(cfg.get("resolve", True)):
        with torch.no_grad():
            return simulate(model, records, settings=sim, initial_state=initial), {
                "substeps": sim.substeps, "change": None}
    top = max(int(cfg.get("max_substeps", 64)), sim.substeps)
    out, substeps, change = simulate_resolved(model, records, settings=sim, max_substeps=top, initial_state=initial)
    finite = all(bool(torch.isfinite(y).all()) for y in out)  # a diverged record: _check_finite names it
    if finite and not change <= RESOLVED:
        text = (f"the response is not resolved: halving the step at {substeps} sub-steps per sample ("
                f"max_substeps={top}) still changes it by more than {RESOLVED:.1%}; sample finer (input.downsample) "
                "or raise max_substeps")
        if not bool(cfg.get("keep_going", False)):
            raise ValueError(text)
        say(f"warning: {text}", error=True)
    return out, {"substeps": substeps, "change": change if math.isfinite(change) else None}


def _check_finite(frames: list[pd.DataFrame], outputs: list[str], records: dict, cfg) -> list:
    """Which records diverged (non-finite output), from which sample: an error naming them (exit code 2), or
    with ``keep_going`` a warning, each record's entry in ``records`` marked (its RMSE and frequency are then
    null: nothing derived from a diverged run is reported as a value)."""
    unit = "s" if cfg.input.kind != "data" else (cfg.data.get("units") or {}).get("t", "s")
    diverged = check_finite([f[outputs].to_numpy() for f in frames], [str(f["record"].iloc[0]) for f in frames],
                            [f["t"].to_numpy() for f in frames], keep_going=bool(cfg.get("keep_going", False)),
                            hint="raise simulation.substeps (or sample finer) or check the model's parameters",
                            time_unit=unit, warn=lambda text: say(text, error=True))
    for d in diverged:
        records[d.record]["diverged"] = {"sample": d.sample, "t": d.t}
        for derived in ("frequency_hz", "rmse"):  # computed from a diverged response: not values
            if derived in records[d.record]:
                records[d.record][derived] = None
    return diverged


def run(cfg: DictConfig) -> dict:
    """Simulate and write ``summary.json`` and ``predictions.csv`` in the run dir."""
    check_app(cfg, "simulate")
    start = time.perf_counter()
    run_dir = prepare_run_dir(cfg)
    with torch_settings(cfg.dtype, cfg.get("threads"), cfg.get("seed")):
        kinds = {"sine": _signal_run, "free_vibration": _signal_run, "data": _data_run}
        if cfg.input.kind not in kinds:
            raise ValueError(f"unknown input.kind {cfg.input.kind!r}; choose one of {sorted(kinds)}")
        model = instantiate(cfg.model, _convert_="all")
        frames, records = kinds[cfg.input.kind](model, cfg)
        diverged = _check_finite(frames, _output_names(model), records, cfg)
        table = pd.concat(frames, ignore_index=True)
        atomic_write(run_dir / "predictions.csv", table.to_csv(index=False))
        summary = {"model": cfg.model.get("name") or model.name, "input": cfg.input.kind,
                   "outputs": _output_names(model), "records": records,
                   "diverged": [d.to_dict() for d in diverged]}
    summary["wall_s"] = time.perf_counter() - start
    write_json(run_dir / "summary.json", summary)
    mark_complete(run_dir, "simulate", ["config.yaml", "predictions.csv", "summary.json"])
    say("\n".join(summary_lines(summary, run_dir)))
    return summary


def summary_lines(summary: dict, run_dir) -> list[str]:
    """The terminal summary: what was simulated, each record's RMSE against its measured response (data) or the
    free vibration's frequency, and where the results are."""
    records = summary["records"]
    lines = [f"simulate: {summary['model']} on {summary['input']} input: {len(records)} record(s) "
             f"({summary['wall_s']:.3g} s)"]
    for name, info in records.items():
        parts = [f"{info['samples']} samples"] if "samples" in info else []
        parts += [f"RMSE {info['rmse']:.4g} {info.get('unit') or ''}".rstrip()] if info.get("rmse") is not None else []
        parts += [f"frequency {info['frequency_hz']:.4g} Hz"] if info.get("frequency_hz") is not None else []
        parts += ["diverged"] if info.get("diverged") else []
        if parts:
            lines.append(f"  {name}: {', '.join(parts)}")
    lines.append(f"  results: {Path(run_dir) / 'predictions.csv'}, {Path(run_dir) / 'summary.json'}")
    return lines


@hydra.main(config_path=CONF_DIR, config_name="simulate", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    guarded(run, cfg)


def main() -> None:
    """Console entry point ``hybridhyst-simulate`` (Hydra overrides on the command line)."""
    hydra_entry(_hydra_main)


if __name__ == "__main__":
    main()
