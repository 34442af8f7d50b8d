"""The one table of Model / State / Control / Scratch fields: name, dtype, shape, unit.

Everything else follows from it: the Warp structs the step kernel reads (``structs``), the
device arrays the Stepper allocates (``allocate``) and the check that a host model carries
exactly the model's fields (``HostModel``). Shapes are symbolic: ``body`` (every scene body,
fixed ones included), ``free`` (free bodies), ``joint``, ``env`` (environments), the
statistics columns, ``problem`` (PROBLEM_COLUMNS), ``point`` (contact points: collision
vertices and sphere centres), ``plane`` (static half-spaces), ``shape`` (fixed bodies'
collision geometries: static boxes, spheres, capsules, cylinders, triangles), ``edge`` and
``face`` (moving bodies' edges and triangles, each body's consecutive), ``static_edge`` and
``static_vertex`` (the static shapes' edges and corners), ``touch`` (pairs of free bodies that
may touch each other), ``body_end`` and ``touch_end`` (one more than ``body``, ``touch``),
``touch_chunk`` (one more than the pairs of bodies' pairs over ``TOUCH_CHUNK``),
``static_pair`` (point × static thing: the planes, then the shapes; then edge × static edge;
then face × static vertex), ``pair`` (the static pairs, then those of each pair of bodies that
may touch: its points against the other's faces both ways, then its edges against the
other's) and ``near`` (room for two near lists, the last step's and the next: twice
``HostModel.near_room`` pairs, grown by the Stepper where a step needs more); ``mimic``
(mimic couplings), ``mimic_body`` (mimic × body) and ``mimic_square`` (mimic × mimic);
``()`` is a plain struct member, not an array. Frames: world, SI units.
"""

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import warp as wp

from affine_joint_sim.physics.contact.kinds import SHAPE_KINDS

__all__ = ['Field', 'FIELDS', 'GROUPS', 'STAT_INT_NAMES', 'STAT_FLOAT_NAMES', 'CONTACT_STATS',
           'COUPLED_STATS', 'PROBLEM_NAMES',
           'PROBLEM_COLUMNS', 'structs',
           'allocate', 'device_model', 'held_structs', 'fields_of', 'env_bytes', 'array_sizes']


@dataclass(frozen=True)
class Field:
    """One field: ``dtype`` is int32, uint64 (an address), scalar (the precision's float),
    vec3, mat33, vec12 or mat12."""

    name: str
    group: str
    dtype: str
    shape: tuple
    unit: str
    doc: str


def _fields(group, rows):
    return [Field(name, group, dtype, shape, unit, doc) for name, dtype, shape, unit, doc in rows]


STAT_INT_NAMES = ('newton_iterations', 'line_search_halvings', 'converged',
                  'line_search_failures', 'angle_aliased', 'torque_dropped', 'non_finite',
                  'step_rejected', 'contacts', 'inner_iterations', 'inner_stalls', 'hessians',
                  'gradient_tries', 'energies', 'near_gathers')
STAT_FLOAT_NAMES = ('residual', 'joint_gap', 'rotation_strain', 'min_distance')
# statistics of a scene with contact only (the Stepper leaves them out otherwise)
CONTACT_STATS = ('contacts', 'min_distance', 'near_gathers')
# statistics of a scene whose free bodies may touch each other only (the coupled solve)
COUPLED_STATS = ('inner_iterations', 'inner_stalls')
# The kinds of trouble a step reports (Stepper warns once per kind): state.problem_counts holds
# per step the number of environments with each, after column 0, the number with any.
PROBLEM_NAMES = ('not_converged', 'non_finite', 'angle_aliased', 'torque_dropped',
                 'line_search_failures', 'near_full')
PROBLEM_COLUMNS = ('any',) + PROBLEM_NAMES

B, F, J, E = ('body',), ('free',), ('joint',), ('env',)
EB, EJ = ('env', 'body'), ('env', 'joint')

