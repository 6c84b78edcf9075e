"""The typed mate vocabulary: fits (ISO 286 / ISO 273), types with DOF signatures, joint kinds,
placement.

Cheap to import: :mod:`.features` (which imports build123d) is loaded only by the compiler, and
:mod:`.placement` (numpy) only by the type methods that compute a ``Delta``.
"""

from .fits import FIT_CLASSES, Fit, FitClass, iso273, iso286
from .kinds import JOINT_KINDS, JointKind, Motion, joint_kind
from .vocabulary import (
                         KINEMATIC_TYPES,
                         STATIC_TYPES,
                         TYPES,
                         CylindricalType,
                         Dof,
                         MateType,
                         PrismaticType,
                         RevoluteType,
                         SphericalType,
                         check_options,
                         get_type,
)

__all__ = ["FIT_CLASSES", "Fit", "FitClass", "iso273", "iso286", "JOINT_KINDS", "JointKind",
           "Motion", "joint_kind", "KINEMATIC_TYPES", "STATIC_TYPES", "TYPES", "CylindricalType",
           "Dof", "MateType", "PrismaticType", "RevoluteType", "SphericalType", "check_options",
           "get_type"]
