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
        bearing_radius_factor: mate gate: registration area counts only within
            ``bearing_radius_factor * d + pcd / 2`` of the mate axis (pcd: the bolt circle of a
            bolt_pattern or flange, else 0), so a part slid along its parent's face does not
            register.
        mate_region_factor: a mate's feature region, in its frame: ``|xy| <= k d + pcd / 2``,
            ``|z| <= k d + depth + length + travel`` with k this factor; only a common solid
            reaching into it may be allowed by the mate's fit (interference gate).
        boolean_pair_budget: the exact common of two parts (mate and interference gates, B3)
            runs when at most this many face pairs (one face of each part, boxes grown by
            ``crop_margin_mm``) overlap: OCCT's boolean costs about what those pairs cost
            (about 0.6 ms a pair here; 5000 pairs is a few seconds). Over it, both solids are
            cropped to their boxes' overlap and counted again; a pair still over it is **not
            verified** (a warning, never a pass and never a blocking error).
        crop_margin_mm: the region two parts can meet in is their boxes' overlap grown by this;
            it also grows the face boxes counted against ``boolean_pair_budget``.
        common_deflection_rel: a common solid is meshed for its depth at this fraction of its
            smallest box side (between common_deflection_min_mm and mesh_linear_mm).
        common_deflection_min_mm: the finest such deflection.
        part_piece_findings: a part with detached pieces gets at most this many findings
            naming pieces (then one counting the rest).
        mesh_linear_mm: tessellation linear deflection floor: every part is meshed with
            ``max(mesh_linear_mm, mesh_linear_rel * diagonal of its bounding box)``.
        mesh_linear_rel: linear deflection as a fraction of the part's bbox diagonal; parts up
            to ``mesh_linear_mm / mesh_linear_rel`` (1 m) across get the 0.1 mm floor, larger
            ones a deflection that grows with them, so a part's triangle count no longer grows
            with its size (``Sphere(1e5)`` meshed at 0.1 mm needed 10 GB).
        mesh_angular_rad: tessellation angular deflection (fixed).
        mesh_max_triangles: a part whose triangle count, estimated from its B-rep before
            meshing (:mod:`procedura_brep.mesh_budget`) or counted after, exceeds this is
            refused with an error naming the part and the figure instead of being meshed.
        sim_mesh_max_faces: meshes handed to MuJoCo (URDF/MJCF visual and collision STL) have
            at most this many triangles: MuJoCo's STL decoder refuses more than 200,000 faces.
        sim_mesh_coarsen: a part over ``sim_mesh_max_faces`` is re-tessellated for MuJoCo with
            its linear deflection multiplied by this (angular by its square root) until it fits.
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
        hold_drift_deg: battery B1: the most a position-held revolute (or a limited cylindrical
            turn, or a ball, by its rotation angle) may drift from its home after the settle.
            B1 holds with an integral term, so a servo with the effort to carry its load ends
            within micro-degrees of home: what is left is the effort's shortfall. 1 deg is about
            the backlash of a plain spur gearhead, the most an engineer would let a held joint
            droop without asking for a stronger drive.
        hold_drift_mm: battery B1: the same for a prismatic joint (a cylindrical slide), mm:
            1 mm is a coarse general tolerance (ISO 2768-c is +-0.8 mm at 30-120 mm).
        hold_tip_mm: battery B1: the most a held joint's drift alone may move the far end of
            its child subtree (any corner of a subtree geom's box, every other joint at home),
            mm. 3 mm is a droop one sees at the end of a desk-sized arm, well above its fits'
            tenths of a millimetre; it catches a drift under ``hold_drift_deg`` on a long
            lever (0.5 deg at 400 mm is 3.5 mm).
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
        sweep_max_cells: battery B2: a part's cover has at most about this many cells: a part
            whose surface area needs more at ``sweep_cell_mm`` gets cells of side
            ``sqrt(area / sweep_max_cells)`` (a coarser cover, still conservative: more poses
            reach the exact check). A 6 m sphere needed 5e7 cells at 1.5 mm.
        sweep_max_booleans: battery B2: the most exact booleans one joint's sweep may run. A
            sweep that needs more (a part that overlaps its neighbours at every pose) stops and
            B2 fails with a finding naming the joint and the pose reached, instead of running
            for minutes. The recorded 31-part drill press needs at most 235 for one joint.
        sweep_time_s: battery B2: the most wall-clock seconds one joint's exact sweep may run
            (checked between booleans and between poses; a single OCCT boolean cannot be
            interrupted). A sweep that runs longer stops and the rest of its range is **not
            verified**, as with ``sweep_max_booleans``: a threaded lead screw swept against its
            threaded nut spent 17 minutes of CPU in one joint's booleans.
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
        normal_crease_deg: GLB vertex normals: two triangles sharing an edge are shaded smooth
            across it when their normals differ by less than this (curved surfaces, whose
            neighbouring triangles differ by at most ~``mesh_angular_rad``); sharper edges
            (box edges, chamfers) split the vertex normals and stay crisp.
        origin_offset_factor: origin gate (``gates/origin.py``): a part whose body lies farther
            from its own origin than this many times its own size (the largest side of its
            local bounding box), with its mounting frame out there at the body (within the same
            distance of the box), is drawn at its assembly position (a ``part-origin`` warning;
            the staged agent retries the part). The root is judged on its body alone.
        origin_offset_min_mm: the origin gate's limit is never below this (tiny parts: a
            2 mm pin drawn 3 mm off its origin is not the mistake the gate looks for).
        coupling_axis_deg: a coupling's two joint axes are parallel (gear, belt, screw) or
            square (rack and pinion) within this angle (``program/couplings.py``).
        coupling_ratio_rel: battery B8: a coupling's measured driven/driver ratio is within
            this fraction of the declared one.
        coupling_cut_mm: battery B8: a linkage's cut joint stays closed within this distance
            while its driver moves.
        coupling_centre_mm: coupling gate: a gear pair's centre distance is (z1 +- z2) m / 2,
            a pinion's axis lies its pitch radius from the rack's pitch line, and a nut's slide
            axis is the screw's axis, each within this (``gates/coupling.py``).
        coupling_module_rel: coupling gate: a gear's module measured from its tip circle agrees
            with the declared one (rack and pinion) and with its partner's within this fraction.
        coupling_lead_rel: coupling gate: a lead screw's (and its nut's) thread lead, measured
            from its helical edges, agrees with the coupling's ``lead`` within this fraction.
            The measurement is exact to about 1e-6 of the lead on ``lead_screw``; standard
            leads a typo swaps (2, 2.5, 3, 4, 5, 8 mm; metric pitches 1.25 / 1.5 / 1.75) lie at
            least 14 % apart.
        coupling_samples: coupling gate: poses over one tooth pitch of the driver (rest
            included) at which a meshing pair's exact common is computed.
        coupling_time_s: coupling gate: the sampled interference check of one model stops
            (reporting the pairs it did not reach as not verified) after this many seconds.
    """

    placement_mm: float = 1e-6
    placement_rad: float = 1e-9
    residual_mm: float = 1e-3
    residual_rad: float = 1e-6
    contact_mm: float = 1e-3
    connect_mm: float = 0.05
    bearing_angle_deg: float = 30.0
    bearing_radius_factor: float = 1.0
    mate_region_factor: float = 2.0
    boolean_pair_budget: int = 5000
    crop_margin_mm: float = 0.05
    common_deflection_rel: float = 0.05
    common_deflection_min_mm: float = 1e-4
    part_piece_findings: int = 8
    mesh_linear_mm: float = 0.1
    mesh_linear_rel: float = 1e-4
    mesh_angular_rad: float = 0.35
    mesh_max_triangles: int = 2_000_000
    sim_mesh_max_faces: int = 200_000
    sim_mesh_coarsen: float = 2.0
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
    hold_drift_deg: float = 1.0
    hold_drift_mm: float = 1.0
    hold_tip_mm: float = 3.0
    drive_min_ratio: float = 0.3
    symmetry_eig_rel: float = 0.02
    contact_plane_cos: float = 0.99995
    sweep_rest_interference_mm: float = 1e-3
    sweep_box_slack_mm: float = 0.01
    sweep_step_mm: float = 1.0
    sweep_cell_mm: float = 1.5
    sweep_max_cells: int = 200_000
    sweep_max_booleans: int = 1500
    sweep_time_s: float = 60.0
    nonconvex_ratio: float = 1.3
    normal_crease_deg: float = 30.0
    wheel_axis_deg: float = 1.0
    wheel_centre_mm: float = 0.5
    wheel_ground_mm: float = 1.0
    drive_max_yaw_deg: float = 5.0
    origin_offset_factor: float = 1.0
    origin_offset_min_mm: float = 5.0
    coupling_axis_deg: float = 0.5
    coupling_ratio_rel: float = 0.01
    coupling_cut_mm: float = 0.1
    coupling_centre_mm: float = 0.05
    coupling_module_rel: float = 0.02
    coupling_lead_rel: float = 0.01
    coupling_samples: int = 7
    coupling_time_s: float = 60.0


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
        source_bytes: a program longer than this (UTF-8 bytes) is refused before it is parsed
            (the goldens are 8-22 KB; 1 MiB leaves room for a few hundred parts).
        message_chars: every finding message and exception text is cut to this many
            characters at its source (the child), so a hostile ``raise ValueError("A" * 10**8)``
            cannot flood the report, the terminal or the model's feedback.
        result_bytes: the parent refuses a child's ``result.json`` larger than this.
        max_parts: parts per program.
        max_part_solids: solids in one part's final shape (a part is one solid unless its
            function declares otherwise; a few hundred covers a tread or a bolt circle).
        max_model_solids: solids over the whole model.
        max_part_faces: B-rep faces of one part (a detailed casting has a few thousand).
        max_model_faces: faces over the whole model.
        max_extent_mm: largest side of a part's bounding box, and of the placed model's: 10 m
            covers furniture, vehicles and robots in mm (a 3 m-radius sphere passes); a
            city block does not.
        max_part_triangles: estimated triangles of one part at the fixed meshing tolerance
            (``TOL.mesh_linear_mm`` / ``TOL.mesh_angular_rad``), from each face's area and
            curvature radius (:mod:`procedura_brep.program.caps`).
        max_model_triangles: the same estimate summed over the model.
    """

    cpu_s: int = 60
    wall_s: float = 90.0
    address_space_bytes: int = 6 * 1024**3
    file_size_bytes: int = 256 * 1024**2
    open_files: int = 256
    recursion: int = 2000
    source_bytes: int = 1024**2
    message_chars: int = 2000
    result_bytes: int = 512 * 1024**2
    max_parts: int = 500
    max_part_solids: int = 256
    max_model_solids: int = 2048
    max_part_faces: int = 20_000
    max_model_faces: int = 200_000
    max_extent_mm: float = 10_000.0
    max_part_triangles: int = 2_000_000
    max_model_triangles: int = 8_000_000


