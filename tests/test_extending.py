"""The checklists of docs/extending.md, one test per item: adding an effect, a structure, a parameter-function kind
or a bundled dataset is complete only when these pass. Each test names what is missing."""

from __future__ import annotations

import ast
import inspect
import re
import textwrap
from collections import Counter
from pathlib import Path

import pytest
import torch
import yaml

import hybridhyst  # noqa: F401 (registers the synthetic dataset "vpptd")
from hybridhyst.data.builtin import BUILTINS
from hybridhyst.discover.candidates import Scales, effect_candidates
from hybridhyst.physics import build_model, model_config
from hybridhyst.physics.build import STRUCTURES
from hybridhyst.physics.effects import EFFECTS, Effect
from hybridhyst.physics.models import NominalModel
from hybridhyst.physics.parameters import _FUNCTIONS, ParameterFunction, ParameterSpec, build_function
from hybridhyst.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
EFFECTS_DIR = ROOT / "hybridhyst" / "physics" / "effects"
EFFECTS_DOC = ROOT / "docs" / "effects.md"
DATA_FILES = ROOT / "hybridhyst" / "data" / "builtin" / "files"
HOOKS = ("discovery_candidate", "discovery_units", "discovery_fixed", "needs_drive", "example_values")
SYMBOLS = {"F", "x", "t", "u", "n"}  # a unit template's symbols (physics.parameters.render_unit)
CONSTRAINTS = ("positive", "nonnegative", "bounded", "real")
PHYSICAL = [name for name, cls in EFFECTS.items() if cls.specs]


def _admits(spec: ParameterSpec, value: float) -> bool:
    return bool(spec.admits(torch.tensor(float(value))))


def _check_spec(where: str, spec, own_units: bool) -> list[str]:
    """What is wrong with one parameter declaration."""
    if not isinstance(spec, ParameterSpec):
        return [f"{where} is a {type(spec).__name__}, not a ParameterSpec"]
    out = []
    if not spec.unit or not spec.doc.strip():
        out.append(f"{where} needs a unit template and a doc (ParameterSpec(unit=..., doc=...))")
    tokens = set(re.findall(r"[A-Za-z_]+", spec.unit or ""))
    if not own_units and not tokens <= SYMBOLS:
        out.append(f"{where}: unit {spec.unit!r} uses {sorted(tokens - SYMBOLS)}, not the model's symbols "
                   f"{sorted(SYMBOLS)} (or override param_unit)")
    if spec.constraint not in CONSTRAINTS:
        out.append(f"{where}: constraint {spec.constraint!r} is not one of {CONSTRAINTS}")
    if not spec.bounds[0] < spec.bounds[1]:
        out.append(f"{where}: search bounds {spec.bounds} are empty")
    if not _admits(spec, spec.default):
        out.append(f"{where}: default {spec.default} is outside its domain ({spec.constraint}, {spec.bounds})")
    if spec.neutral is not None and not _admits(spec, spec.neutral):
        out.append(f"{where}: neutral value {spec.neutral} is outside its domain")
    return out


# -------------------------------------------------------------------------------------------------------- effects
def test_every_effect_file_holds_one_registered_effect():
    files = {p.stem for p in EFFECTS_DIR.glob("*.py")} - {"__init__", "base"}
    modules = Counter(cls.__module__ for cls in EFFECTS.values())
    twice = sorted(m for m, n in modules.items() if n > 1)
    assert not twice, f"one effect per file: {twice} hold several registered effects"
    outside = sorted(f"{n} ({c.__module__})" for n, c in EFFECTS.items()
                     if c.__module__.rpartition(".")[0] != "hybridhyst.physics.effects")
    assert not outside, f"registered effects defined outside hybridhyst/physics/effects/: {outside}"
    registered = {m.rpartition(".")[2] for m in modules}
    assert files == registered, (f"files without a registered effect: {sorted(files - registered)}; register "
                                 "their class in EFFECTS (hybridhyst/physics/effects/__init__.py)")


