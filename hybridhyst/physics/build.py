"""Build a nominal model from a plain config (a Hydra ``conf/model/*.yaml`` or a dict)."""

from __future__ import annotations

from .models import Constitutive, DrivenOscillator, NominalModel

__all__ = ["build_effect", "build_model", "model_config", "rebuilt_model"]

STRUCTURES = {"constitutive": Constitutive, "oscillator": DrivenOscillator}


def _plain(cfg) -> dict:
    try:  # OmegaConf containers → plain python
        from omegaconf import DictConfig, OmegaConf

        if isinstance(cfg, DictConfig):
            return OmegaConf.to_container(cfg, resolve=True)
    except ImportError:  # pragma: no cover
        pass
    return dict(cfg)


def build_effect(key: str, cfg):
    """One effect from ``{"effect": "<library name>", <param>: value | function config, ...}``."""
    from .effects import EFFECTS

    cfg = _plain(cfg)
    name = cfg.pop("effect", None)
    if name is None:
        raise ValueError(f"effect {key!r} needs an 'effect:' entry naming one of {sorted(EFFECTS)}")
    if name not in EFFECTS:
        import difflib

        close = difflib.get_close_matches(name, list(EFFECTS), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"effect {key!r}: unknown effect {name!r}{hint}; the library has {sorted(EFFECTS)}")
    try:
        return EFFECTS[name](**cfg)
    except ValueError as err:  # the effect names its kind; the model config's key says which one of them
        text = str(err)
        if text.startswith(f"effect {name!r}"):
            raise ValueError(f"effect {key!r} ({name})" + text[len(f"effect {name!r}"):]) from None
        raise


def build_model(structure: str = "constitutive", effects: dict | None = None, units: dict | None = None,
                name: str = "model", **structure_options) -> NominalModel:
    """Compose a nominal model.

    Parameters
    ----------
    structure : "constitutive" (damper law, response = Σ forces along the prescribed excitation) or
        "oscillator" (m ẍ + Σ forces = g u, or base excitation).
    effects : ordered mapping ``key -> {"effect": name, **parameters}``; order matters for input operators.
    units : {"x": ..., "F": ..., "u": ..., "t": ...} used to render parameter units.
    structure_options : for "oscillator": mass, drive_gain, excitation, outputs, fixed.
    """
    if structure not in STRUCTURES:
        raise ValueError(f"unknown structure {structure!r}; choose one of {sorted(STRUCTURES)}")
    if not effects:
        raise ValueError(f"model {name!r} has no effects; list at least one under 'effects:'")
    built = {key: build_effect(key, cfg) for key, cfg in _plain(effects).items()}
    if structure == "constitutive" and structure_options:
        raise ValueError(f"a constitutive model takes no structure options, got {sorted(structure_options)}")
    return STRUCTURES[structure](built, units=_plain(units) if units else None, name=name, **structure_options)


def model_config(model: NominalModel) -> dict:
    """The config ``build_model`` builds ``model`` back from, with its current parameter values: structure,
    name, units, every effect (``Effect.config``) and, for an oscillator, its structure options. A model
    found by discovery or identification can so be written as a ``conf/model/*.yaml`` and used by every app.

    A network's weights (a neural effect or parameter function) are not config values: the config gives its
    form, and the model's state dict (``model.pt``) its weights.
    """
    from .parameters import Fixed

    structure = next((key for key, cls in STRUCTURES.items() if type(model) is cls), None)
    if structure is None:
        raise ValueError(f"{type(model).__name__} is not one of the structures {sorted(STRUCTURES)}")
    cfg = {"_target_": "hybridhyst.physics.build_model", "name": model.name, "structure": structure,
           "units": dict(model.units), "effects": {key: effect.config() for key, effect in model.effects.items()}}
    if structure == "oscillator":
        cfg.update(excitation=model.excitation, outputs=list(model.outputs),
                   fixed=[k for k, fn in model.structure_params.items() if isinstance(fn, Fixed)],
                   **{k: fn.config() for k, fn in model.structure_params.items()})
    return cfg


def rebuilt_model(config: dict, state: dict) -> NominalModel:
    """The model ``model_config`` and ``state_dict`` were taken from, built back (its dtype the state's)."""
    model = build_model(**{k: v for k, v in config.items() if k != "_target_"})
    dtype = next((v.dtype for v in state.values() if v.is_floating_point()), None)
    if dtype is not None:
        model = model.to(dtype)
    model.load_state_dict(state)
    return model
