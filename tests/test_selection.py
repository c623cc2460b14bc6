"""Selection that removes and swaps (``discover.selection.simplify``): a flexible effect that plays the part of a
simpler one is replaced by it, and one that is needed is kept. Data from numpy (arctan sign), not the library."""

import math

import numpy as np
import pytest

from hybridhyst.data.records import Record
from hybridhyst.discover.candidates import Scales
from hybridhyst.discover.fitting import polish
from hybridhyst.discover.rule import Acceptance, Judged
from hybridhyst.discover.selection import simplify
from hybridhyst.discover.validation import rmse_on
from hybridhyst.physics.effects import Coulomb, LinearStiffness, Stribeck, Viscous
from hybridhyst.physics.models import Constitutive
from hybridhyst.simulate import SimulationSettings

SIM = SimulationSettings(backend="reference")
OPTS = {"lm_steps": 25, "box_factor": 10.0}

pytestmark = pytest.mark.usefixtures("float64")  # tests/conftest.py


def _records(dFs: float, vs: float, seed: int = 0) -> list[Record]:
    """F = 2x + 0.2v + (0.4 + dFs e^{-(v/vs)^2}) (2/π) arctan(v / 0.01), sines at 0.5 and 1 in, 1 Hz."""
    rng = np.random.default_rng(seed)
    out = []
    for amp in (0.5, 1.0):
        t = np.arange(0, 2.0, 1 / 100)
        x, v = -amp * np.cos(2 * np.pi * t), 2 * np.pi * amp * np.sin(2 * np.pi * t)
        level = 0.4 + dFs * np.exp(-((v / vs) ** 2))
        y = 2 * x + 0.2 * v + level * (2 / np.pi) * np.arctan(v / 0.01) + 0.01 * rng.standard_normal(len(t))
        out.append(Record(f"a{amp}", t, x, y, conditions={"amplitude_in": amp}))
    return out


def _stribeck_model(vs: float):
    return Constitutive({"spring": LinearStiffness(k=1.5), "viscous": Viscous(c=0.1),
                         "stribeck": Stribeck(dFs=0.3, vs=vs, v_s=0.01)}).double()


def _run(fit, records, sim, rivals=None, settled=False):
    """``simplify`` with the loop's default rule, the training error as the score; (fit, changes as in the
    report)."""
    rule = Acceptance(0.02, "bic", sum(len(r) for r in records))
    now = Judged(rmse_on(fit.model, records, sim), rule.ic(fit))
    fit, _, changes = simplify(fit, now, records, sim, Scales.of(records), rule, lambda m, s: rmse_on(m, records, s),
                               OPTS, rivals=rivals, settled=settled)
    return fit, [c.as_json() for c in changes]


def _simplify(records, model):
    return _run(polish(model, records, SIM, 25, 10.0), records, SIM)




def test_stribeck_playing_coulomb_is_replaced_by_coulomb():
    fit, changes = _simplify(_records(0.0, 1.0), _stribeck_model(vs=30.0))
    names = [e.name for e in fit.model.effects.values()]
    assert [c["kind"] for c in changes] == ["replaced"] and changes[0]["by"] == ["coulomb"], changes
    assert "stribeck" not in names and "coulomb" in names
    fc = float(fit.model.effects["coulomb"].params["Fc"].value.detach())
    assert math.isclose(fc, 0.4, rel_tol=0.05)


