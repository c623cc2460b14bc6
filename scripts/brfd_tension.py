"""Which band tension's characterisation tests predict the BRFD earthquake records (issue 11, item 3)?

The four BRFD earthquake records are labelled 36 lb, but a repeat campaign holds bit-identical copies
documented as 30 lb. For each tension (30 and 36 lb) this script takes that tension's characterisation sine
tests (train: 0.5 and 1.5 in, validation: 1 in; thinned and split exactly as ``hybridhyst-discover`` does,
``cli.discover.load_split``), with the earthquakes as the test split in both cases, and fits two structures:

* ``nominal``: Coulomb + viscous + Dahl (``conf/model/dahl_friction.yaml``);
* ``discovered``: the final structure of a discovery report (``--discovery``), started from its values.

Each fit: the better on training of ``discover.fitting.polish`` (LM with step doubling) from the starting
values and ``identify`` (CMA-ES, pop 24, 30 generations, 4 restarts) followed by ``polish``. Reported per
tension and structure: training, validation and earthquake RMSE [kip] (pooled,
``analysis.split_metrics``; also with each record's mean force removed), RMSE per earthquake, the mean force
of the measured and simulated records (the offsets), the sub-steps and the fitted parameters; and, as a
reference, the discovered structure at the report's own values, not refitted ("reported").

Run (seconds per fit on one core once the fast backend is compiled)::

    PYTHONPATH=. python scripts/brfd_tension.py --json /tmp/brfd_tension.json
    PYTHONPATH=. python scripts/brfd_tension.py --discovery experiments/brfd_discovery/discovery.json
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import torch

from hybridhyst.simulate import SimulationSettings

ROOT = Path(__file__).resolve().parents[1]
TENSIONS = (30, 36)
SIM = SimulationSettings(backend="fast", method="rk4", substeps=1)
_TERM = re.compile(r"([+-][0-9.eE+-]+?)·(\w+)\^(\d+)")


def load(tension: float):
    """(records, Split) of ``tension``'s characterisation tests plus the earthquake records (the test split)."""
    from hydra import compose, initialize_config_dir

    from hybridhyst.cli.common import CONF_DIR
    from hybridhyst.cli.discover import load_split

    # split.select is a mapping in conf/data/discover/brfd.yaml: delete it, then give the list (any matches)
    select = f"+split.select=[{{tension_lb:{tension},kind:characterisation}},{{kind:earthquake}}]"
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose("discover", overrides=["~split.select", select, "progress=false"])
    return cfg, *load_split(cfg)


def _value(text):
    """A reported parameter value: a number, or a polynomial of a condition ("+a·c^0 +b·c^1", a trend)."""
    if isinstance(text, (int, float)):
        return float(text)
    terms = _TERM.findall(str(text))
    if not terms or len({c for _, c, _ in terms}) != 1:
        raise ValueError(f"cannot rebuild the parameter value {text!r} (numbers and polynomial trends only)")
    coeffs = [0.0] * (1 + max(int(i) for _, _, i in terms))
    for a, _, i in terms:
        coeffs[int(i)] = float(a)
    return {"kind": "polynomial", "coeffs": coeffs, "condition": terms[0][1]}


def build_structure(report: dict, nominal):
    """The final model of a discovery report: one ``EFFECTS[name]`` per parameter key (``<name>`` or
    ``<name>_added``) at the reported values. Parameters fixed in ``nominal`` under the same key stay fixed;
    an added effect's ``discovery_fixed`` parameters are fixed; input operators (backlash) go first."""
    from hybridhyst.physics.effects import EFFECTS, Effect
    from hybridhyst.physics.models import Constitutive

    values: dict[str, dict] = {}
    for name, info in report["after"]["parameters"].items():
        key, pname = name.split(".", 1)
        values.setdefault(key, {})[pname] = _value(info["value"])
    table = nominal.parameter_table()
    effects = {}
    for key, vals in values.items():
        name = key if key in EFFECTS else key.removesuffix("_added")
        if name not in EFFECTS:
            raise ValueError(f"discovery report: {key!r} names no library effect ({sorted(EFFECTS)})")
        cls = EFFECTS[name]
        if key in nominal.effects and nominal.effects[key].name == name:
            fixed = [p for p, info in table[key].items() if info["fixed"]]
        else:
            fixed = sorted(getattr(cls, "discovery_fixed", {}))
        effects[key] = cls(fixed=fixed, **vals)
    final = report["effects"]["final"]
    if sorted(e.name for e in effects.values()) != sorted(final):
        raise ValueError(f"discovery report: parameters name {sorted(values)}, effects.final is {final}")
    first = {k: e for k, e in effects.items() if type(e).transform is not Effect.transform}
    return Constitutive({**first, **effects}, units=dict(nominal.units), name="discovered").double()


