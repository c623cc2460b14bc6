"""The closed loop: fit the nominal, diagnose the residual, name and add the missing effect, report."""

from .candidates import Candidate, Scales, condition_candidates, effect_candidates, library_candidates
from .diagnose import diagnose, features, structure_explained
from .loop import DiscoveryResult, discover
from .rule import information_criterion
from .settings import DiscoverSettings

__all__ = ["Candidate", "DiscoverSettings", "DiscoveryResult", "Scales", "condition_candidates", "diagnose", "discover",
           "effect_candidates", "features", "information_criterion", "library_candidates", "structure_explained"]
