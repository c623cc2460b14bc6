"""scripts/brfd_tension.py: the structure builder rebuilds a discovery report's final model (fast, no fitting)."""

import importlib.util
from pathlib import Path

import pytest
import torch

from hybridhyst.physics.compositions import dahl_friction

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "brfd_tension.py"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("brfd_tension", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _report(params: dict, final: list[str]) -> dict:
    return {"effects": {"final": final}, "after": {"parameters": {k: {"value": v, "unit": "-"} for k, v in
                                                                   params.items()}}}


def test_structure_round_trips(script):
    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    try:
        nominal = dahl_friction().double()
        params = {"coulomb.Fc": 0.2, "coulomb.v_s": 0.05, "bouc_wen.alpha": 0.0, "bouc_wen.k": 10.0,
                  "bouc_wen.k1": 0.0, "bouc_wen.D": 1.0, "bouc_wen.A": 1.0, "bouc_wen.beta": 90.0,
                  "bouc_wen.gamma": -50.0, "bouc_wen.n": 2.5, "backlash.r": 0.01,
                  "dahl.sigma0": 3.0, "dahl.Fc": "+0.3·amplitude_in^0 -0.05·amplitude_in^1"}
        model = script.build_structure(_report(params, ["coulomb", "bouc_wen", "backlash", "dahl"]), nominal)
        table = model.parameter_table()
        assert list(model.effects)[0] == "backlash"  # the input operator goes first
        for name, value in params.items():
            key, p = name.split(".")
            if isinstance(value, float):
                assert table[key][p]["value"] == pytest.approx(value)
        assert table["coulomb"]["v_s"]["fixed"] and not table["coulomb"]["Fc"]["fixed"]  # as in the nominal
        assert table["bouc_wen"]["A"]["fixed"] and not table["bouc_wen"]["beta"]["fixed"]  # discovery_fixed
        assert model.effects["dahl"].params["Fc"].coeffs.tolist() == pytest.approx([0.3, -0.05])
        with pytest.raises(ValueError, match="effects.final"):
            script.build_structure(_report({"coulomb.Fc": 0.2}, ["coulomb", "dahl"]), nominal)
    finally:
        torch.set_default_dtype(old)
