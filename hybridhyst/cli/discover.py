"""``hybridhyst-discover``: the closed loop on measured data (``hybridhyst.discover``).

Default (``conf/discover.yaml``): the measured BRFD friction damper at 36 lb band tension from a Coulomb +
viscous + Dahl nominal; train on the 0.5 and 1.5 in characterisation tests, validate on the 1 in tests,
test on the earthquake records. Writes ``discovery.json``, ``report.md``, ``residuals.png``, ``loops.png``
and ``config.yaml`` into the run directory (``hydra.run.dir=...``).
"""

from __future__ import annotations

import hydra
from omegaconf import DictConfig

from ..data.datamodule import decimation_factors
from ..data.records import RecordSet
from ..discover import discover
from ..discover.report import write_discovery
from .common import CONF_DIR, check_app, guarded, instantiate, prepare_run_dir, to_plain, torch_settings

__all__ = ["load_records", "main", "run"]


def load_records(cfg: DictConfig) -> RecordSet:
    """The selected records, thinned (``cfg.thinning``)."""
    records = instantiate(cfg.data, _convert_="all")
    select = to_plain(cfg.get("select")) or {}
    records = records.select(**select)
    if len(records) == 0:
        raise ValueError(f"data selection {select} leaves no records")
    th = cfg.thinning
    factors = decimation_factors(records, th.samples_per_cycle, th.downsample, th.frequency_condition)
    return RecordSet([r.slice(step=factors[r.name]) if factors[r.name] > 1 else r for r in records], records.name)


def run(cfg: DictConfig) -> dict:
    """Discover, write the run directory, return ``discovery.json``'s content."""
    check_app(cfg, "discover")
    run_dir = prepare_run_dir(cfg)
    d = cfg.discover
    with torch_settings(cfg.dtype, cfg.get("threads"), cfg.get("seed")):
        records = load_records(cfg)
        model = instantiate(cfg.model, _convert_="all").double()
        result = discover(records, model, candidates=to_plain(d.candidates), split=to_plain(cfg.split),
                          conditions=to_plain(d.conditions), label_conditions=to_plain(d.get("label_conditions")),
                          margin=float(d.margin), criterion=d.criterion,
                          max_steps=int(d.max_steps), top=int(d.top), lm_steps=int(d.lm_steps),
                          noise_sd=d.noise_sd, fit_nominal=bool(d.fit_nominal),
                          identify_options={**to_plain(d.identify), "seed": int(cfg.seed)}, backend=d.backend,
                          method=d.method, substeps=int(d.substeps), progress=bool(cfg.progress))
    unit = records.records[0].units.get("y", "")
    write_discovery(result, run_dir, title=cfg.title, unit=unit)
    return result.report


@hydra.main(config_path=CONF_DIR, config_name="discover", version_base="1.3")
def main(cfg: DictConfig) -> None:
    """Console entry point ``hybridhyst-discover`` (Hydra overrides on the command line)."""
    guarded(run, cfg)


if __name__ == "__main__":
    main()