def test_a_drift_that_levelled_off_before_the_record_is_replaced_by_the_constant_term():
    """A stiffness drift with travel that levels off at once (λ large: the spring is built up within a fiftieth of
    an inch of travel) is a constant spring: from a nominal without its spring, the loop took such a drift for the
    missing spring, which held its place beside the friction added next (4 parameters for 1) and extrapolated to
    the held-out records through its carried travel. Its special case, the constant term, replaces it."""
    from hybridhyst.physics.effects import TravelStiffness

    model = Constitutive({"viscous": Viscous(c=0.1), "coulomb": Coulomb(Fc=0.3, v_s=0.01, fixed=["v_s"]),
                          "travel_stiffness": TravelStiffness(dk=80.0, lam=50.0)}).double()
    fast = SimulationSettings(backend="fast")  # the compiled loop (its equality with the reference: test_fast.py)
    records = _records(0.0, 1.0)
    fit, changes = _run(polish(model, records, fast, 25, 10.0), records, fast)
    assert [(c["kind"], c["by"], c["replacement"]) for c in changes] == [
        ("replaced", ["linear_stiffness"], "special_case")], changes
    k = float(fit.model.effects["linear_stiffness"].params["k"].value.detach())
    assert math.isclose(k, 2.0, rel_tol=0.02), k


def test_a_needed_stribeck_stays():
    fit, changes = _simplify(_records(0.4, 1.0), _stribeck_model(vs=1.0))
    assert changes == [] and "stribeck" in fit.model.effects


def test_an_effect_whose_contribution_vanished_is_removed():
    model = Constitutive({"spring": LinearStiffness(k=1.5), "viscous": Viscous(c=0.1),
                          "coulomb": Coulomb(Fc=0.3, v_s=0.01, fixed=["v_s"]),
                          "extra": Viscous(c=0.0)}).double()
    fit, changes = _simplify(_records(0.0, 1.0), model)
    assert [c["kind"] for c in changes] == ["removed"] and changes[0]["key"] in ("viscous", "extra")
    assert len(fit.model.effects) == 3


def test_special_cases_name_library_effects():
    from hybridhyst.physics.effects import EFFECTS

    for name, cls in EFFECTS.items():
        for case in cls.special_cases:
            assert case and all(n in EFFECTS and n != name for n in case), (name, case)


def test_an_added_effect_is_swapped_for_a_finalist_it_beat_only_when_the_loop_names_it():
    """F = x + 0.8x³ + 0.2v + 0.4 arctan sign: a hardening Bouc–Wen (γ < 0) plays the cubic spring. Its special
    cases (Dahl) cannot, so without rivals it stays; given the finalist it beat when it was added
    (``rivals``, what the loop passes once it has stopped), it is replaced by the cubic spring, fitted near 0.8."""
    from hybridhyst.physics.effects import BoucWenHysteresis

    rng = np.random.default_rng(0)
    records = []
    for amp in (0.5, 1.0):
        t = np.arange(0, 2.0, 1 / 100)
        x, v = -amp * np.cos(2 * np.pi * t), 2 * np.pi * amp * np.sin(2 * np.pi * t)
        y = x + 0.8 * x**3 + 0.2 * v + 0.4 * (2 / np.pi) * np.arctan(v / 0.01) + 0.01 * rng.standard_normal(len(t))
        records.append(Record(f"a{amp}", t, x, y, conditions={"amplitude_in": amp}))
    model = Constitutive({"spring": LinearStiffness(k=1.0), "viscous": Viscous(c=0.2),
                          "coulomb": Coulomb(Fc=0.4, v_s=0.01, fixed=["v_s"]),
                          "bouc_wen": BoucWenHysteresis(alpha=0.0, k=0.3, k1=0.0, D=1.0, A=1.0, beta=0.0, gamma=-0.3,
                                                        n=2.0, fixed=["alpha", "k1", "D", "A"])}).double()
    sim = SIM.replace(backend="fast")  # a hysteretic state: the compiled loop
    fit = polish(model, records, sim, 25, 10.0)

    def run(rivals, settled=False):
        return _run(fit, records, sim, rivals, settled)

    kept, changes = run(None)
    assert changes == [] and "bouc_wen" in kept.model.effects
    swapped, changes = run({"bouc_wen": ["cubic_stiffness"]})
    assert [(c["effect"], c["kind"], c["by"]) for c in changes] == [("bouc_wen", "replaced", ["cubic_stiffness"])]
    # Bouc–Wen is not among the cubic spring's special cases, nor the other way round: a swap for a runner-up,
    # recorded and reported so (before: "lugre replaced by its special case bouc_wen")
    from hybridhyst.discover.report import change_sentence

    assert changes[0]["replacement"] == "rival_swap"
    text = change_sentence({**changes[0], "after_step": 2}, "validation", "kip")
    assert "**bouc_wen** swapped for cubic_stiffness" in text and "special case cubic" not in text, text
    special = {"effect": "stribeck", "by": ["coulomb"], "replacement": "special_case", "after_step": 1,
               "val_rmse_before": 0.5, "val_rmse_after": 0.49}
    assert "**stribeck** replaced by its special case coulomb after step 1" in change_sentence(special, "validation",
                                                                                              "kip")
    removed = {**special, "by": [], "replacement": None}
    assert "removed: its contribution vanished" in change_sentence(removed, "validation", "kip")
    (cubic,) = [e for e in swapped.model.effects.values() if e.name == "cubic_stiffness"]
    assert math.isclose(float(cubic.params["k3"].value.detach()), 0.8, rel_tol=0.05)
    assert "bouc_wen" not in {e.name for e in swapped.model.effects.values()}
    # the loop's final pass (the model already simplified): the swap alone in the first round, the same result
    settled, changes = run({"bouc_wen": ["cubic_stiffness"]}, settled=True)
    assert [(c["effect"], c["by"]) for c in changes] == [("bouc_wen", ["cubic_stiffness"])]
    assert settled.sse == pytest.approx(swapped.sse, rel=1e-9)