def score(model, records, substeps: int, outputs=None) -> dict:
    """Pooled RMSE/MAE (``split_metrics``, per record name), and mean measured / simulated force [kip];
    ``outputs``: the records already simulated at ``substeps`` (``simulate``'s list), else simulated here."""
    from hybridhyst.analysis.metrics import split_metrics
    from hybridhyst.simulate import simulate

    recs = list(records)
    out = outputs
    if out is None:
        with torch.no_grad():
            out = simulate(model, recs, settings=SIM.at(substeps))
    preds = [{"condition": r.name, "y": np.asarray(r.y), "y_pred": o[:, 0].numpy(), "warmup": r.warmup}
             for r, o in zip(recs, out)]
    m = split_metrics(preds)
    centred = split_metrics([{**p, "y": p["y"] - np.mean(p["y"]), "y_pred": p["y_pred"] - np.mean(p["y_pred"])}
                             for p in preds])  # each record's mean force removed: the error beside the offsets
    return {"rmse": m["rmse"], "rmse_demeaned": centred["rmse"], "mae": m["mae"], "n": m["n"],
            "per_record": {k: v["rmse"] for k, v in m["per_condition"].items()},
            "mean_measured": {p["condition"]: float(np.mean(p["y"])) for p in preds},
            "mean_simulated": {p["condition"]: float(np.mean(p["y_pred"])) for p in preds}}


def fit(model, train):
    """The better (training SSE) of two fits: LM from the model's own values, and CMA-ES then LM."""
    import copy

    from hybridhyst.discover.fitting import polish
    from hybridhyst.identify import identify

    local = polish(copy.deepcopy(model), train, SIM, 25, 10.0)
    identify(model, train, search="cma", pop=24, generations=30, restarts=4, fisher=False, progress=False)
    searched = polish(model, train, SIM, 25, 10.0)
    return local if local.sse < searched.sse else searched


def run(discovery: Path) -> dict:
    from hybridhyst.cli.common import instantiate

    report = json.loads(discovery.read_text())
    out = {}
    for tension in TENSIONS:
        cfg, records, split = load(tension)
        nominal = instantiate(cfg.model, _convert_="all").double()
        structures = {"nominal": nominal, "discovered": build_structure(report, nominal)}
        out[str(tension)] = {"records": {s: [r.name for r in getattr(split, s)] for s in ("train", "val", "test")}}
        reported = structures["discovered"]  # scored at the report's values first (no refit), then fitted
        sub = int(report.get("settings", {}).get("substeps_final", 1))
        out[str(tension)]["reported"] = {"substeps": sub, **{s: score(reported, getattr(split, s), sub)
                                                             for s in ("train", "val", "test")}}
        for label, model in structures.items():
            t0 = time.perf_counter()
            f = fit(model, split.train)
            entry = {"substeps": f.substeps, "k": f.k, "fit_s": time.perf_counter() - t0,
                     "effects": [e.name for e in f.model.effects.values()],
                     "parameters": {f"{e}.{p}": info["value"] for e, ps in f.model.parameter_table().items()
                                    for p, info in ps.items()}}
            entry.update({s: score(f.model, getattr(split, s), f.substeps) for s in ("train", "val", "test")})
            out[str(tension)][label] = entry
            print(f"[{tension} lb {label}: {entry['fit_s']:.0f} s]", file=sys.stderr, flush=True)
    return out


def table(results: dict) -> str:
    quakes = list(results[str(TENSIONS[0])]["records"]["test"])
    short = [q.removeprefix("eq36lb_") for q in quakes]
    lines = ["RMSE [kip] (earthquakes centred: each record's mean force removed from measured and simulated)", "",
             "| tension | structure | sub-steps | train | val (1 in) | earthquakes | earthquakes centred | "
             + " | ".join(short) + " |", "|---" * (7 + len(short)) + "|"]
    for t in TENSIONS:
        for label in ("nominal", "discovered", "reported"):
            e = results[str(t)][label]
            cells = [f"{e[s]['rmse']:.4f}" for s in ("train", "val", "test")] + [f"{e['test']['rmse_demeaned']:.4f}"]
            cells += [f"{e['test']['per_record'][q]:.4f}" for q in quakes]
            name = "discovered at the report's values, no refit" if label == "reported" else label
            lines.append(f"| {t} lb | {name} | {e['substeps']} | " + " | ".join(cells) + " |")
    lines += ["", "Mean force [kip] of each split (measured; simulated by the nominal / discovered fit):", "",
              "| tension | split | measured | nominal | discovered |", "|---|---|---|---|---|"]
    for t in TENSIONS:
        for s in ("train", "val", "test"):
            ms = [np.mean(list(results[str(t)][lab][s][k].values())) for lab, k in
                  (("nominal", "mean_measured"), ("nominal", "mean_simulated"), ("discovered", "mean_simulated"))]
            lines.append(f"| {t} lb | {s} | " + " | ".join(f"{m:+.4f}" for m in ms) + " |")
    lines.append("")
    for t in TENSIONS:
        for label in ("nominal", "discovered"):
            ps = results[str(t)][label]["parameters"]
            lines.append(f"- {t} lb {label}: " + ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}"
                                                            for k, v in ps.items()))
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--discovery", type=Path,
                    default=ROOT / "experiments/brfd_discovery/discovery_leftover_dynamics.json",
                    help="the discovery report whose final structure is fitted (default: the committed run that kept "
                    "the asymmetric Coulomb step, clearance + LuGre + asymmetric Coulomb)")
    ap.add_argument("--json", type=Path, default=None, help="write every number here")
    args = ap.parse_args(argv)
    torch.set_default_dtype(torch.float64)
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    results = run(args.discovery)
    wall = time.perf_counter() - t0
    print(table(results))
    print(f"\nwall time {wall:.0f} s")
    if args.json:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
        doc = {"command": " ".join(["python", *sys.argv]), "git_commit": commit, "wall_s": wall,
               "discovery": str(args.discovery), "units": "kip", "results": results}
        args.json.write_text(json.dumps(doc, indent=1))
    return results


if __name__ == "__main__":
    main()