FIELDS = _fields('model', [
    ('dt', 'scalar', (), 's', 'time step'),
    ('gravity', 'vec3', (), 'm/s^2', 'gravity acceleration, world'),
    ('has_gravity', 'int32', (), '-', '0 when gravity is zero: the term is skipped'),
    ('integrator', 'int32', (), '-', 'BDF1 | BDF2 (physics.host.codes)'),
    ('newton_tol', 'scalar', (), 'm/s',
     'update displacement / dt at convergence (or its rounding floor, if larger)'),
    ('newton_max_iter', 'int32', (), '-', 'Newton iterations per step at most'),
    ('line_search', 'int32', (), '-', '1: line search on E (a turn-following trial, then '
     'backtracking); 0: the turn-following step, capped, unchecked'),
    ('warm_start', 'int32', (), '-', '1: Newton starts from q̃ with rigid A (polar rotation)'),
    ('state_coupling', 'int32', (), '-', '1: some joint term depends on the state, so the tree '
     'coupling blocks are assembled per environment each iteration (else model.elim_offdiag)'),
    ('body_fixed', 'int32', B, '-', '1: kinematic body, no DOFs'),
    ('body_mass', 'scalar', B, 'kg', 'm'),
    ('body_second_moment', 'vec3', B, 'kg·m^2', 'diagonal of S about the COM, body axes'),
    ('body_ortho_coeff', 'scalar', B, 'J', 'κ·v̄ of the orthogonality energy'),
    ('body_half_extent', 'vec3', B, 'm', 'half box extents: corners of the convergence test'),
    ('body_resolves_turns', 'int32', B, '-', '1: the precision resolves its rotational inertia '
     'against its rigidity, and Newton follows its turns'),
    ('body_joint_hessian', 'mat12', B, 'kg', 'Σ of the joints\' constant diagonal blocks'),
    ('elim_order', 'int32', F, '-', 'free bodies leaves-first (fill-in free elimination)'),
    ('elim_parent', 'int32', B, '-', 'tree parent in the elimination, -1 for a root'),
    ('elim_offdiag', 'mat12', B, 'kg', 'constant coupling block H[b, elim_parent[b]]'),
    ('joint_type', 'int32', J, '-', 'JointKind.code (physics.host.joint_kinds)'),
    ('joint_parent', 'int32', J, '-', 'parent body index (libuipc left, i)'),
    ('joint_child', 'int32', J, '-', 'child body index (libuipc right, j)'),
    ('joint_stiffness', 'scalar', J, 'kg', 'K = strength_ratio (m_P + m_C)'),
    ('joint_has_free', 'int32', J, '-', '0 when both bodies are fixed'),
    ('joint_offdiag_body', 'int32', J, '-', 'body b whose block H[b, elim_parent[b]] couples '
     'the joint\'s bodies, -1 if one is fixed'),
    ('joint_offdiag_child', 'int32', J, '-', '1 if that body is the child (block H_CP)'),
    ('joint_parent_point0', 'vec3', J, 'm', 'parent rest point of x0 (revolute u0; prismatic '
     'c̄; fixed: of the weld centre)'),
    ('joint_parent_point1', 'vec3', J, 'm', 'parent rest point of x1 (revolute u1)'),
    ('joint_child_point0', 'vec3', J, 'm', 'child rest point of x0 (revolute w0)'),
    ('joint_child_point1', 'vec3', J, 'm', 'child rest point of x1 (revolute w1)'),
    ('joint_parent_axis', 'vec3', J, '-', 't̄ of the joint frame in the parent rest frame'),
    ('joint_child_axis', 'vec3', J, '-', 't̄ of the joint frame in the child rest frame'),
    ('joint_parent_normal', 'vec3', J, '-', 'n̄ of the joint frame in the parent rest frame'),
    ('joint_parent_binormal', 'vec3', J, '-', 'b̄ of the joint frame in the parent rest frame'),
    ('joint_child_normal', 'vec3', J, '-', 'n̄ of the joint frame in the child rest frame'),
    ('joint_child_binormal', 'vec3', J, '-', 'b̄ of the joint frame in the child rest frame'),
    ('joint_torque_model', 'int32', J, '-', 'LEVER_ARM | GENERALIZED (physics.host.codes)'),
    ('joint_angle_mode', 'int32', J, '-', 'WRAPPED | CONTINUOUS (physics.host.codes)'),
    ('joint_state_terms', 'int32', J, '-', '1: the joint has a limit, drive or damping term'),
    ('joint_limit_lower', 'scalar', J, 'rad | m', 'limit l on the coordinate'),
    ('joint_limit_upper', 'scalar', J, 'rad | m', 'limit u on the coordinate'),
    ('joint_limit_strength', 'scalar', J, 'J·s²', 'limit s (0: no limit)'),
    ('joint_damping', 'scalar', J, 'N·m·s/rad | N·s/m', 'viscous damping c'),
    ('joint_friction', 'scalar', J, 'N·m | N', 'Coulomb friction f'),
    ('joint_initial_position', 'scalar', J, 'rad | m', 'coordinate x₀ at t = 0 (its origin is '
     'the URDF\'s)'),
    ('joint_drive_stiffness', 'scalar', J, 'kg', 'drive K = strength_ratio (m_P + m_C), 0: none'),
    ('joint_limit_alone', 'int32', J, '-', '1: a revolute joint whose only coordinate term is a '
     'limit of some width (skipped where it provably stays inside: physics.stages.joint_terms)'),
    ('limits_alone', 'int32', (), '-', 'how many joint_limit_alone'),
    ('mimic_follower', 'int32', ('mimic',), '-', 'the joint of each mimic coupling (its '
     'follower)'),
    ('mimic_leader', 'int32', ('mimic',), '-', 'the joint it follows'),
    ('mimic_multiplier', 'scalar', ('mimic',), '-', 'm of x_follower = m x_leader + o'),
    ('mimic_offset', 'scalar', ('mimic',), 'rad | m', 'o'),
    ('mimic_stiffness', 'scalar', ('mimic',), 'kg', 'K of the coupling K/2 (x_f − m x_l − o)² '
     '= strength_ratio (m_P + m_C) of the follower\'s bodies'),
    ('has_contact', 'int32', (), '-', '1: the scene has contact (every contact loop is skipped '
     'otherwise)'),
    ('model_address', 'uint64', (), '-', 'the device address of a one-element array holding '
     'this Model: the step kernel\'s out-of-line functions take the Model there, by reference '
     '(set by the Stepper)'),
    ('contact_d_hat', 'scalar', (), 'm', 'barrier activation distance d̂'),
    ('contact_kappa', 'scalar', (), 'J/m^4', 'barrier stiffness κ'),
    ('point_body', 'int32', ('point',), '-', 'free body of each contact point'),
    ('point_rest', 'vec3', ('point',), 'm', 'its rest position x̄ (COM-centred body frame)'),
    ('point_radius', 'scalar', ('point',), 'm', 'its radius (0: a vertex; r: a sphere centre)'),
    ('plane_normal', 'vec3', ('plane',), '-', 'unit normal of each static half-space (free side)'),
    ('plane_offset', 'scalar', ('plane',), 'm', 'its offset h: the half-space n·x ≥ h'),
    ('plane_tangent', 'vec3', ('plane',), '-', 'first unit tangent t₁ of its friction basis '
     '(t₂ = n × t₁)'),
    ('shape_kind', 'int32', ('shape',), '-', 'a fixed body\'s collision geometry: '
     + ', '.join(f'{kind.code} {kind.name}' for kind in SHAPE_KINDS) + ' (of a mesh; '
     'contact.kinds.SHAPE_KINDS)'),
    ('shape_rotation', 'mat33', ('shape',), '-', 'its axes in the world (columns); a '
     'triangle\'s three vertices'),
    ('shape_center', 'vec3', ('shape',), 'm', 'its centre in the world'),
    ('shape_size', 'vec3', ('shape',), 'm',
     '; '.join(f'{kind.name}: {kind.size}' for kind in SHAPE_KINDS)),
    ('body_reach', 'scalar', B, 'm', 'the farthest contact point or corner of an edge or face of '
     'a free body from its centre of mass, rest (0: none); bounds how far they move'),
    ('body_bound', 'scalar', B, 'm', 'the radius of a sphere about a free body\'s centre of '
     'mass holding its collision geometry, rest (0: none)'),
    ('edge_body', 'int32', ('edge',), '-', 'free body of each moving edge'),
    ('edge_a', 'vec3', ('edge',), 'm', 'its first end, rest position'),
    ('edge_b', 'vec3', ('edge',), 'm', 'its second end, rest position'),
    ('edge_radius', 'scalar', ('edge',), 'm', 'its radius (a capsule\'s axis: r)'),
    ('face_body', 'int32', ('face',), '-', 'free body of each moving face (a triangle)'),
    ('face_rest', 'mat33', ('face',), 'm', 'its corners\' rest positions (columns)'),
    ('static_edge_a', 'vec3', ('static_edge',), 'm', 'first end of each static edge, world'),
    ('static_edge_b', 'vec3', ('static_edge',), 'm', 'its second end (= the first: a sphere)'),
    ('static_edge_radius', 'scalar', ('static_edge',), 'm', 'its radius'),
    ('static_vertex', 'vec3', ('static_vertex',), 'm', 'each static vertex, world'),
    ('static_vertex_radius', 'scalar', ('static_vertex',), 'm', 'its radius'),
    ('surface_centre', 'vec3', ('surface',), 'm', 'centre of a sphere holding a static surface '
     '(a fixed body\'s convex geometry or mesh), world'),
    ('surface_radius', 'scalar', ('surface',), 'm', 'its radius (grown a little against '
     'rounding)'),
    ('surface_edge_end', 'int32', ('surface',), '-', 'one past its last static edge (its edges '
     'start where the previous surface\'s end)'),
    ('surface_vertex_end', 'int32', ('surface',), '-', 'likewise of its static vertices'),
    ('pair_friction', 'scalar', ('static_pair',), '-', 'Coulomb μ of each static pair: point i '
     'against static thing g (the half-spaces, then the shapes) at i·(planes + shapes) + g, '
     'then moving edge e against static edge s, then moving face f against static vertex v, '
     'likewise'),
    ('pair_on', 'int32', ('static_pair',), '-', '1: the static pair may touch (0: '
     'contact.exclude names it, or a fixed body of the moving body\'s own articulation '
     'without self_collision, or one jointed to it, or the edge is a sphere\'s centre)'),
    ('body_first_point', 'int32', ('body_end',), '-', 'index of each body\'s first contact '
     'point (its points end where the next body\'s start)'),
    ('body_first_edge', 'int32', ('body_end',), '-', 'likewise of its moving edges'),
    ('body_first_face', 'int32', ('body_end',), '-', 'likewise of its moving faces'),
    ('touch_a', 'int32', ('touch',), '-', 'first body of each pair of free bodies that may '
     'touch each other (touch_a < touch_b)'),
    ('touch_b', 'int32', ('touch',), '-', 'its second body'),
    ('touch_first', 'int32', ('touch_end',), '-', 'where each touch pair\'s pairs start after '
     'the static pairs: the points of touch_a against the faces of touch_b, those of touch_b '
     'against the faces of touch_a, then the edges of touch_a against those of touch_b, row '
     'by row; then their end'),
    ('touch_chunk', 'int32', ('touch_chunk',), '-', 'the touch pair holding pair '
     'TOUCH_CHUNK·c of the pairs of bodies (counted after the static pairs), for each c up '
     'to their end: where the search for a pair\'s touch pair starts'),
    ('touch_slot', 'int32', ('body', 'body'), '-', 'the touch pair of bodies a and b (either '
     'order), -1 if they never touch'),
    ('body_friction', 'scalar', ('body', 'body'), '-', 'Coulomb μ between two bodies'),
    ('contact_eps_velocity', 'scalar', (), 'm/s', 'slip speed ε_v below which friction is '
     'viscous'),
    ('contact_damping', 'scalar', (), '-', 'ζ: contact damping as a ratio to critical'),
]) + _fields('state', [
    ('state_address', 'uint64', (), '-', 'the device address of a one-element array holding '
     'this State (as model_address)'),
    ('q', 'vec12', EB, 'm, -', 'ABD state [p, a1, a2, a3]'),
    ('v', 'vec12', EB, 'm/s, 1/s', 'ABD velocity q̇'),
    ('q_prev', 'vec12', EB, 'm, -', 'BDF2 history q_{n-1}'),
    ('v_prev', 'vec12', EB, 'm/s, 1/s', 'BDF2 history v_{n-1}'),
    ('correction', 'vec12', EB, 'm/s², 1/s²', 'how far the last step ended from its '
     'warm-started prediction without the commands, over its force scale: M⁻¹ times the '
     'forces besides inertia and gravity (Newton\'s start: physics.solve.newton)'),
    ('correction_prev', 'vec12', EB, 'm/s², 1/s²', 'the correction of the step before the '
     'last (Newton\'s start extrapolates the two where they change smoothly)'),
    ('history_ready', 'int32', E, '-', '0: the next step starts afresh: BDF1 under BDF2, '
     'Newton from the prediction without the last correction'),
    ('joint_coordinate', 'scalar', EJ, 'rad | m', 'multi-turn angle or distance x, last step'),
    ('joint_coordinate_prev', 'scalar', EJ, 'rad | m', 'x of the step before (BDF2 damping)'),
    ('joint_position', 'scalar', EJ, 'rad | m', 'reported coordinate (angle per angle_mode)'),
    ('joint_velocity', 'scalar', EJ, 'rad/s | m/s', 'Δx / dt of the last step'),
    ('joint_effort', 'scalar', EJ, 'N·m | N', 'torque or force applied in the last step'),
    ('nearest_seen', 'scalar', E, 'm', 'smallest min_distance at the end of a step since the '
     'Stepper was made (+inf before; scenes with contact)'),
    ('most_contacts', 'int32', E, '-', 'most contacts at the end of a step since then'),
    ('stats_int', 'int32', ('env', 'stat_int'), '-', 'STAT_INT_NAMES of the last step'),
    ('stats_float', 'scalar', ('env', 'stat_float'), 'm/s, m, -', 'STAT_FLOAT_NAMES'),
    ('problem_counts', 'int32', ('chunk', 'problem'), '-', 'environments of the last step '
     'with any and with each kind of PROBLEM_COLUMNS, per launch (zeroed before each step): '
     'what the host reads every step; the stats only for a kind it has not warned about yet'),
]) + _fields('control', [
    ('control_address', 'uint64', (), '-', 'the device address of a one-element array '
     'holding this Control (as model_address)'),
    ('joint_torque', 'scalar', EJ, 'N·m | N', 'external torque τ (UID 668) or force (UID 667)'),
    ('joint_enabled', 'int32', EJ, '-', 'external_torque/is_constrained'),
    ('joint_target', 'scalar', EJ, 'rad | m', 'drive target'),
    ('joint_drive_enabled', 'int32', EJ, '-', 'driving/is_constrained'),
    ('joint_velocity_target', 'scalar', EJ, 'rad/s | m/s', 'the speed a joint\'s damping pulls '
     'toward (a velocity drive; 0: damping alone)'),
]) + _fields('scratch', [
    ('scratch_address', 'uint64', (), '-', 'the device address of a one-element array '
     'holding this Scratch (as model_address)'),
    ('q_n', 'vec12', EB, 'm, -', 'start-of-step state'),
    ('q_tilde', 'vec12', EB, 'm, -', 'predicted state q̃'),
    ('q_start', 'vec12', EB, 'm, -', 'state at the start of a line search'),
    ('q_predicted', 'vec12', EB, 'm, -', 'this step\'s prediction q̃ without the commands, '
     'warm-started: what its correction is taken against'),
    ('dq', 'vec12', EB, 'm, -', 'Newton direction'),
    ('q_before', 'vec12', EB, 'm, -', 'the iterate before a full step taken unchecked (without '
     'contact: physics.solve.newton)'),
    ('dq_before', 'vec12', EB, 'm, -', 'its direction'),
    ('rhs', 'vec12', EB, 'J', '−∇E of the current iterate'),
    ('forward', 'vec12', EB, 'J', 'L⁻¹ rhs of the tree solve'),
    ('velocity', 'vec12', EB, 'm/s, 1/s', 'velocity of the candidate end-of-step state'),
    ('hessian', 'mat12', EB, 'kg', 'diagonal Hessian blocks of the current iterate'),
    ('factor', 'mat12', EB, 'kg^½', 'Cholesky factors of the tree solve'),
    ('pivot_inverse', 'vec12', EB, 'kg^-½', '1 / the diagonal of each Cholesky factor'),
    ('offdiag', 'mat12', EB, 'kg', 'H[b, elim_parent[b]] of the current iterate (when the '
     'model has state_coupling)'),
    ('offdiag_set', 'int32', EB, '-', '1 if offdiag holds this iterate\'s block (a state term '
     'added to it), 0 if the block is the constant elim_offdiag'),
    ('coupling', 'mat12', EB, 'kg^½', 'L⁻¹ H[b, parent] of the tree solve'),
    ('joint_raw', 'scalar', EJ, 'rad | m', 'raw coordinate of each joint at the Newton result '
     '(joint_raw_coordinate), for the commit'),
    ('near_pairs', 'int32', ('env', 'near'), '-', 'the pairs evaluated this step, ascending '
     '(the static ones first): those within d̂ + body_margin at q_listed (both bodies\' '
     'margins for a pair of bodies; the others stay beyond d̂); the list in [0, near_count), '
     'the room after it for the next one'),
    ('near_count', 'int32', E, '-', 'how many near_pairs'),
    ('near_gathers', 'int32', E, '-', 'how many times this step gathered the near list'),
    ('near_full', 'int32', E, '-', '0, or how many pairs a near list needed this step where '
     'they outgrew the room: the step is rejected and the Stepper grows the room'),
    ('friction_normal', 'scalar', ('env', 'near'), 'N·s²', 'lagged normal force dt²·λ of each '
     'listed pair (beside its entry of near_pairs) at the start of the step (0: no friction '
     'this step)'),
    ('normal_damping', 'scalar', ('env', 'near'), 'kg', 'lagged c·dt of each listed pair: its '
     'damping c = 2ζ √(k m) [N·s/m] at the start of the step (0: none this step)'),
    ('damping_release', 'scalar', ('env', 'near'), 'm', 'the distance beyond which an opening '
     'pair\'s damper only cancels its barrier\'s push (where normal_damping > 0)'),
    ('damping_before', 'scalar', ('env', 'near'), 'kg', 'normal_damping of the step before '
     '(what friction\'s lagged load reads, kept for a step taken again with more room)'),
    ('gap_n', 'scalar', ('env', 'near'), 'm', 'each listed pair\'s distance at q_n, taken by '
     'friction\'s lag (0: unknown, a pair listed since): less its bodies\' body_drift, a '
     'lower bound of its distance at an iterate'),
    ('point_world', 'vec3', ('env', 'point'), 'm', 'each contact point at q_n, for the broad '
     'phase of pairs of bodies'),
    ('point_size', 'scalar', ('env', 'point'), 'm', 'its radius, beside it'),
    ('edge_centre', 'vec3', ('env', 'edge'), 'm', 'each moving edge\'s midpoint at q_n'),
    ('edge_size', 'scalar', ('env', 'edge'), 'm', 'its half length plus radius'),
    ('face_centre', 'vec3', ('env', 'face'), 'm', 'each moving face\'s centroid at q_n'),
    ('face_size', 'scalar', ('env', 'face'), 'm', 'its farthest corner from the centroid'),
    ('slab_faces', 'int32', ('env', 'face'), '-', 'the faces of one body near another\'s slab, '
     'while their pairs are gathered'),
    ('slab_edges', 'int32', ('env', 'edge'), '-', 'likewise its edges'),
    ('body_placed', 'int32', EB, '-', '1 once a body\'s primitives are placed while the pairs '
     'of bodies are gathered (only those of bodies near another are)'),
    ('body_low', 'vec3', EB, 'm', 'the least height of a body\'s contact points and edge balls '
     'at q_n along each of its own axes (A\'s columns normalized)'),
    ('body_high', 'vec3', EB, 'm', 'likewise the greatest'),
    ('contact_block', 'mat12', ('env', 'touch'), 'kg', 'the Hessian block H[touch_a, touch_b] '
     'of the contact between two bodies this iterate'),
    ('block_used', 'int32', ('env', 'touch'), '-', '1 if contact_block holds a block this '
     'iterate'),
    ('forest_parent', 'int32', EB, '-', 'each free body\'s parent in the elimination forest of '
     'this iterate (joints, then contacts between bodies joining two trees), -1 for a root'),
    ('forest_block', 'mat12', EB, 'kg', 'H[b, forest_parent[b]]'),
    ('forest_order', 'int32', ('env', 'free'), '-', 'the free bodies, every one before its '
     'forest parent'),
    ('forest_root', 'int32', EB, '-', 'union-find links of the trees while the forest grows'),
    ('forest_depth', 'int32', EB, '-', 'each body\'s depth below its forest root'),
    ('cg_residual', 'vec12', EB, 'J', 'residual of the coupled solve (conjugate gradients)'),
    ('cg_preconditioned', 'vec12', EB, 'm, -', 'the tree solve of that residual'),
    ('cg_direction', 'vec12', EB, 'm, -', 'conjugate search direction'),
    ('cg_product', 'vec12', EB, 'J', 'H times the search direction'),
    ('body_margin', 'scalar', EB, 'm', 'how far a body\'s contact points, edges and faces may '
     'move from where they were at q_listed before near_pairs is gathered again (−1: at the '
     'next step)'),
    ('q_listed', 'vec12', EB, 'm, -', 'q_n of the step that gathered near_pairs last'),
    ('body_drift', 'scalar', EB, 'm', 'how far a free body\'s contact points, edges and faces '
     'are at most from where they were at q_n, at the state being evaluated (for a step '
     'bound, plus how far they move along the path over 1 − η)'),
    ('mimic_gradient', 'vec12', ('env', 'mimic_body'), '-', 'per mimic coupling (body rows '
     'of one after another\'s) the gradient g of its x_f − m x_l at the last factorization: '
     'its Hessian K g gᵀ enters every solve by the Sherman–Morrison–Woodbury formula'),
    ('mimic_solved', 'vec12', ('env', 'mimic_body'), 'm, - per (rad | m)', 'H⁻¹ g of each, H '
     'the factored blocks'),
    ('mimic_matrix', 'scalar', ('env', 'mimic_square'), 'kg^-½', 'the Cholesky '
     'factor (lower, row-major) of 1/K + gᵀ H⁻¹ g over the couplings'),
    ('mimic_weight', 'scalar', ('env', 'mimic'), 'kg · (rad | m)', 'the Woodbury weights of '
     'the solve in progress'),
    ('limit_reach', 'scalar', EJ, '-', 'per joint_limit_alone, the largest bound D on its '
     'bodies\' turn since q_n (``limit_idle``) within which its coordinate stays inside its '
     'limits this step (≤ 0: none)'),
    ('body_size', 'scalar', EB, '-', '‖A‖_F of each body at q_n'),
    ('body_turn', 'scalar', EB, '-', '‖A − A(q_n)‖_F of each free body at the iterate being '
     'evaluated (with joint_limit_alone joints)'),
    ('limit_depth', 'scalar', EJ, '-', 'limit penetration / (u − l) at the last Newton iterate '
     '(0: inside the limits; −1: none yet this step)'),
])

