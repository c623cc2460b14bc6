"""Identification of nominal-model parameters from records.

``fit_gradient`` (local, Adam + L-BFGS on the model's own parameters) and ``identify`` (batched global
search — differential evolution, CMA-ES, Monte Carlo or a grid — with gradient refinement of several
restarts in one batch and an identifiability analysis at the optimum).
"""

from .fisher import FisherReport as FisherReport
from .fisher import fisher_analysis as fisher_analysis
from .fisher import output_jacobian as output_jacobian
from .gradient import FitResult as FitResult
from .gradient import fit_gradient as fit_gradient
from .identify import IdentificationResult as IdentificationResult
from .identify import identify as identify
from .problem import RecordsProblem as RecordsProblem
from .refine import RefineResult as RefineResult
from .refine import refine as refine
from .search import SearchResult as SearchResult
from .search import cma_es as cma_es
from .search import differential_evolution as differential_evolution
from .search import grid_search as grid_search
from .search import monte_carlo as monte_carlo
from .search import safe_costs as safe_costs
from .settings import IdentifySettings as IdentifySettings
from .space import Box as Box
from .space import Coordinate as Coordinate
from .space import SearchSpace as SearchSpace

__all__ = [
    "Box", "Coordinate", "FisherReport", "FitResult", "IdentificationResult", "IdentifySettings", "RecordsProblem",
    "RefineResult",
    "SearchResult", "SearchSpace", "cma_es", "differential_evolution", "fisher_analysis", "fit_gradient",
    "grid_search", "identify", "monte_carlo", "output_jacobian", "refine", "safe_costs",
]
