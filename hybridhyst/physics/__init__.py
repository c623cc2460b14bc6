"""Physics: constrained parameters, the effect library, structures and the seeds' compositions."""

from .build import build_effect as build_effect
from .build import build_model as build_model
from .build import model_config as model_config
from .models import Constitutive as Constitutive
from .models import DrivenOscillator as DrivenOscillator
from .models import NominalModel as NominalModel

__all__ = ["Constitutive", "DrivenOscillator", "NominalModel", "build_effect", "build_model", "model_config"]
