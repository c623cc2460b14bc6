"""The runs of ``scripts/readme_apps.py`` and the renderers of the blocks that quote them.

The runs are the app commands the user guides (docs/) show, with what each keeps of its run directory
(``Run``, ``SECTION_RUNS``, ``own_data_runs``, ``all_runs``); the renderers (``block_*``) write the text of each
``<!-- apps:<block>:start -->`` ... ``end`` block from the committed JSON in ``experiments/apps/``. This module
imports only the standard library at the top, so the test can render the blocks cheaply.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
OWN_DATA_DOC = DOCS / "own-data.md"  # the own-data commands: the first bash block of its "Your own measurements"
FOLDER = ROOT / "experiments" / "apps"
MAKE_EXAMPLE = ROOT / "examples" / "own_data" / "make_example.py"
COMMAND = "OMP_NUM_THREADS=1 PYTHONPATH=. python scripts/readme_apps.py"


@dataclass(frozen=True)
class Run:
    """One README command: ``name`` (its JSON file), the command as the README shows it, the run-directory file
    whose content is kept (``keep``: its top-level keys), the config values kept (dotted keys of the resolved
    ``config.yaml``), and files copied next to the JSON (into ``experiments/apps/<name>/``)."""

    name: str
    command: str
    output: str
    keep: tuple[str, ...]
    config: tuple[str, ...] = ()
    files: tuple[str, ...] = ()


FIT_KEEP = ("parameters", "rmse", "per_record", "split", "units", "fit", "reference", "wall_s")
IDENTIFY_KEEP = ("model", "records", "coordinates", "units", "rmse", "per_record", "noise_sd", "identifiable",
                 "non_identifiable", "combinations", "uncertainty", "search", "wall_s")
TRAIN_KEEP = ("status", "train", "val", "test", "info", "physics", "nominal", "start", "wall_s")
DISCOVER_KEEP = ("before", "after", "steps", "rejected", "removed", "effects", "records", "wall_s")
SPLIT = ("split.select", "split.held_out")

SECTION_RUNS = (
    Run("fit", "hybridhyst-fit", "summary.json", FIT_KEEP, (*SPLIT, "fit.steps", "fit.lbfgs_steps"),
        files=("report.md", "loop.png")),
    Run("fit_reference", "hybridhyst-fit simulation.backend=reference", "summary.json", FIT_KEEP,
        ("simulation.backend",)),
    Run("fit_every_sample", "hybridhyst-fit evaluate.samples_per_cycle=null evaluate.downsample=1", "summary.json",
        FIT_KEEP, ("evaluate.samples_per_cycle", "evaluate.downsample")),
    Run("identify", "hybridhyst-identify", "summary.json", IDENTIFY_KEEP, ("split.select",)),
    Run("train", "hybridhyst-train", "metrics.json", TRAIN_KEEP, (*SPLIT, "split.val", "datamodule.samples_per_cycle")),
    Run("simulate", "hybridhyst-simulate model=vpptd_rig input.kind=free_vibration 'input.initial_state=[10.0,40.0]' "
        "+conditions.pressure_mpa=0.05 input.duration_s=20 input.dt=0.001", "summary.json",
        ("model", "input", "outputs", "records", "wall_s"), ("conditions",)),
)
# the own-data commands, in the order of docs/own-data.md's code block
OWN_NAMES = ("own_identify", "own_fit", "own_discover", "own_train", "own_train_linear")
OWN_OUTPUT = {"identify": ("summary.json", IDENTIFY_KEEP), "fit": ("summary.json", FIT_KEEP),
              "discover": ("discovery.json", DISCOVER_KEEP), "train": ("metrics.json", TRAIN_KEEP)}


def own_data_runs(text: str | None = None) -> tuple[Run, ...]:
    """The commands of docs/own-data.md's first code block ("Your own measurements"), named ``OWN_NAMES`` in
    order."""
    section = text if text is not None else OWN_DATA_DOC.read_text(encoding="utf-8")
    block = section.split("```bash\n", 1)[1].split("```", 1)[0]
    commands = [" ".join(c.split()) for c in block.replace("\\\n", " ").splitlines()
                if c.strip().startswith("hybridhyst-")]
    if len(commands) != len(OWN_NAMES):
        raise ValueError(f"docs/own-data.md's command block has {len(commands)} commands, expected {len(OWN_NAMES)}")
    runs = []
    for name, command in zip(OWN_NAMES, commands):
        app = command.split()[0].removeprefix("hybridhyst-")
        output, keep = OWN_OUTPUT[app]
        runs.append(Run(name, command, output, keep, SPLIT))
    return tuple(runs)


def all_runs() -> tuple[Run, ...]:
    return (*SECTION_RUNS, *own_data_runs())


# -------------------------------------------------------------------------------------------------- rendering


def load(name: str, folder: Path = FOLDER) -> dict:
    return json.loads((folder / f"{name}.json").read_text(encoding="utf-8"))


def g(v: float, digits: int = 3) -> str:
    """``v`` to ``digits`` significant digits, plain notation for 1e-4 <= |v| < 1e5."""
    if v == 0 or not math.isfinite(v):
        return f"{v:g}"
    if not 1e-4 <= abs(v) < 1e5:
        return f"{v:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e")
    decimals = max(digits - 1 - math.floor(math.log10(abs(v))), 0)
    return f"{round(v, decimals):.{decimals}f}"


def secs(v: float) -> str:
    return f"{v:.1f}" if v < 100 else f"{v:.0f}"


def wrap(text: str, first: str = "", rest: str = "") -> str:
    """``text`` filled to the README's width (110), inline code spans and ``a = b + c`` kept on one line (a line
    that starts with ``+`` or ``-`` would be read as a list item)."""
    import textwrap

    keep = re.sub(r"`[^`]+`", lambda m: m.group(0).replace(" ", "\u00a0"), text)
    keep = re.sub(r" ([-+=×]) ", "\u00a0\\1\u00a0", keep)
    filled = textwrap.fill(keep, width=110, initial_indent=first, subsequent_indent=rest, break_long_words=False,
                           break_on_hyphens=False)
    return filled.replace("\u00a0", " ")


def _wall(r: dict) -> str:
    return secs(r["measured"]["wall_s"])


def _param(summary: dict, effect: str, name: str) -> float:
    """A fitted value of hybridhyst-fit's ``parameters`` ({effect: {parameter: {value, ...}}})."""
    return float(summary["parameters"][effect][name]["value"])