GROUPS = ('model', 'state', 'control', 'scratch')


def fields_of(group: str) -> list[Field]:
    """The fields of one group, in table order."""
    return [f for f in FIELDS if f.group == group]


def _wp_type(t, dtype):
    return {'int32': wp.int32, 'uint64': wp.uint64}.get(dtype) or getattr(t, dtype)


def _annotation(t, f):
    kind = _wp_type(t, f.dtype)
    if f.shape == ():
        return kind
    return wp.array(dtype=kind) if len(f.shape) == 1 else wp.array2d(dtype=kind)


def structs(t) -> SimpleNamespace:
    """Warp structs Model, State, Control, Scratch for the types namespace ``t``."""
    made = {}
    for group in GROUPS:
        name = group.capitalize()
        cls = type(f'{name}_{t.name}', (), {
            '__annotations__': {f.name: _annotation(t, f) for f in fields_of(group)},
            '__module__': __name__, '__doc__': f'{name} fields of physics.host.fields.FIELDS.'})
        made[name] = wp.struct(cls)
    return SimpleNamespace(**made)


def _numpy_dtype(t, dtype):
    return np.int32 if dtype == 'int32' else t.numpy_scalar


def device_model(t, struct, host, device):
    """The Model struct filled from a host model (attributes named as the model fields)."""
    model = struct()
    for f in fields_of('model'):
        value = getattr(host, f.name)
        if f.shape == ():
            setattr(model, f.name, _wp_type(t, f.dtype)(*np.atleast_1d(value)))
        else:
            array = np.ascontiguousarray(np.asarray(value).astype(_numpy_dtype(t, f.dtype)))
            setattr(model, f.name, wp.array(array, dtype=_wp_type(t, f.dtype), device=device))
    return model