def test_the_registry_is_keyed_by_each_effects_name():
    wrong = {key: getattr(cls, "name", None) for key, cls in EFFECTS.items()
             if not (isinstance(cls, type) and issubclass(cls, Effect) and cls.name == key)}
    assert not wrong, f"EFFECTS keys must be each Effect subclass's `name`: {wrong}"
    defaults = sorted(k for k, cls in EFFECTS.items() if "name" not in cls.__dict__)
    assert not defaults, f"effects that inherit their `name` instead of declaring it: {defaults}"


@pytest.mark.parametrize("name", EFFECTS)
def test_every_effect_documents_itself(name):
    cls = EFFECTS[name]
    assert (cls.__dict__.get("__doc__") or "").strip(), f"effect {name!r} needs a class docstring"
    assert cls.equation.strip() and cls.source.strip(), f"effect {name!r} needs `equation` and `source`"


@pytest.mark.parametrize("name", EFFECTS)
def test_every_parameter_declares_a_unit_a_description_and_a_default_in_its_domain(name):
    cls = EFFECTS[name]
    own_units = cls.param_unit is not Effect.param_unit
    problems = [p for kind, specs in (("specs", cls.specs), ("start", cls.start)) for pname, spec in specs.items()
                for p in _check_spec(f"{name}.{kind}[{pname!r}]", spec, own_units)]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("name", PHYSICAL)
def test_every_effect_declares_example_values(name):
    cls = EFFECTS[name]
    values = cls.__dict__.get("example_values") or {}
    assert set(values) == set(cls.specs), (f"effect {name!r}: example_values must give every parameter "
                                           f"{sorted(cls.specs)}, got {sorted(values)}")
    for pname, value in values.items():
        spec = cls.specs[pname]
        inside = spec.bounds[0] < value < spec.bounds[1] if spec.constraint == "bounded" else _admits(spec, value)
        assert inside, f"effect {name!r}: example value {pname} = {value} is outside its domain"
        assert spec.neutral is None or value != spec.neutral, (
            f"effect {name!r}: example value {pname} = {value} is its neutral value; take one that exercises it")
    cls(**values)


def test_an_effect_without_parameters_is_not_a_discovery_candidate():
    offered = sorted(n for n, cls in EFFECTS.items() if not cls.specs and cls.discovery_candidate)
    assert not offered, f"effects without physical parameters must set discovery_candidate = False: {offered}"


def test_the_compiled_path_test_reads_example_values():
    """tests/test_fast.py compares every registered effect (but networks and what needs a control channel) at its
    own example_values: a new effect is covered by its registration, not by a list to extend."""
    from tests import test_fast

    expected = {name: dict(cls.example_values) for name, cls in EFFECTS.items()
                if name != "neural" and name not in test_fast.CONTROL_EFFECTS}
    assert test_fast.EFFECT_VALUES == expected


def _class_body(cls) -> tuple[list[ast.stmt], list[str]]:
    source = textwrap.dedent(inspect.getsource(cls))
    return ast.parse(source).body[0].body, source.splitlines()


def test_every_discovery_hook_is_declared_on_effect_with_its_doc():
    body, lines = _class_body(Effect)
    for hook in HOOKS:
        found = [i for i, node in enumerate(body)
                 if isinstance(node, (ast.Assign, ast.AnnAssign))
                 and hook in [t.id for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
                              if isinstance(t, ast.Name)]]
        assert found, f"Effect declares no class attribute {hook!r}"
        i = found[0]
        after = body[i + 1] if i + 1 < len(body) else None
        doc_after = (isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                     and isinstance(after.value.value, str))
        comment_before = lines[body[i].lineno - 2].strip().startswith("#")
        assert doc_after or comment_before, f"Effect.{hook} needs its doc (a string after it or a comment above)"
    source = (ROOT / "hybridhyst" / "discover" / "candidates.py").read_text(encoding="utf-8")
    read = {node.args[1].value for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "getattr" and len(node.args) >= 2
            and isinstance(node.args[1], ast.Constant)}
    undeclared = sorted(a for a in read if not hasattr(Effect, a))
    assert not undeclared, f"discover/candidates.py reads hooks that Effect does not declare: {undeclared}"


