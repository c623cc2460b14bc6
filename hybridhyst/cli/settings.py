"""The apps' settings objects from their config blocks: every key of the conf/ file's block read (a deleted one is
the config error naming it), then the typed schema of the object (``hybridhyst.settings.from_mapping``)."""

from __future__ import annotations

import os

from omegaconf import DictConfig, OmegaConf

from ..settings import CONF_DIR
from ..training.config import to_plain

__all__ = ["config_block", "identify_settings", "identify_start", "simulation_settings", "start_settings"]


def config_block(block, conf: str, section: str) -> dict:
    """``block`` (an app's config section) as plain values, every key of that section in conf/``conf`` read by item
    access (a deleted one is the config error naming it: the config files are the one source of defaults, so a
    settings object never falls back to its own silently), then any key the user added."""
    defaults = OmegaConf.load(os.path.join(CONF_DIR, conf))[section]
    block = defaults if block is None else block
    return {key: to_plain(block[key]) for key in [*defaults, *(k for k in block if k not in defaults)]}


def simulation_settings(cfg: DictConfig, app: str):
    """The app's ``simulation:`` block as a ``SimulationSettings`` (every key of conf/<app>.yaml's block read, as
    ``config_block``)."""
    from ..simulate import SimulationSettings

    return SimulationSettings.from_config(config_block(cfg.simulation, f"{app}.yaml", "simulation"))


def identify_settings(block, where: str, reserved: tuple[str, ...] = (), /, **given):
    """``IdentifySettings`` from a config block of conf/identify.yaml's ``identify:`` keys with ``given`` laid over
    it (the one conversion of ``hybridhyst-identify``, of ``hybridhyst-fit``'s start, ``hybridhyst-train``'s
    ``nominal_init`` and discovery's first fit): every key of conf/identify.yaml's block is read by item access
    (a deleted one is a config error naming it), and a key ``IdentifySettings`` does not have, a value of the
    wrong type, or a key the app sets itself (``reserved``) is a one-line error naming ``where``."""
    from ..identify import IdentifySettings

    options = config_block(block, "identify.yaml", "identify")
    for key in ("seed", "progress", *reserved):
        if key in options:
            raise ValueError(f"config key {where}.{key} is set by the app itself; leave it out of {where}")
    options.update(given)
    return IdentifySettings.from_config(options, where)


def start_settings(simulation, extra, where: str):
    """``IdentifySettings`` of a search that starts an app's fit (``identify_start``): conf/identify.yaml's
    ``identify:`` block, with the app's ``simulation`` (``SimulationSettings``: the grid the app then simulates on,
    no step doubling of the search's own), no Fisher analysis, then the app's ``extra`` block (``where``: its
    key)."""
    extra = dict(to_plain(extra) or {})
    if isinstance(extra.get("simulation"), dict):  # keys of the app's simulation changed for the search alone
        extra["simulation"] = type(simulation).from_config({**simulation.as_dict(), **extra["simulation"]},
                                                           f"{where}.simulation")
    return identify_settings(None, where, **{"fisher": False, "resolve": False, "simulation": simulation, **extra})


def identify_start(model, records, settings, where: str, fallback: str, *, seed: int, progress: bool):
    """Fit ``model`` in place by ``hybridhyst.identify`` with ``settings`` (``start_settings``): the start of
    ``hybridhyst-fit`` (``fit.start=identify``) and of ``hybridhyst-train``'s nominal (``nominal_init``). A failed
    search is a ``ValueError`` naming ``where`` (the options' key) and ``fallback`` (how to start otherwise)."""
    from ..identify import identify

    try:
        return identify(model, records, settings, seed=seed, progress=progress)
    except ValueError as e:
        raise ValueError(f"{where.split('.')[0]}: the global search on the training records failed: {e} "
                         f"({where}={{bounds: ...}} sets its search box; {fallback})") from e