def _coord(values: dict, key: str) -> float:
    """A value of identify's ``coordinates`` or discover's ``parameters`` ({name: value or {value, unit}})."""
    v = values[key]
    return float(v["value"] if isinstance(v, dict) else v)


def _pressure(record: str) -> float:
    return float(record.removeprefix("p"))


def _example():
    """examples/own_data/make_example.py (numpy only): the law the example file was made with."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_example", MAKE_EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _held_out_phrase(held_out, unit_of: dict) -> str:
    """'the 1 in tests' from ``[{amplitude_in: [1.0]}]``."""
    parts = []
    for query in held_out or []:
        for cond, values in query.items():
            values = values if isinstance(values, list) else [values]
            parts.append(" and ".join(f"{v:g}" for v in values) + f" {unit_of.get(cond, cond)}")
    return " and ".join(parts)


def measured_note(names: list[str]) -> str:
    """Where the numbers come from, with the date and the load of the runs quoted."""
    records = [load(n) for n in names]
    dates = sorted(r["measured"]["finished_utc"][:10] for r in records)
    loads = [r["measured"]["load_average_at_start"][0] for r in records]
    date = dates[0] if dates[0] == dates[-1] else f"{dates[0]} to {dates[-1]}"
    spread = g(min(loads), 2) if min(loads) == max(loads) else f"{g(min(loads), 2)}–{g(max(loads), 2)}"
    return (f"Measured by `scripts/readme_apps.py` ([`experiments/apps/`](experiments/apps/), {date}; wall time "
            f"of the whole command on the shared {records[0]['measured']['cpus']}-core development machine at a "
            f"load average of {spread}: it varies with the load).")


def block_fit() -> str:
    fit, ref, every = load("fit"), load("fit_reference"), load("fit_every_sample")
    s, sr, se = fit["summary.json"], ref["summary.json"], every["summary.json"]
    diff = max(abs(s["rmse"][k] - sr["rmse"][k]) for k in ("train", "held_out"))
    u = s["units"]["y"]
    same = "the same RMSE" if diff < 1e-12 else f"RMSE within {diff:.0e} {u}"
    refs = s["reference"]["held_out_rmse"]
    return wrap(
        f"{measured_note(['fit', 'fit_reference', 'fit_every_sample'])} `hybridhyst-fit` takes {_wall(fit)} s with "
        f"the default compiled simulator (`simulation.backend=fast`; {_wall(ref)} s with `hybridhyst-fit "
        f"simulation.backend=reference`, {same}) and ends at held-out RMSE {s['rmse']['held_out']:.3f} {u}, train "
        f"{s['rmse']['train']:.3f} {u}. SOURCE.md's reference numbers for the same protocol are "
        f"{refs['Coulomb + viscous']} {u} for Coulomb + viscous and {refs['LuGre']} {u} for LuGre (`report.md` "
        f"lists them all). The fitted Dahl state saturates at Fc = {g(_param(s, 'dahl', 'Fc'))} {u} with "
        f"σ0 = {g(_param(s, 'dahl', 'sigma0'))} kip/in; the Coulomb term is Fc = {g(_param(s, 'coulomb', 'Fc'), 2)} "
        f"{u}, the viscous c = {g(_param(s, 'viscous', 'c'), 2)} kip·s/in. Scoring on every sample instead "
        f"(`{every['command']}`, {_wall(every)} s) gives {se['rmse']['held_out']:.3f} {u} held out."
    )


def block_identify() -> str:
    r = load("identify")
    s = r["summary.json"]
    n_ok = sum(1 for c in s["combinations"] if c["identifiable"])
    weak = s["non_identifiable"]
    names = {"hysteresis.alpha": "α", "hysteresis.gamma": "γ", "hysteresis.beta": "β"}
    weak_text = (", ".join(names.get(w, w.split(".")[-1]) for w in weak) + " individually are not identifiable "
                 "from one loop") if weak else "every parameter is identifiable from one loop"
    return wrap(
        f"{measured_note(['identify'])} The default run (`hybridhyst-identify`, {_wall(r)} s wall, "
        f"{secs(s['search']['identify_wall_s'])} s identifying) reaches RMSE {s['rmse']:.4f} Nm against a noise sd "
        f"of {s['noise_sd']:g} Nm and finds {n_ok} identifiable combinations of the {len(s['coordinates'])} "
        f"parameters; {weak_text}."
    )


def _train_row(m: dict) -> tuple[str, ...]:
    return tuple(f"{m[k]['rmse']:.3f}" if m.get(k) else "-" for k in ("train", "val", "test"))


def block_train() -> str:
    r = load("train")
    m, cfg = r["metrics.json"], r["config"]
    info, nominal = m["info"], m["nominal"]
    n_tr, n_va, n_te = _train_row(nominal)
    tr, va, te = _train_row(m)
    held = _held_out_phrase(cfg["split.held_out"], {"amplitude_in": "in"})
    val = _held_out_phrase(cfg["split.val"], {"frequency_hz": "Hz"})
    kept = " (the starting weights kept)" if (m.get("start") or {}).get("restored") else ""
    u = info["units"]["F"]
    return wrap(
        f"{measured_note(['train'])} The default run (`hybridhyst-train`, {_wall(r)} s wall, "
        f"{secs(info['train_time_s'])} s training, {secs(nominal['identify']['wall_s'])} s identifying the nominal, "
        f"{info['epochs']} epochs) starts from the identified Dahl nominal (train {n_tr}, validation on the {val} "
        f"tests {n_va}, held-out {held} tests {n_te} {u} on the {cfg['datamodule.samples_per_cycle']}-samples-per-"
        f"cycle grid) and ends at {tr}, {va} and {te} {u}{kept}."
    )


def block_simulate() -> str:
    r = load("simulate")
    info = r["summary.json"]["records"]["free_vibration"]
    return wrap(f"The free-vibration run (the third command, {_wall(r)} s wall; its `summary.json` in "
                f"[`experiments/apps/simulate.json`](experiments/apps/simulate.json)): `frequency_hz` "
                f"{info['frequency_hz']:.4g}.")


OWN_LABELS = {"viscous.c": ("c", "Nm·s/rad"), "stiffness.k": ("k", "Nm/deg"), "cubic.k3": ("k2", "Nm/deg³"),
              "friction.Fc": ("Ms", "Nm")}   # seed 000's names and units (conf/model/vpptd_algebraic.yaml)
EXAMPLE_NAMES = {"viscous.c": "c", "stiffness.k": "k", "cubic.k3": "k2", "friction.Fc": "Ms"}
FIT_NAMES = {"viscous.c": ("viscous", "c"), "stiffness.k": ("stiffness", "k"), "cubic.k3": ("cubic", "k3"),
             "friction.Fc": ("friction", "Fc")}


def _terminal_block(lines: list[str]) -> str:
    return "  ```text\n" + "\n".join("  " + line for line in lines) + "\n  ```"


def _item(text: str) -> str:
    return wrap(text, "* ", "  ")


def _own_identify(ex) -> str:
    r = load("own_identify")
    s = r["summary.json"]
    p = _pressure(s["records"][0])
    truth = ex.parameters(p)
    fitted = ", ".join(f"{OWN_LABELS[k][0]} = {g(_coord(s['coordinates'], k), 4)} {OWN_LABELS[k][1]}"
                       for k in OWN_LABELS)
    made = ", ".join(f"{truth[EXAMPLE_NAMES[k]]:.6g}" for k in OWN_LABELS)
    weak = s["non_identifiable"]
    verdict = (f"all {len(s['coordinates'])} identifiable from one loop" if not weak
               else f"{', '.join(weak)} not identifiable from one loop")
    return _item(f"`hybridhyst-identify` ({_wall(r)} s, {secs(s['search']['identify_wall_s'])} s identifying): "
                 f"RMSE {s['rmse']:.4f} Nm against the {ex.NOISE_NM:g} Nm noise, {fitted} — the file was made "
                 f"with {made} at {p:g} MPa — {verdict}.")


def _own_fit() -> str:
    r = load("own_fit")
    s = r["summary.json"]
    values = ", ".join(f"{OWN_LABELS[k][0]} = {g(_param(s, *FIT_NAMES[k]), 4)}" for k in OWN_LABELS)
    held = " and ".join(f"{g(s['per_record'][n])} Nm at {_pressure(n):g}" for n in s["split"]["held_out"])
    return _item(f"`hybridhyst-fit` ({_wall(r)} s): one set of constants for every pressure ({values}) cannot "
                 f"follow the pressure: training RMSE {s['rmse']['train']:.3f} Nm, held-out "
                 f"{s['rmse']['held_out']:.3f} Nm ({held} MPa).")


def _trend(after: dict, key: str) -> tuple[float, float] | None:
    """(intercept, slope) of a parameter that discover made linear in a condition (its value reads
    ``+5.86·pressure_mpa^0 +83.9·pressure_mpa^1``); None when the parameter is constant."""
    value = after["parameters"][key]["value"]
    if not isinstance(value, str):
        return None
    terms = {int(power): float(coef) for coef, power in re.findall(r"([-+][^·\s]+)·\w+\^(\d+)", value)}
    if set(terms) != {0, 1}:
        return None
    return terms[0], terms[1]


def _own_discover(ex) -> str:
    r = load("own_discover")
    d = r["discovery.json"]
    lo, hi = ex.parameters(0.0), ex.parameters(1.0)   # the example's law is linear in p: value at 0, at 1 MPa
    fitted, law = [], []
    for k, (label, _) in OWN_LABELS.items():
        t = _trend(d["after"], k)
        if t is not None:
            n = EXAMPLE_NAMES[k]
            fitted.append(f"{label} = {g(t[0], 4)} + {g(t[1], 4)} p")
            law.append(f"{lo[n]:.6g} + {hi[n] - lo[n]:.6g} p")
    accepted = [s for s in d["steps"] if s.get("accepted", True)]
    # the step that stopped the loop: not a trend, not a start state offered right after its effect ("when")
    rejected = [r for r in d.get("rejected") or [] if r.get("kind") != "trend" and "when" not in r]
    steps = "one step" if len(accepted) == 1 else f"{len(accepted)} steps"
    refused = f" and refuses the best effect left (`{rejected[0]['effect']}`)" if rejected else ""
    return "\n\n".join([
        _item(f"`hybridhyst-discover` ({_wall(r)} s): the loop makes {len(fitted)} parameters linear in "
              f"`pressure_mpa` in {steps} ({', '.join(fitted)} with p in MPa; the file's law is {', '.join(law)})"
              f"{refused}. It ends with a summary on the terminal:"),
        _terminal_block(r["terminal"]),
        wrap("(a validation line too when `split.val` is set: `'split.val=[{pressure_mpa: [0.03, 0.07]}]'`).",
             "  ", "  ")])


def _per_pressure(metrics: dict) -> str:
    """'0.59 Nm at 0.05, 2.66 Nm at 0.09' from the test split's ``per_condition`` ({'pressure_mpa=0.05': {...}})."""
    return ", ".join(f"{g(v['rmse'])} Nm at {k.split('=')[-1]}" for k, v in metrics["test"]["per_condition"].items())