TOL = Tolerances()
SANDBOX = SandboxLimits()


@dataclass(frozen=True)
class TerminalLimits:
    """What the CLI prints of text that came from a program or a model (see ``text.py``).

    Attributes:
        message_chars: a message longer than this is cut on the terminal (the full text stays
            in report.json), with a note of how many characters were left out.
    """

    message_chars: int = 2000


TERMINAL = TerminalLimits()


@dataclass(frozen=True)
class ParentLimits:
    """Limits of the forked child that meshes, exports, gates and simulates a compiled model
    (``procedura_brep.limited``), so a blow-up there is a one-line error with report.json
    written, never a dead or hung CLI.

    Attributes:
        address_space_bytes: RLIMIT_AS of the child. It includes what the CLI process has
            already mapped (about 1.5 GiB of libraries after its imports).
        wall_s: the child is killed after this many wall-clock seconds.
    """

    address_space_bytes: int = 12 * 1024**3
    wall_s: float = 1800.0


PARENT = ParentLimits()


@dataclass(frozen=True)
class MaterialLimits:
    """Ranges of a program's own material declarations (``material(...)``, see
    :mod:`procedura_brep.materials`) and the materials stage of the staged agent.

    Attributes:
        density_range: allowed density in kg/m^3: from aerogel-like foams (a few kg/m^3) to
            osmium (22,590); anything outside is a typo in units.
        max_declared: most materials one program may declare.
        subparts_triangle_tol: the materials stage's sub-part pass may rewrite a part only if
            the rewritten part's triangle count (at the fixed meshing tolerance) stays within
            this fraction of the original's, so paint never changes shape.
        paint_volume_rtol: a colour block (``@paint``) conserves volume: the blocks plus the
            rest of the painted part must add up to the unpainted part within this fraction of
            its volume (the booleans are exact; this only absorbs OCCT's volume integration).
        paint_min_fraction: a block smaller than this fraction of the unpainted part's volume
            is a region that misses the part; a rest smaller than it leaves the part empty. A
            region that takes more than this fraction of a mate feature's volume cuts the
            feature away.
        reply_attempts: tries of a materials, material_critic or subparts call whose reply does not parse
            (each retry is told the parse error).
    """

    density_range: tuple[float, float] = (1.0, 25_000.0)
    max_declared: int = 64
    subparts_triangle_tol: float = 0.02
    paint_volume_rtol: float = 1e-6
    paint_min_fraction: float = 1e-6
    reply_attempts: int = 2


MATERIAL = MaterialLimits()
