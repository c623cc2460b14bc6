"""Hydra entry points. Each app is a plain ``run(cfg) -> dict`` plus a thin ``@hydra.main`` ``main()``.

* ``hybridhyst-simulate`` (``hybridhyst.cli.simulate``, ``conf/simulate.yaml``)
* ``hybridhyst-fit`` (``hybridhyst.cli.fit``, ``conf/fit.yaml``)
"""
