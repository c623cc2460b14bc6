"""The only place where time is integrated (docs/architecture.md)."""

from .api import Prepared as Prepared
from .api import coarsest_substeps as coarsest_substeps
from .api import jacobian_covers as jacobian_covers
from .api import resolved_substeps as resolved_substeps
from .api import row_jacobian as row_jacobian
from .api import simulate as simulate
from .api import simulate_jacobian as simulate_jacobian
from .api import simulate_resolved as simulate_resolved
from .fixed import ORDER as ORDER
from .settings import SimulationSettings as SimulationSettings

__all__ = ["ORDER", "Prepared", "SimulationSettings", "coarsest_substeps", "jacobian_covers", "resolved_substeps",
           "row_jacobian", "simulate", "simulate_jacobian", "simulate_resolved"]