def test_the_candidates_module_names_no_effect():
    """Discovery decides what to offer from the hooks, not from a list of names; the one effect it builds itself
    is the lag it offers per control channel (``control_candidates``)."""
    source = (ROOT / "hybridhyst" / "discover" / "candidates.py").read_text(encoding="utf-8")
    literals = {node.value for node in ast.walk(ast.parse(source))
                if isinstance(node, ast.Constant) and isinstance(node.value, str)}
    named = sorted((literals & set(EFFECTS)) - {"control_lag"})
    assert not named, (f"discover/candidates.py names effects {named}; declare discovery_candidate / needs_drive "
                       "on the effect instead")


@pytest.mark.parametrize("structure", ["constitutive", "oscillator"])
def test_discovery_offers_exactly_the_declared_candidates(structure):
    present = "viscous"
    model = build_model(structure, {present: {"effect": present, "c": 0.1},
                                    "stiffness": {"effect": "linear_stiffness", "k": 1.0}})
    offered = {c.name for c in effect_candidates(model, Scales(F=1.0, x=1.0, v=1.0, u=1.0))}
    expected = {n for n, cls in EFFECTS.items() if cls.discovery_candidate
                and (structure == "oscillator" or not cls.needs_drive)} - {present, "linear_stiffness"}
    assert offered == expected, (f"offered but not declared: {sorted(offered - expected)}; declared but not "
                                 f"offered: {sorted(expected - offered)}")


@pytest.mark.parametrize("name", EFFECTS)
def test_the_discovery_hooks_name_real_parameters(name):
    cls = EFFECTS[name]
    assert isinstance(cls.discovery_candidate, bool) and isinstance(cls.needs_drive, bool)
    assert set(cls.discovery_fixed) <= set(cls.specs), f"{name}.discovery_fixed names no parameter of it"
    assert set(cls.discovery_units) <= set(cls.specs), f"{name}.discovery_units names no parameter of it"
    scales = Scales(F=2.0, x=3.0, v=5.0, u=7.0)
    for pname, template in cls.discovery_units.items():
        assert scales.of_unit(template) is not None, f"{name}.discovery_units[{pname!r}] = {template!r} is not a unit"
    for pname, value in cls.discovery_fixed.items():
        spec = cls.specs[pname]
        inside = spec.bounds[0] <= value <= spec.bounds[1] if spec.constraint == "bounded" else _admits(spec, value)
        assert inside, f"{name}.discovery_fixed holds {pname} = {value}, outside its domain"
    if cls.discovery_candidate:
        cls(**cls.discovery_fixed, fixed=sorted(cls.discovery_fixed))


@pytest.mark.parametrize("name", EFFECTS)
def test_special_cases_name_registered_effects(name):
    for case in EFFECTS[name].special_cases:
        unknown = [e for e in case if e not in EFFECTS]
        assert case and not unknown, f"{name}.special_cases names unregistered effects {unknown or case}"


@pytest.mark.parametrize("name", EFFECTS)
def test_every_effect_is_in_the_effects_doc(name):
    assert f"### `{name}`" in EFFECTS_DOC.read_text(encoding="utf-8"), (
        f"docs/effects.md lacks {name!r}: run PYTHONPATH=. python scripts/docs_effects.py")


# ----------------------------------------------------------------------------------------------------- structures
@pytest.mark.parametrize("name", STRUCTURES)
def test_every_structure_implements_its_equations(name):
    cls = STRUCTURES[name]
    assert issubclass(cls, NominalModel), f"structure {name!r} must subclass NominalModel"
    missing = [m for m in ("kinematics", "derivative", "output", "output_dim") if m not in cls.__dict__]
    assert not missing, f"structure {name!r} ({cls.__name__}) does not define {missing}"


@pytest.mark.parametrize("name", STRUCTURES)
def test_every_structure_documents_itself_and_its_parameters(name):
    cls = STRUCTURES[name]
    assert (cls.__dict__.get("__doc__") or "").strip(), f"structure {name!r} needs a class docstring"
    problems = [p for pname, spec in cls.structure_specs.items()
                for p in _check_spec(f"{name}.structure_specs[{pname!r}]", spec, own_units=False)]
    assert not problems, "\n".join(problems)
    assert f"### `{name}` (`{cls.__name__}`)" in EFFECTS_DOC.read_text(encoding="utf-8"), (
        f"docs/effects.md lacks structure {name!r}: run PYTHONPATH=. python scripts/docs_effects.py")


