"""Hydra entry points. Each app is a plain ``run(cfg) -> dict`` plus a thin ``main()`` (its ``@hydra.main``
function run through ``common.hydra_entry`` and ``common.guarded``: errors are one line, exit code 2).

* ``hybridhyst-simulate`` (``hybridhyst.cli.simulate``, ``conf/simulate.yaml``)
* ``hybridhyst-fit`` (``hybridhyst.cli.fit``, ``conf/fit.yaml``)
* ``hybridhyst-identify`` (``hybridhyst.cli.identify``, ``conf/identify.yaml``)
* ``hybridhyst-train`` (``hybridhyst.cli.train``, ``conf/train.yaml``)
* ``hybridhyst-discover`` (``hybridhyst.cli.discover``, ``conf/discover.yaml``)
* ``hybridhyst-study`` (``hybridhyst.cli.study``, ``conf/study.yaml``)
* ``hybridhyst-report`` (``hybridhyst.cli.report``, argparse)

Records are chosen by ``split.select`` / ``split.held_out`` / ``split.val`` in every app; a bundled dataset's
choices for an app are ``conf/data/<app>/<data>.yaml``.
"""