def test_a_settled_model_is_not_simplified_again_without_a_rival():
    """``settled``: the model has been through the removals already, so the first round tries rivals only; with
    none, a removal that would qualify (a vanished extra damper) is not made (the loop's final pass does not
    repeat its last step's work)."""
    model = Constitutive({"spring": LinearStiffness(k=1.5), "viscous": Viscous(c=0.1),
                          "coulomb": Coulomb(Fc=0.3, v_s=0.01, fixed=["v_s"]),
                          "extra": Viscous(c=0.0)}).double()
    records = _records(0.0, 1.0)
    fit = polish(model, records, SIM, 25, 10.0)
    _, changes = _run(fit, records, SIM, settled=True)
    assert changes == [] and len(fit.model.effects) == 4


def _dahl_records(z0: float) -> list[Record]:
    """F = 2x + 0.2v + Dahl (σ0 10, Fc 0.5), its deflection z0 at each record's start: Dahl integrated exactly in
    displacement (z relaxes towards ±Fc/σ0 as e^(−travel σ0/Fc) over each monotone step) on a 20× finer path."""
    rng = np.random.default_rng(3)
    sigma0, L = 10.0, 0.05  # L = Fc / σ0, Fc 0.5
    out = []
    for amp in (0.5, 1.0):
        t = np.arange(0, 2.0 + 1e-9, 1 / 200)
        tf = np.linspace(0, t[-1], 20 * (len(t) - 1) + 1)
        xf = -amp * np.cos(2 * np.pi * tf)
        z, zs = z0, [z0]
        for dx in np.diff(xf):
            s = np.sign(dx)
            z = s * L + (z - s * L) * math.exp(-abs(dx) / L) if s else z
            zs.append(z)
        x, v = -amp * np.cos(2 * np.pi * t), 2 * np.pi * amp * np.sin(2 * np.pi * t)
        y = 2 * x + 0.2 * v + sigma0 * np.asarray(zs)[::20] + 0.01 * rng.standard_normal(len(t))
        out.append(Record(f"a{amp}", t, x, y, conditions={"amplitude_in": amp}))
    return out


