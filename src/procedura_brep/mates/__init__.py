"""The typed mate vocabulary: fits (ISO 286 / ISO 273), types with DOF signatures, placement.

Cheap to import: :mod:`.features` (which imports build123d) is loaded only by the compiler.
"""

from .fits import FIT_CLASSES, Fit, FitClass, iso273, iso286
from .vocabulary import KINEMATIC_TYPES, STATIC_TYPES, TYPES, Dof, MateType, check_options, get_type

__all__ = ["FIT_CLASSES", "Fit", "FitClass", "iso273", "iso286", "KINEMATIC_TYPES",
           "STATIC_TYPES", "TYPES", "Dof", "MateType", "check_options", "get_type"]
