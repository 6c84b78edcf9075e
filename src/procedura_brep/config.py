"""Every tolerance and fixed setting in one documented object (trimesh ``constants.py`` habit).

Call sites never write a bare tolerance: they read ``TOL`` (geometry) or ``SANDBOX`` (limits).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerances:
    """Geometric tolerances, lengths in millimetres, angles in radians unless named ``_deg``.

    Attributes:
        placement_mm: max distance between a child's mate frame and its parent's after placement.
        placement_rad: max angle between those frames.
        residual_mm: a secondary static mate whose residual exceeds this is reported as a finding.
        residual_rad: same, for rotation.
        contact_mm: two faces closer than this are in contact (contact regions, evidence).
        connect_mm: two pieces closer than this are connected (connectivity gate); large
            enough to bridge ISO 286 fit clearances (tens of micrometres).
        bearing_angle_deg: mate gate: child faces within this angle of -Z of the mate frame
            (and parent faces of +Z) are bearing faces.
        penetration_fill_box: mate gate: an interference solid filling at least this fraction
            of its mate-frame box is block-like (a gouge: depth = its smallest side); thinner
            ones are fit rings (depth = wall thickness 2V/A).
        mesh_linear_mm: tessellation linear deflection for every shipped mesh (fixed).
        mesh_angular_rad: tessellation angular deflection (fixed).
        mesh_weld_mm: vertices closer than this are welded before topology is counted.
        degenerate_area_mm2: triangles with less area are dropped (OCCT poles, fillet corners).
        span_tau: connectivity gate threshold on rho = span(component) / span(model).
        registration_tau: mate gate: registration area must reach tau_a * d^2.
        registration_band_mm: faces within this distance of each other count as registered.
        penetration_slack_mm: added to the fit's own interference to give delta_max(fit).
        sharp_dihedral_deg: Shrp60 threshold.
        volume_rel: relative volume tolerance in golden comparisons.
        bbox_mm: absolute bbox tolerance in golden comparisons.
        sim_penetration_mm: battery B2/B3: exact-solid interference thicker than this (2V/S)
            counts as penetration.
        sim_anchor_m: battery B0/B5/B6: max joint anchor disagreement between an export and
            the mate graph, metres.
        sim_axis_rad: battery B0/B5/B6: max joint axis disagreement, radians.
        sim_mass_rel: battery B5: max relative link mass disagreement after URDF re-import.
        sweep_reach: battery B2: fraction of its range a position-driven joint must reach.
        sweep_separation_m: battery B2: max separation of a child's joint anchor from its
            parent's during a sweep, metres.
        settle_joint_speed: battery B1: max joint speed (rad/s or m/s) after the settle.
        drive_min_ratio: battery B4: min ratio of travelled to ideal rolling distance.
        symmetry_eig_rel: articulation evidence: two surface-covariance eigenvalues closer than
            this fraction of the largest are equal (symmetry axes).
        contact_plane_cos: articulation evidence: two triangle normals with a dot product above
            this are parallel (contact planes).
        sweep_rest_interference_mm: battery B2: a pair thicker than this at rest is interfering
            at rest (checked by B3 and the mate gate) and is not swept.
        sweep_box_slack_mm: battery B2: slack added to the box prefilters of the sweep.
        sweep_step_mm: battery B2: the most any point of a moved part that can come near a
            fixed part travels between two sweep samples (so a fin this thick cannot be
            stepped over).
        sweep_cell_mm: battery B2: side of the surface cells whose sphere cover prefilters the
            exact checks (smaller: fewer booleans near contacts, more cells to query).
        wheel_axis_deg: articulation: a wheel's symmetry axis is parallel to its joint axis
            within this angle.
        wheel_centre_mm: articulation: a wheel's symmetry axis passes this close to its joint
            axis line.
        wheel_ground_mm: articulation: a wheel's lowest point is within this of the model's
            lowest point (the floor).
        drive_max_yaw_deg: battery B4: the most the base may turn while one uniform command
            drives every wheel (a straight drive).
        nonconvex_ratio: exports: a mesh component whose convex hull volume exceeds its own
            volume by this factor is decomposed into convex collision pieces (CoACD).
    """

    placement_mm: float = 1e-6
    placement_rad: float = 1e-9
    residual_mm: float = 1e-3
    residual_rad: float = 1e-6
    contact_mm: float = 1e-3
    connect_mm: float = 0.05
    bearing_angle_deg: float = 30.0
    penetration_fill_box: float = 0.5
    mesh_linear_mm: float = 0.1
    mesh_angular_rad: float = 0.35
    mesh_weld_mm: float = 1e-5
    degenerate_area_mm2: float = 1e-10
    span_tau: float = 0.01
    registration_tau: float = 0.05
    registration_band_mm: float = 0.05
    penetration_slack_mm: float = 0.01
    sharp_dihedral_deg: float = 60.0
    volume_rel: float = 1e-6
    bbox_mm: float = 1e-3
    sim_penetration_mm: float = 0.1
    sim_anchor_m: float = 1e-6
    sim_axis_rad: float = 1e-6
    sim_mass_rel: float = 1e-6
    sweep_reach: float = 0.97
    sweep_separation_m: float = 3e-3
    settle_joint_speed: float = 0.05
    drive_min_ratio: float = 0.3
    symmetry_eig_rel: float = 0.02
    contact_plane_cos: float = 0.99995
    sweep_rest_interference_mm: float = 1e-3
    sweep_box_slack_mm: float = 0.01
    sweep_step_mm: float = 1.0
    sweep_cell_mm: float = 1.5
    nonconvex_ratio: float = 1.3
    wheel_axis_deg: float = 1.0
    wheel_centre_mm: float = 0.5
    wheel_ground_mm: float = 1.0
    drive_max_yaw_deg: float = 5.0


@dataclass(frozen=True)
class SandboxLimits:
    """Resource limits for one sandboxed compile (a forked child of the warm worker).

    Attributes:
        cpu_s: RLIMIT_CPU of the child; the kernel sends SIGXCPU then SIGKILL.
        wall_s: the parent kills the child after this many wall-clock seconds.
        address_space_bytes: RLIMIT_AS; a memory bomb fails with MemoryError or is killed.
        file_size_bytes: RLIMIT_FSIZE; the child may only write in its scratch dir anyway.
        open_files: RLIMIT_NOFILE.
        recursion: Python recursion limit in the child.
    """

    cpu_s: int = 60
    wall_s: float = 90.0
    address_space_bytes: int = 6 * 1024**3
    file_size_bytes: int = 256 * 1024**2
    open_files: int = 256
    recursion: int = 2000


TOL = Tolerances()
SANDBOX = SandboxLimits()