def _small_model(structure: str) -> NominalModel:
    return build_model(structure, {"viscous": {"effect": "viscous", "c": 0.3},
                                   "stiffness": {"effect": "linear_stiffness", "k": 2.0},
                                   "friction": {"effect": "dahl", "sigma0": 5.0, "Fc": 1.0}},
                       units={"x": "mm", "F": "N", "t": "s"}, name=f"small_{structure}")


@pytest.mark.parametrize("name", STRUCTURES)
def test_every_structure_round_trips_through_its_config(name):
    model = _small_model(name)
    cfg = model_config(model)
    assert cfg["structure"] == name, f"model_config writes structure {cfg['structure']!r} for {name!r}"
    again = build_model(**{k: v for k, v in cfg.items() if k != "_target_"})
    assert type(again) is type(model)
    for key, value in model.state_dict().items():
        torch.testing.assert_close(again.state_dict()[key], value, msg=key)


@pytest.mark.parametrize("name", STRUCTURES)
def test_every_structure_simulates_the_same_on_both_backends(name):
    model = _small_model(name).double()
    t = torch.linspace(0.0, 2.0, 201, dtype=torch.float64)
    x = torch.sin(2 * torch.pi * t)[None]
    with torch.no_grad():
        ref = simulate(model, x, t=t, backend="reference")
        fast = simulate(model, x, t=t, backend="fast")
    torch.testing.assert_close(fast, ref, rtol=1e-8, atol=1e-10)


# ------------------------------------------------------------------------------------------ parameter functions
# one config per kind: a new kind is complete when it has one here (docs/extending.md)
FUNCTION_EXAMPLES = {
    "constant": {"kind": "constant", "value": 1.5},
    "fixed": {"kind": "fixed", "value": 2.0},
    "linear": {"kind": "linear", "slope": 3.0, "intercept": 1.0, "condition": "p"},
    "polynomial": {"kind": "polynomial", "coeffs": [1.0, 2.0, -0.5], "condition": "p"},
    "exp_rise": {"kind": "exp_rise", "y0": 1.0, "a": 2.0, "b": 3.0, "condition": "p"},
    "exp_decay": {"kind": "exp_decay", "y0": 1.0, "a": 2.0, "b": 3.0, "condition": "p"},
    "exp_growth": {"kind": "exp_growth", "y0": 1.0, "a": 2.0, "b": 3.0, "condition": "p"},
    "per_condition": {"kind": "per_condition", "levels": [0.1, 0.2], "values": [1.0, 2.0], "condition": "p"},
    "neural": {"kind": "neural", "base": 1.0, "condition": "p", "hidden": 4},
}
CONDITIONS = {"p": torch.tensor([0.1, 0.2])}
FOLLOWS = [k for k, cls in _FUNCTIONS.items() if cls.at is not ParameterFunction.at]


def test_every_kind_has_an_example():
    assert set(FUNCTION_EXAMPLES) == set(_FUNCTIONS), (
        f"give FUNCTION_EXAMPLES (tests/test_extending.py) a config of every kind: missing "
        f"{sorted(set(_FUNCTIONS) - set(FUNCTION_EXAMPLES))}, "
        f"unknown {sorted(set(FUNCTION_EXAMPLES) - set(_FUNCTIONS))}")


@pytest.mark.parametrize("kind", sorted(FUNCTION_EXAMPLES))
def test_every_kind_round_trips_through_its_config(kind):
    fn = build_function(dict(FUNCTION_EXAMPLES[kind]))
    assert type(fn) is _FUNCTIONS[kind]
    config = fn.config()
    again = build_function(dict(config) if isinstance(config, dict) else config)
    if kind != "fixed":  # a number builds a constant; the fixed kind is written as its value (held by `fixed:`)
        assert type(again) is type(fn), f"{kind}: config() {config!r} builds a {type(again).__name__}"
    with torch.no_grad():
        torch.testing.assert_close(again(CONDITIONS, 2), fn(CONDITIONS, 2))