def allocate(t, struct, group, sizes: dict, device):
    """A ``group`` struct of zeroed device arrays; ``sizes`` maps symbolic dims to lengths."""
    instance = struct()
    for f in fields_of(group):
        if f.shape == ():       # a plain member (an address): 0
            setattr(instance, f.name, _wp_type(t, f.dtype)(0))
            continue
        shape = tuple(sizes[d] for d in f.shape)
        setattr(instance, f.name, wp.zeros(shape, dtype=_wp_type(t, f.dtype), device=device))
    return instance


def held_structs(t, device, **structs) -> list:
    """One-element device arrays holding each struct given by group (``model=``, ``state=``,
    ...), each struct's ``<group>_address`` field set first to its array's address: the step
    kernel's out-of-line functions read the structs there, by reference
    (physics.stages.out_of_line). The arrays must live as long as the structs are launched."""
    held = []
    for group, struct in structs.items():
        kind = getattr(t.structs, group.capitalize())
        array = wp.empty(1, dtype=kind, device=device)
        setattr(struct, f'{group}_address', array.ptr)
        wp.copy(array, wp.array([struct], dtype=kind, device='cpu'))
        held.append(array)
    return held


def array_sizes(host, envs: int, chunks: int = 1, near_room: int | None = None) -> dict:
    """The symbolic dimensions of the fields for a host model and ``envs`` environments
    stepped in ``chunks`` launches (one problem count row each), with room for ``near_room``
    pairs in a near list (``host.near_room`` by default)."""
    return {'env': envs, 'chunk': chunks, 'body': host.body_count,
            'free': int(np.sum(host.body_fixed == 0)),
            'joint': host.joint_count, 'point': len(host.point_body),
            'plane': len(host.plane_offset), 'shape': len(host.shape_kind),
            'static_pair': len(host.pair_friction), 'pair': host.pair_count,
            'touch': len(host.touch_a), 'touch_end': len(host.touch_a) + 1,
            'touch_chunk': len(host.touch_chunk),
            'body_end': host.body_count + 1,
            'edge': len(host.edge_body),
            'face': len(host.face_body), 'static_edge': len(host.static_edge_a),
            'static_vertex': len(host.static_vertex),
            'surface': len(host.surface_radius),
            'near': 2 * (host.near_room if near_room is None else near_room),
            'mimic': len(host.mimic_follower),
            'mimic_body': len(host.mimic_follower) * host.body_count,
            'mimic_square': len(host.mimic_follower) ** 2,
            'stat_int': len(STAT_INT_NAMES),
            'stat_float': len(STAT_FLOAT_NAMES), 'problem': len(PROBLEM_COLUMNS)}


def env_bytes(t, sizes: dict) -> int:
    """Device bytes per environment of the State, Control and Scratch arrays (``sizes`` as
    for ``allocate``; its ``env`` entry is ignored)."""
    total = 0
    for f in FIELDS:
        if f.group != 'model' and 'env' in f.shape:
            kind = _wp_type(t, f.dtype)
            count = np.prod([sizes[d] for d in f.shape if d != 'env'], dtype=np.int64)
            total += int(count) * wp.types.type_size_in_bytes(kind)
    return total