def _own_train(ex) -> str:
    r, lin = load("own_train"), load("own_train_linear")
    m, ml = r["metrics.json"], lin["metrics.json"]
    fit, law = load("own_fit")["summary.json"], load("own_discover")["discovery.json"]["after"]
    same = abs(m["nominal"]["train"]["rmse"] - fit["rmse"]["train"]) <= 0.005 * fit["rmse"]["train"]
    constants = "; the constants `hybridhyst-fit` finds" if same else ""
    per = m["test"]["per_condition"]
    last = max(per, key=lambda k: float(k.split("=")[-1]))
    worse = (f": the network interpolates in pressure but does not extrapolate to {last.split('=')[-1]} MPa the way "
             "the discovered law does" if per[last]["rmse"] > 2 * law["test_rmse"] else "")
    floor = ml["test"]["rmse"] <= 1.05 * ex.NOISE_NM
    return "\n\n".join([
        _item(f"`hybridhyst-train` ({_wall(r)} s, {m['info']['epochs']} epochs): the nominal starts from "
              f"`hybridhyst.identify` on the {m['nominal']['identify']['records']} training loops "
              f"({secs(m['nominal']['identify']['wall_s'])} s{constants}), then the hybrid, whose residual network "
              f"sees the pressure, trains; the run ends with the starting nominal's RMSE beside the hybrid's:"),
        _terminal_block(r["terminal"]),
        wrap(f"(held out: {_per_pressure(m)} MPa){worse}. With `model=vpptd_algebraic_linear` (every parameter "
             f"linear in the pressure, slopes starting at 0){' the nominal lacks nothing:' if floor else ''} "
             f"identification finds the law ({secs(ml['nominal']['identify']['wall_s'])} s; training RMSE "
             f"{ml['nominal']['train']['rmse']:.4f} Nm) and the hybrid ends at {ml['train']['rmse']:.4f} Nm on "
             f"training and {ml['test']['rmse']:.4f} Nm held out ({_per_pressure(ml)} MPa"
             f"{': the noise level' if floor else ''}), {_wall(lin)} s in all.", "  ", "  ")])