@pytest.mark.parametrize("kind", sorted(FUNCTION_EXAMPLES))
def test_every_kind_declares_its_coordinates(kind):
    fn = build_function(dict(FUNCTION_EXAMPLES[kind]))
    coords, values = fn.coordinates(), fn.coordinate_values()
    assert len(coords) == values.numel() == len(fn.suffixes())
    with torch.no_grad():
        torch.testing.assert_close(fn.evaluate_batch(values[None], CONDITIONS, 2)[0], fn(CONDITIONS, 2))
        fn.set_coordinates(values.detach().clone())
        torch.testing.assert_close(fn.coordinate_values(), values)


@pytest.mark.parametrize("kind", FOLLOWS)
def test_a_kind_that_follows_a_control_agrees_with_itself(kind):
    fn = build_function(dict(FUNCTION_EXAMPLES[kind]))
    with torch.no_grad():
        coords = [v.expand(2) for v in fn.coordinate_values()]
        torch.testing.assert_close(fn.at(coords, CONDITIONS["p"]), fn(CONDITIONS, 2))


@pytest.mark.parametrize("kind", sorted(_FUNCTIONS))
def test_every_kind_is_in_the_effects_doc(kind):
    assert f"| `{kind}` |" in EFFECTS_DOC.read_text(encoding="utf-8"), (
        f"docs/effects.md lacks the kind {kind!r}: run PYTHONPATH=. python scripts/docs_effects.py")


# -------------------------------------------------------------------------------------------------------- datasets
@pytest.mark.parametrize("name", sorted(BUILTINS))
def test_every_dataset_has_its_data_config(name):
    path = ROOT / "conf" / "data" / f"{name}.yaml"
    assert path.is_file(), f"dataset {name!r} needs conf/data/{name}.yaml"
    cfg = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert cfg.get("_target_") == "hybridhyst.data.load_builtin" and cfg.get("name") == name, path
    options = set(inspect.signature(BUILTINS[name]).parameters)
    assert set(cfg) - {"_target_", "name"} <= options, f"conf/data/{name}.yaml: keys that are no option of the loader"


@pytest.mark.parametrize("name", sorted(BUILTINS))
def test_every_dataset_is_bundled_with_its_source_and_licence_or_made_here(name):
    module = BUILTINS[name].__module__
    folder = DATA_FILES / name
    if module.startswith("hybridhyst.synth"):  # simulated: nothing third-party to attribute
        assert not folder.exists(), f"{folder} holds files of a synthetic dataset"
        return
    assert module == f"hybridhyst.data.builtin.{name}", (
        f"dataset {name!r}: its loader belongs in hybridhyst/data/builtin/{name}.py")
    for required in ("SOURCE.md", "ATTRIBUTION.md"):
        assert (folder / required).is_file(), f"dataset {name!r} needs {folder.relative_to(ROOT)}/{required}"
    assert list(folder.glob("LICENSE*")), f"dataset {name!r} needs its licence text in {folder.relative_to(ROOT)}/"


def test_every_data_folder_belongs_to_a_registered_dataset():
    folders = {p.name for p in DATA_FILES.iterdir() if p.is_dir()}
    assert folders <= set(BUILTINS), f"data folders without a registered dataset: {sorted(folders - set(BUILTINS))}"


@pytest.mark.parametrize("name", sorted(BUILTINS))
def test_every_loader_documents_its_options(name):
    loader = BUILTINS[name]
    doc = loader.__doc__ or ""
    assert doc.strip(), f"the loader of {name!r} needs a docstring"
    missing = [p for p in inspect.signature(loader).parameters if p not in doc]
    assert not missing, f"the loader of {name!r} does not document its options {missing}"


@pytest.mark.parametrize("name", sorted(BUILTINS))
def test_every_dataset_is_listed_in_the_readme(name):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("\n## Data and licences", 1)[1].split("\n## ", 1)[0]
    assert f"`data={name}`" in section, f"README 'Data and licences' does not list `data={name}`"
    if (DATA_FILES / name).exists():
        assert f"hybridhyst/data/builtin/files/{name}/" in section, (
            f"README 'Data and licences' does not point to hybridhyst/data/builtin/files/{name}/")
