"""Articulation: links, joints and the kinematic tree; mass properties; geometric evidence.

Example:
    >>> art = articulate(model)                      # doctest: +SKIP
    >>> [l.name for l in art.links], [j.name for j in art.joints]  # doctest: +SKIP
"""

from .mass import MassProps, link_masses
from .tree import Articulation, ArticulationError, Joint, Link, articulate, joint_limits


def mates_evidence(model):  # noqa: ANN001, ANN201 - thin lazy wrapper
    """Symmetry axes and contact regions per part (see :mod:`.evidence`)."""
    from .evidence import mates_evidence as _ev
    return _ev(model)


__all__ = ["Articulation", "ArticulationError", "Joint", "Link", "MassProps", "articulate",
           "joint_limits", "link_masses", "mates_evidence"]
