"""The independent discovery test bed (hybridhyst/testbed): the case list, the scoring, one small case end to end,
and (slow) the whole bed against its pass criteria. The generators against known solutions are in
tests/test_testbed_generators.py."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

# -- (c) the case list ---------------------------------------------------------------------------------------------


FAMILIES = {"viscous", "coulomb", "asymmetric_coulomb", "stribeck", "linear_stiffness", "cubic_stiffness", "bouc_wen",
            "dahl", "lugre", "backlash", "inertia", "attenuation", "time_delay", "travel_drift", "maxwell", "clearance"}


def test_case_list_sanity():
    from hybridhyst.physics.effects import EFFECTS
    from hybridhyst.testbed.cases import CASES, CATEGORIES

    assert len(CASES) >= 24
    assert len({c.name for c in CASES}) == len(CASES)
    counts = Counter(c.category for c in CASES)
    assert set(counts) <= set(CATEGORIES)
    assert counts["single"] >= 16 and counts["pair"] >= 4 and counts["condition"] >= 3 and counts["clean"] >= 3
    assert counts["out_of_library"] >= 2
    singles = [c for c in CASES if c.category == "single"]
    assert FAMILIES <= {n for c in singles for fam in c.expected for n in fam}
    for c in CASES:
        assert all(name in EFFECTS for fam in c.expected for name in fam), c.name
        if c.category in ("single", "pair", "condition"):
            assert len(c.expected) == (2 if c.category == "pair" else 1), c.name
            assert c.keys, c.name
            for coord, truth, tol in c.keys:
                effect = coord.split(".")[0]
                if effect.startswith("lag_"):  # discover's key of a control's lag: lag_<control>
                    effect = "control_lag"
                assert any(effect in fam for fam in c.expected), (c.name, coord)
                assert math.isfinite(truth) and truth != 0 and 0 < tol < 1
        else:
            assert not c.expected and not c.keys, c.name
        assert c.noise > 0
        assert set(c.split) <= {"held_out", "val"} and c.split.get("held_out") and c.split.get("val")


def test_case_data_nominal_and_split():
    """The records, nominal and split of the fast cases (every case: ``test_every_case_of_the_beds_builds``)."""
    from hybridhyst.testbed.cases import CASE_BY_NAME, FAST_CASES

    _case_data_nominal_and_split([CASE_BY_NAME[name] for name in FAST_CASES])


@pytest.mark.slow
def test_every_case_of_the_beds_builds():
    """Every case of the first bed, and of the second blind bed, builds its records (generated with scipy's
    integrators: most of a minute on 2 cores), splits them and simulates its nominal."""
    from hybridhyst.testbed.blind_cases import bed_cases
    from hybridhyst.testbed.cases import CASES

    _case_data_nominal_and_split(CASES)
    _every_case_builds_splits_and_simulates(bed_cases("blind2"))


def _case_data_nominal_and_split(cases):
    import torch

    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    try:
        for c in cases:
            records = c.records()
            train, val, test = records.split(held_out=c.split["held_out"], val=c.split["val"])
            assert len(train) >= 2 and len(val) >= 1 and len(test) >= 1, c.name
            assert 4 <= len(records) <= 9, c.name
            for r in records:
                assert np.all(np.isfinite(r.y)) and len(r) >= 60, (c.name, r.name)
            nominal = c.nominal()
            present = {e.name for e in nominal.effects.values()}
            assert not present & {n for fam in c.expected for n in fam}, c.name  # the extra effect is missing
            if c.category == "condition" and records.records[0].controls:  # the condition varies in every record
                for r in records:
                    assert r.controls and all(np.ptp(v) > 0 for v in r.controls.values()), (c.name, r.name)
            elif c.category == "condition":  # every record at a level of the condition the split holds out
                (condition,) = c.split["held_out"]
                assert len({r.conditions[condition] for r in records}) >= 6, c.name
    finally:
        torch.set_default_dtype(old)


# -- scoring --------------------------------------------------------------------------------------------------------


def _report(named, params=None, trends=(), flagged=None, after=0.031):
    ev = {"val_rmse_before": 0.1, "val_rmse_after": 0.05}
    steps = [{"effect": n, "kind": "effect", "new_coordinates": {}, "evidence": ev} for n in named]
    steps += [{"effect": n, "kind": "condition", "new_coordinates": {}, "evidence": ev} for n in trends]
    unexplained = {} if flagged is None else {"structure_flagged": flagged}
    return {"before": {"test_rmse": 1.0}, "after": {"test_rmse": after, "parameters": params or {}},
            "steps": steps, "effects": {"added": list(named), "dropped": []}, "unexplained": unexplained}


def test_score_rules():
    from hybridhyst.testbed.cases import CASE_BY_NAME
    from hybridhyst.testbed.run import markdown, score, summary

    pair = CASE_BY_NAME["backlash+coulomb"]
    row = score(pair, _report(["backlash", "asymmetric_coulomb"],
                              {"backlash.r": {"value": 0.081}, "asymmetric_coulomb.Fc": {"value": 0.41}}), 1.0)
    assert row["found"] and not row["wrong"] and row["ok_effect"] and row["ok_param"] and row["ok_rmse"] and row["ok"]
    assert row["keys"][1]["found_as"] == "asymmetric_coulomb.Fc"  # the alias carries the key parameter
    row = score(pair, _report(["backlash", "dahl"], {"backlash.r": {"value": 0.08}}), 1.0)
    assert not row["found"] and row["wrong"] == ["dahl"] and not row["ok_effect"]
    clean = CASE_BY_NAME["clean_friction"]
    assert score(clean, _report([]), 1.0)["ok"]
    assert not score(clean, _report([], trends=["viscous.c~frequency_hz"]), 1.0)["ok_effect"]
    assert not score(clean, _report([], after=0.05), 1.0)["ok_rmse"]
    ool = CASE_BY_NAME["cogging"]
    assert not score(ool, _report([]), 1.0)["ok"]  # not flagged (a missing key counts as False)
    assert score(ool, _report([], flagged=True), 1.0)["ok"]
    rows = [score(pair, _report(["backlash", "coulomb"]), 2.0), score(clean, _report([]), 3.0)]
    s = summary(rows)
    assert s["effect_share"] == 1.0 and s["clean_ok"] == 1 and s["wall_s"] == 5.0
    text = markdown(rows)
    assert "| backlash+coulomb | pair |" in text and "Pass criteria" in text
    # two members of one family for one effect: the second is an effect the data lack
    row = score(pair, _report(["backlash", "coulomb", "asymmetric_coulomb"]), 1.0)
    assert row["found"] and row["wrong"] == ["asymmetric_coulomb"] and not row["ok_effect"]


def test_blind_bed_cases_are_scored_by_the_library_families_of_their_effect_words():
    """The blind bed (``testbed/blind/``, written without the library): every case builds records, a nominal of
    its declared base law that simulates, and a split; an effect the library has a family for is scored as an
    effect case, one it lacks as out of library, no effect as a clean control."""
    from hybridhyst.testbed import blind
    from hybridhyst.testbed.blind_cases import BLIND_CASES, family

    assert len(BLIND_CASES) >= 16
    by = {c.name: c for c in BLIND_CASES}
    assert by["clean_symmetric_damper"].category == "clean"
    assert by["play_friction_damper"].expected == (frozenset({"backlash", "relaxing_backlash", "clearance"}),)
    assert by["asymmetric_friction_drift_damper"].category == "pair"
    assert by["asymmetric_viscous_damper"].category == "out_of_library"  # no direction-dependent damping
    assert by["cogging_rotary_damper"].category == "out_of_library"
    assert by["clean_pressure_cubic_damper"].trends_ok == ("pressure_kpa",)
    assert not by["clean_symmetric_damper"].trends_ok
    from hybridhyst.testbed.run import score

    clean = by["clean_pressure_cubic_damper"]
    assert score(clean, _report([], trends=["trends~pressure_kpa"]), 1.0)["ok_effect"]
    assert not score(clean, _report([], trends=["spring.k~amplitude"]), 1.0)["ok_effect"]
    # one parameter at a time (too few training levels for the joint step): the truth's condition all the same
    assert score(clean, _report([], trends=["spring.k~pressure_kpa", "cubic.k3~pressure_kpa"]), 1.0)["ok_effect"]
    assert not score(clean, _report([], trends=["spring.k~pressure_kpa", "trends~amplitude"]), 1.0)["ok_effect"]
    assert not score(clean, _report([], trends=["clearance.start"]), 1.0)["ok_effect"]  # a start state is added
    assert family("asymmetry", blind.case("asymmetric_viscous_damper")) is None
    _every_case_builds_splits_and_simulates(BLIND_CASES)


def _every_case_builds_splits_and_simulates(cases):
    import torch

    from hybridhyst.simulate import simulate

    for case in cases:
        records = case.records()
        train, val, test = records.split(**case.split)
        assert len(train.records) >= 3 and len(test.records) >= 1, case.name
        out = simulate(case.nominal(), [train.records[0]], backend="reference")
        assert bool(torch.isfinite(out[0]).all()), case.name


def test_the_second_blind_bed_is_scored_like_the_first():
    """The second blind bed (``testbed/blind2/``, another author): at least 16 cases with clean controls, effect
    cases and out-of-library ones; an oscillator's mass is the one its author declared; a case name is found in
    either bed and built alone (every case's records, split and nominal: ``test_every_case_of_the_beds_builds``)."""
    from hybridhyst.testbed import blind2
    from hybridhyst.testbed.blind_cases import _nominal, bed_cases, blind_case
    from hybridhyst.testbed.run import _registered

    cases = bed_cases("blind2")
    assert len(cases) >= 16
    categories = [c.category for c in cases]
    assert categories.count("clean") >= 4 and categories.count("out_of_library") >= 2
    assert categories.count("single") + categories.count("pair") >= 10
    assert not {c.name for c in cases} & {c.name for c in bed_cases("blind")}  # one name, one case
    for fn in blind2.CASES:
        spec = fn()
        if spec.kind == "oscillator":
            model = _nominal(spec)
            mass = float(model.structure_params.mass.value.detach())  # [N s²/mm] or [N s²/m]
            assert mass == pytest.approx(spec.mass_kg * {"mm": 1e-3, "m": 1.0}[spec.units["y"]], rel=1e-6)
    name = cases[0].name
    assert blind_case(name) is _registered(name) is cases[0]
    assert blind_case("no_such_case") is None


# -- (e) one small case end to end -------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["clean_friction", "linear_stiffness"])
def test_fast_cases_end_to_end_pass(name):
    """The fast subset of the bed in the default run: a clean control (nothing added) and a single effect at
    20 samples per cycle (named, key parameter within tolerance, held-out error at the noise)."""
    import torch

    from hybridhyst.testbed.cases import CASE_BY_NAME, FAST_CASES
    from hybridhyst.testbed.run import markdown, run_case

    assert name in FAST_CASES
    old = torch.get_default_dtype()
    try:
        row = run_case(CASE_BY_NAME[name])
    finally:
        torch.set_default_dtype(old)
    assert row["error"] is None, row["error"]
    assert isinstance(row["named"], list) and all(isinstance(n, str) for n in row["named"])
    assert isinstance(row["trends"], list)
    for key in ("test_rmse_before", "test_rmse_after", "after_over_noise"):
        assert isinstance(row[key], float) and math.isfinite(row[key]) and row[key] > 0, key
    assert row["wall_s"] > 0
    assert isinstance(row["ok"], bool) and isinstance(row["ok_rmse"], bool) and isinstance(row["flagged"], bool)
    assert row["name"] in markdown([row])
    assert row["ok"] and row["ok_rmse"] and row["ok_effect"], row


def test_the_bed_gives_every_case_the_same_discover_options():
    """``run_case(case, options)`` passes the options to discover (here one it refuses: the row says so)."""
    import torch

    from hybridhyst.testbed.cases import CASE_BY_NAME
    from hybridhyst.testbed.run import run_case

    old = torch.get_default_dtype()
    try:
        row = run_case(CASE_BY_NAME["clean_friction"], {"validation": "lofo"})
    finally:
        torch.set_default_dtype(old)
    assert "unknown validation 'lofo'" in row["error"] and not row["ok"]


# -- (d) the whole bed against its targets ----------------------------------------------------------------------------


@pytest.mark.slow
def test_whole_bed_meets_the_pass_criteria():
    from hybridhyst.testbed.cases import CASES
    from hybridhyst.testbed.run import TARGETS, markdown, run_bed, summary

    rows = run_bed(CASES, jobs=2, progress=False)
    s = summary(rows)
    table = markdown(rows)
    assert not s["errors"], table
    assert s["effect_share"] >= TARGETS["effect_share"], table
    assert s["rmse_share"] >= TARGETS["rmse_share"], table
    assert s["clean_ok"] == s["clean_cases"], table
    assert s["ool_ok"] == s["ool_cases"], table


def test_the_bed_script_runs_every_case_with_the_settings_given_and_keeps_the_readme_for_the_defaults(monkeypatch):
    """``scripts/discovery_testbed.py``: ``--cross-check``, ``--validation`` and ``--no-start-states`` reach
    ``discover()`` for every case alike (the committed JSON of each non-default run is regenerable by its own
    command), and ``--write-readme`` refuses them (the README's tables are the library's defaults)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "scripts" / "discovery_testbed.py"
    spec = importlib.util.spec_from_file_location("discovery_testbed", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    seen = []
    monkeypatch.setattr("hybridhyst.testbed.run.run_bed", lambda cases, jobs, options, cost: seen.append(options) or [])
    monkeypatch.setattr("hybridhyst.testbed.run.markdown", lambda rows: "")
    script.main(["--cases", "viscous", "--cross-check", "report", "--no-start-states"])
    script.main(["--cases", "viscous"])
    assert seen == [{"start_states": False, "cross_check": "report"}, None]
    for bad in (["--cross-check", "report"], ["--validation", "loco"], ["--no-start-states"]):
        with pytest.raises(SystemExit):
            script.main(["--cases", "viscous", "--write-readme", *bad])


# -- (f) the floor: each structure fitted to the held-out records themselves ------------------------------------------


def test_the_floor_fits_each_structure_to_the_held_out_records_themselves():
    """``floor.case_floor``: the nominal, every offered effect and the expected structure, each fitted to the
    held-out record alone (the loop's own nominal phase and candidate fits, that record its only training record,
    every other record held out so that a history carried between records stays the case's). On a single-effect
    case the expected effect is the best single effect and reaches the noise where the nominal does not; an
    unknown option is an error; ``run_bed`` runs it as its task."""
    import torch

    from hybridhyst.data.records import TRAVEL_BEFORE, with_travel_before
    from hybridhyst.testbed import floor
    from hybridhyst.testbed.cases import CASE_BY_NAME
    from hybridhyst.testbed.run import RMSE_RATIO, run_bed

    case = CASE_BY_NAME["maxwell"]
    test = case.records().split(**case.split).test
    old = torch.get_default_dtype()
    try:
        loop = floor._loop(case, test[0].name)
        assert [r.name for r in loop.train] == [test[0].name] and test[0].name not in [r.name for r in loop.test]
        carried = {r.name: r.conditions[TRAVEL_BEFORE] for r in with_travel_before(case.records())}
        assert loop.train[0].conditions[TRAVEL_BEFORE] == carried[test[0].name] > 0  # the travel the case gives it
        assert loop.scales.travel == carried[test[0].name]  # the scale of the carried travel, as the loop takes it
        [row] = run_bed([case], jobs=1, progress=False, task=floor.case_floor, options={"search": 24})
        with pytest.raises(ValueError, match="takes the options 'search' and 'loop' only"):
            floor.case_floor(case, {"validation": "loco"})
    finally:
        torch.set_default_dtype(old)
    assert row["samples"] == sum(len(r) for r in test)
    assert row["expected_structure"] == [["maxwell"]] and row["best_effect_name"] == "maxwell", row
    assert row["expected"] <= RMSE_RATIO < 2 * RMSE_RATIO < row["nominal"], row
    assert row["expected"] <= row["effects"]["maxwell"] + 1e-12  # its start state can only help
    assert row["discovered"] is None and row["loop"] is None


def test_the_loops_own_model_refitted_to_a_held_out_record_is_no_worse_than_its_prediction():
    """``case_floor(..., {"loop": True})`` runs the loop as the bed does and refits its final model to the
    held-out records from its values: an in-sample fit that starts at the prediction can only lower the error."""
    import torch

    from hybridhyst.testbed import floor
    from hybridhyst.testbed.cases import CASE_BY_NAME

    old = torch.get_default_dtype()
    try:
        torch.set_default_dtype(torch.float64)
        row = floor.case_floor(CASE_BY_NAME["linear_stiffness"], {"loop": True, "search": 24})
    finally:
        torch.set_default_dtype(old)
    assert row["loop"]["named"] == ["linear_stiffness"] and row["loop"]["ok"], row["loop"]
    assert row["discovered"] <= row["loop"]["after_over_noise"] * (1 + 1e-6), row
    assert row["discovered"] <= 1.2


def test_the_floor_script_tells_a_miss_of_the_loop_from_a_target_out_of_reach():
    """``scripts/testbed_floor.py``'s verdicts and tallies on rows written by hand: the loop's result decides first
    (a floor that failed does not hide a case the loop met), then whether any structure fitted to the held-out
    records reaches the target, then whether the loop's own model refitted does (generalisation) or only another
    structure (selection); the expected structures of the records are all shown."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "scripts" / "testbed_floor.py"
    spec = importlib.util.spec_from_file_location("testbed_floor", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)

    def row(name, nominal=5.0, expected=5.0, best=5.0, discovered=None, error=None, structure=(("maxwell",),)):
        r = {"name": name, "category": "single", "expected_families": [["maxwell"]], "nominal": nominal,
             "expected": expected, "best_effect": best, "best_effect_name": "lugre", "discovered": discovered,
             "expected_structure": [list(s) for s in structure]}
        return {**r, "error": error} if error else r

    rows = [row("met"), row("general", expected=1.1, discovered=1.0), row("select", best=1.1, discovered=3.0),
            row("plain", expected=1.0), row("out", discovered=2.0), row("failed", error="ValueError: x"),
            row("met_failed", error="ValueError: x"), row("unscored", expected=1.0),
            row("mixed", structure=((), ("maxwell",)))]
    loops = {"met": {"after_over_noise": 1.1, "named": ["maxwell"]}, "met_failed": {"after_over_noise": 0.9},
             **{n: {"after_over_noise": 4.0, "named": []} for n in ("general", "select", "plain", "out", "failed",
                                                                     "mixed")}}
    got = {r["name"]: script.verdict(r, loops.get(r["name"]), 1.2) for r in rows}
    assert got == {"met": "the loop meets it", "met_failed": "the loop meets it", "failed": "error",
                   "general": "the loop's miss: its model fits the record, not from the others (generalisation)",
                   "select": "the loop's miss: another structure fits (selection)", "plain": "the loop's miss",
                   "out": "out of reach", "unscored": "no loop result", "mixed": "out of reach"}
    counts = script.tally(rows, loops, 1.2)
    assert counts == {"cases": 9, "reachable": 5, "loop_meets": 2, "loop_misses": 3, "generalisation_misses": 1,
                      "selection_misses": 1, "out_of_reach": 2, "effect_cases": 9, "expected_best": 0, "errors": 1,
                      "no_loop": 1}
    table = script.markdown(rows, loops, 1.2)
    assert "the nominal / maxwell" in table and table.count("\n| ") == len(rows)
