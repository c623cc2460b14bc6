"""The settings objects and their one typed schema (``hybridhyst.settings.from_mapping``, ``check_fields``)."""

import pytest

from hybridhyst.discover import DiscoverSettings, discover
from hybridhyst.identify import IdentifySettings, identify
from hybridhyst.settings import UnknownOption
from hybridhyst.simulate import SimulationSettings


def test_a_config_block_becomes_typed_settings_with_nested_simulation():
    s = IdentifySettings.from_config({"search": "de", "pop": 16.0, "bounds": {"viscous.c": [0.1, 2]},
                                      "simulation": {"substeps": 4, "backend": "reference"}})
    assert (s.search, s.pop, s.bounds) == ("de", 16, {"viscous.c": (0.1, 2)}) and isinstance(s.pop, int)
    assert s.simulation == SimulationSettings(substeps=4, backend="reference")
    assert s.simulation.at(8).substeps == 8 and s.simulation.substeps == 4  # frozen: at() is a copy


@pytest.mark.parametrize("block,message", [
    ({"popsize": 8}, "unknown config key identify.popsize: did you mean identify.pop?"),
    ({"pop": "many"}, "identify.pop must be a whole number, got 'many'"),
    ({"pop": 2.5}, "identify.pop must be a whole number"),
    ({"fisher": "yes"}, "identify.fisher must be true or false"),
    ({"simulation": {"substep": 2}}, "unknown config key identify.simulation.substep: did you mean "
                                     "identify.simulation.substeps?"),
    ({"search": "pso"}, "unknown search 'pso'"),
])
def test_a_bad_config_block_is_one_line_naming_the_key(block, message):
    with pytest.raises(ValueError, match=message.replace("?", r"\?").replace("(", r"\(")):
        IdentifySettings.from_config(block)


def test_simulation_settings_refuse_what_cannot_run():
    with pytest.raises(ValueError, match="fast backend|backend='fast' runs the fixed-step solver only"):
        SimulationSettings(solver="torchdiffeq", method="dopri5")
    with pytest.raises(ValueError, match="unknown fixed-step method 'rk5'"):
        SimulationSettings(method="rk5")
    with pytest.raises(ValueError, match="substeps must be a whole number >= 1"):
        SimulationSettings(substeps=0)


def test_a_renamed_option_names_its_new_name_in_a_python_call():
    with pytest.raises(UnknownOption, match="identify.method was renamed: use search") as e:
        identify(None, [], method="de")
    assert isinstance(e.value, TypeError) and isinstance(e.value, ValueError)
    renamed = r"discover.backend was renamed: use simulation=SimulationSettings\(backend"
    with pytest.raises(UnknownOption, match=renamed):
        discover([], None, backend="reference")
    with pytest.raises(UnknownOption, match="did you mean discover.margin"):
        DiscoverSettings().replace(margn=0.05)
    with pytest.raises(UnknownOption, match="did you mean simulation.substeps"):
        SimulationSettings().replace(substep=4)
    assert SimulationSettings().at(4) == SimulationSettings(substeps=4)