def test_a_special_case_takes_over_the_start_state_of_the_effect_it_replaces():
    # a clearance whose gap has closed is Dahl; the records start with the element deflected (z0 = -0.04), which
    # the clearance's fitted start state carries: Dahl replaces it only with a start state of its own, free
    from hybridhyst.physics.effects import Clearance

    records = _dahl_records(-0.04)
    model = Constitutive({"spring": LinearStiffness(k=2.0), "viscous": Viscous(c=0.2),
                          "clearance": Clearance(sigma0=10.0, Fc=0.5, r=1e-4, q0=-0.03)}).double()
    sim = SimulationSettings(substeps=2)
    fit, changes = _run(polish(model, records, sim, 25, 10.0), records, sim)
    assert [(c["effect"], c["by"]) for c in changes] == [("clearance", ["dahl"])]
    dahl = fit.model.effects["dahl"]
    assert float(dahl.params["z0"].value.detach()) == pytest.approx(-0.04, rel=0.1)


def test_a_swap_seeds_the_new_start_state_at_the_replaced_ones_and_ignores_a_held_one():
    from hybridhyst.discover.selection import ways_to_simplify
    from hybridhyst.physics.effects import Clearance

    records = _dahl_records(-0.04)
    scales = Scales.of(records)

    def swap(clearance):
        model = Constitutive({"spring": LinearStiffness(k=2.0), "clearance": clearance}).double()
        fit = polish(model, records, SimulationSettings(substeps=2), 0, 10.0)
        return next(c for case, _, c, _ in ways_to_simplify(fit, "clearance", scales) if case == ("dahl",))

    cand = swap(Clearance(sigma0=10.0, Fc=0.5, r=1e-4, q0=-0.03))
    assert "dahl.z0" in cand.free
    seeded = [s["dahl.z0"] for s in cand.starts]
    # the fitted q0 with every start of Dahl's parameters, then the start candidates' grid
    n = len({tuple(sorted((k, v) for k, v in s.items() if k != "dahl.z0")) for s in cand.starts})
    assert seeded[:n] == [pytest.approx(-0.03)] * n and 0.0 in seeded[n:]
    held = swap(Clearance(sigma0=10.0, Fc=0.5, r=1e-4, q0=-0.03, fixed=["q0"]))
    assert "dahl.z0" not in held.free  # a start state the user held is not a fitted one


def test_a_first_step_that_stood_in_for_two_effects_is_revisited(float64):
    """The first bed's delayed friction damper (its own generator: F = 2x + 0.3v + 0.5 v/√(v²+0.05²) read 15 ms
    late) from spring + viscous, no friction declared: Dahl's presliding lag stands in for the friction and the
    delay at the first step, and then neither a delay nor Coulomb alone helps. ``revisit`` tries Dahl replaced by
    its special case, Coulomb, with one more effect from there: the delay, at the noise held out; without it the
    loop ends with Dahl above twice the noise."""
    from hybridhyst.discover import discover
    from hybridhyst.testbed.cases import CASE_BY_NAME

    case = CASE_BY_NAME["time_delay"]
    records = case.records()

    def run(revisit):
        nominal = case.nominal()
        nominal = nominal.with_effects({k: e for k, e in nominal.effects.items() if k != "coulomb"})
        return discover(records, nominal, candidates=["dahl", "coulomb", "time_delay", "maxwell"], split=case.split,
                        conditions=False, noise_sd=case.noise, progress=False, revisit=revisit).report

    plain, revisited = run(False), run(True)
    assert "dahl" in plain["effects"]["final"] and plain["after"]["test_rmse"] > 2 * case.noise
    assert {"coulomb", "time_delay"} <= set(revisited["effects"]["final"])
    assert "dahl" not in revisited["effects"]["final"]
    assert revisited["after"]["test_rmse"] < 1.2 * case.noise
    step = next(s for s in revisited["steps"] if s.get("when") == "revisit")
    assert step["effect"] == "coulomb+time_delay" and step["replaces"] == "dahl"
    change = next(c for c in revisited["removed"] if c["replacement"] == "revisit")
    assert change["effect"] == "dahl" and change["by"] == ["coulomb", "time_delay"]
