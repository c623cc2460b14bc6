"""The only place where time is integrated (see DESIGN.md "Packages and their one job")."""

from .api import resolved_substeps as resolved_substeps
from .api import simulate as simulate
from .fixed import ORDER as ORDER

__all__ = ["ORDER", "resolved_substeps", "simulate"]