def block_own_data() -> str:
    ex = _example()
    return "\n".join([wrap(measured_note(list(OWN_NAMES))), "", _own_identify(ex), _own_fit(), _own_discover(ex),
                      _own_train(ex)])


def _headline(out: dict) -> str:
    if isinstance(out.get("rmse"), dict):
        return f"RMSE train {g(out['rmse']['train'], 4)}, held out {g(out['rmse']['held_out'], 4)}"
    if "rmse" in out:
        return f"RMSE {g(out['rmse'], 4)}; {len(out['identifiable'])} identifiable combinations"
    if "after" in out:
        return "RMSE " + ", ".join(f"{k.removesuffix('_rmse')} {g(out['before'][k], 4)} → {g(out['after'][k], 4)}"
                                   for k in ("train_rmse", "val_rmse", "test_rmse") if out["before"].get(k) is not None)
    if "test" in out:
        return "RMSE nominal → trained: " + ", ".join(f"{k} {g(out['nominal'][k]['rmse'], 4)} → {g(out[k]['rmse'], 4)}"
                                                      for k in ("train", "val", "test") if out.get(k))
    return f"frequency_hz {out['records']['free_vibration']['frequency_hz']:.4g}"


def block_table() -> str:
    """experiments/apps/README.md: every run, its wall time and headline numbers, then the commands."""
    rows = ["| run | app | wall [s] | load average at start | headline (response units) |", "|---|---|---|---|---|"]
    commands = []
    for run in all_runs():
        r = load(run.name)
        app = run.command.split()[0]
        model = re.search(r"\bmodel=(\w+)", run.command)
        what = f"`{app}`" + (f" (own data, `{model.group(0)}`)" if run.name.startswith("own_") else "")
        rows.append(f"| [{run.name}]({run.name}.json) | {what} | {secs(r['measured']['wall_s'])} | "
                    f"{r['measured']['load_average_at_start'][0]:g} | {_headline(r[run.output])} |")
        commands.append(f"{run.command}   # {run.name}")
    when = sorted(load(run.name)["measured"]["finished_utc"] for run in all_runs())
    return "\n".join([f"Runs finished {when[0]} to {when[-1]} UTC.", "", *rows, "", "The commands, as README.md "
                      "shows them:", "", "```bash", *commands, "```"])


def block_index() -> str:
    """experiments/README.md: the apps row of the index."""
    fit, own, train = load("fit")["summary.json"], load("own_discover")["discovery.json"], load("train")
    total = sum(load(run.name)["measured"]["wall_s"] for run in all_runs())
    head = (f"BRFD nominal fit held-out RMSE {fit['rmse']['held_out']:.3f} kip (train {fit['rmse']['train']:.3f}); "
            f"default hybrid {train['metrics.json']['nominal']['test']['rmse']:.3f} → "
            f"{train['metrics.json']['test']['rmse']:.3f} kip held out; own-data example: the discovered law "
            f"{own['before']['test_rmse']:.3f} → {own['after']['test_rmse']:.4f} Nm held out (noise "
            f"{_example().NOISE_NM:g} Nm)")
    return "\n".join(["| study | command | headline result | time to run |", "|---|---|---|---|",
                      f"| [apps](apps/) — the commands README.md shows for `hybridhyst-fit`, `-identify`, `-train`, "
                      f"`-simulate` and the own-data example, one at a time | `{COMMAND}` | {head} | "
                      f"{total:.0f} s ({len(all_runs())} runs) |"])
