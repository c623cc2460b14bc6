"""Comparison reports over many ``hybridhyst-train`` run directories (``hybridhyst-report``).

``collect_runs`` reads every ``metrics.json`` below some folders into one table; ``summary_table`` and
``condition_table`` compare configurations (mean ± std over seeds); ``write_report`` writes
``report.md``, ``summary.csv``, ``per_condition.csv`` and ``figures/*.png``.
"""

from .collect import collect_runs as collect_runs
from .collect import find_run_dirs as find_run_dirs
from .markdown import write_report as write_report
from .tables import condition_stats as condition_stats
from .tables import condition_table as condition_table
from .tables import failed_table as failed_table
from .tables import summary_table as summary_table

__all__ = [
    "collect_runs",
    "condition_stats",
    "condition_table",
    "failed_table",
    "find_run_dirs",
    "summary_table",
    "write_report",
]
