"""Articulation: links, joints and the kinematic tree; mass properties; geometric evidence.

:class:`Articulation` is the value the exporters (URDF, MJCF, USD) and the MuJoCo battery take;
:func:`articulate` builds it once from the compiled model (and its evidence). This package sits
below ``export`` in the layer order: it imports ``program`` and ``kernel``, never ``export``.

Example:
    >>> art = articulate(model)                      # doctest: +SKIP
    >>> [l.name for l in art.links], [j.name for j in art.joints]  # doctest: +SKIP
"""

from .mass import MassProps, link_masses
from .tree import (
    Articulation,
    ArticulationError,
    Base,
    Drive,
    Joint,
    JointDof,
    Link,
    articulate,
    default_drive,
    joint_limits,
)


def mates_evidence(model):  # noqa: ANN001, ANN201 - thin lazy wrapper
    """Symmetry axes and contact regions per part (see :mod:`.evidence`)."""
    from .evidence import mates_evidence as _ev
    return _ev(model)


__all__ = ["Articulation", "ArticulationError", "Base", "Drive", "Joint", "JointDof", "Link",
           "MassProps", "articulate", "default_drive", "joint_limits", "link_masses",
           "mates_evidence"]
