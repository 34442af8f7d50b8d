"""Host-side model build: a Scene turned into the constant arrays the step kernel reads.

Everything here is NumPy float64 and runs once per scene. Frames: world z up; a body's rest
frame is centred at its centre of mass with the shape's axes, so its
state is q = [p, a1, a2, a3], p the COM [m], A's rows a_r (docs/physics.md#state-and-kinematics).
"""

import math
import warnings

import numpy as np

from affine_joint_sim import portable_math as pm
from affine_joint_sim.physics.contact.model import contact_arrays
from affine_joint_sim.physics.host.codes import (BDF1, BDF2, CONTINUOUS, GENERALIZED, LEVER_ARM,
                                                 WRAPPED)
from affine_joint_sim.physics.host.joint_kinds import JOINT_KINDS, joint_kind
from affine_joint_sim.physics.joints import host_functions
from affine_joint_sim.physics.host.fields import fields_of
from affine_joint_sim.physics.host.mass import body_mass_properties
from affine_joint_sim.physics.contact.pairs import pair_total
from affine_joint_sim.physics.host.rigidity import body_rigidity
from affine_joint_sim.rotations import rotation_matrix
from affine_joint_sim.sim_warnings import SimulationWarning

NEAR_ROOM_LEAST = 64    # pairs: the least room of a near list (HostModel.near_room)

__all__ = ['HostModel', 'build_model', 'initial_states', 'jacobian', 'direction_jacobian',
           'linear_pairs', 'residual_jacobians', 'largest_step_efforts']


class HostModel:
    """Constant model data of one scene (shared by all environments), NumPy float64.

    Its attributes are exactly the model fields of ``physics.host.fields.FIELDS`` (names, units and
    shapes are documented there) plus host-only ones: ``precision``, ``active_terms`` (the
    terms a step evaluates), ``body_q0`` and ``body_v0`` (initial state and velocity, (nb, 12))
    and ``static_names`` (the name of each half-space, then each static shape, then the fixed
    body of each static edge and of each static vertex). Body arrays
    have one row per scene body, fixed ones included (unused by the solver).
    """

    def __init__(self, values: dict, **host_only):
        expected = {f.name for f in fields_of('model')}
        if set(values) != expected:
            raise ValueError(f'host model fields differ from the table: missing '
                             f'{sorted(expected - set(values))}, extra '
                             f'{sorted(set(values) - expected)}')
        vars(self).update(values)
        vars(self).update(host_only)

    @property
    def body_count(self) -> int:
        return len(self.body_fixed)

    @property
    def joint_count(self) -> int:
        return len(self.joint_parent)

    @property
    def has_body_pairs(self) -> bool:
        """Whether some free bodies may touch each other (the step kernel with pairs of bodies
        and the coupled solve, ``kernels.step_kernels``)."""
        return len(self.touch_a) > 0

    @property
    def has_static_shapes(self) -> bool:
        """Whether contact meets more than half-spaces: static shapes, meshes, their edges or
        vertices (the step kernel without them: ``kernels.step_kernels``)."""
        return len(self.shape_kind) + len(self.static_edge_a) + len(self.static_vertex) > 0

    @property
    def pair_count(self) -> int:
        """Contact pairs numbered (physics.host.fields ``pair``)."""
        return pair_total(vars(self))

    @property
    def near_room(self) -> int:
        """Pairs a near list has room for at first (physics.host.fields ``near``): twice the
        moving contact primitives (points, edges, faces), at least 64, at most every pair. A
        step whose list needs more is taken again with more room (``Stepper``)."""
        primitives = len(self.point_body) + len(self.edge_body) + len(self.face_body)
        return min(self.pair_count, max(NEAR_ROOM_LEAST, 2 * primitives))


def jacobian(x_bar) -> np.ndarray:
    """J(x̄), the 3×12 map from q to the world point p + A x̄ of rest point x̄."""
    j = np.zeros((3, 12))
    for r in range(3):
        j[r, r] = 1.0
        j[r, 3 + 3 * r:6 + 3 * r] = x_bar
    return j


def _skew(w) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _joint_frame(axis) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal (n, b) with (t̂, n, b) right-handed (docs/physics.md#joint-frame)."""
    t = axis / pm.norm(axis)
    s = np.array([1.0, 0.0, 0.0]) if abs(t[0]) <= 0.9 else np.array([0.0, 1.0, 0.0])
    n = pm.cross(t, s)
    n /= pm.norm(n)
    b = pm.cross(t, n)
    return n, b / pm.norm(b)


def initial_states(scene) -> np.ndarray:
    """The bodies' states q = [p, A] (n_bodies, 12) at t = 0: A their rotation."""
    q0 = np.zeros((len(scene.bodies), 12))
    for i, body in enumerate(scene.bodies):
        q0[i, :3], q0[i, 3:] = body.position, rotation_matrix(body.orientation).reshape(9)
    return q0


def build_model(scene, starts=None) -> HostModel:
    """Precompute the constant arrays of ``scene``; warn about torques that cannot act.
    ``starts``: the states (n_bodies, 12) it goes on from, checked for touching instead of
    its initial state (``contact_arrays``)."""
    nb = len(scene.bodies)
    props = [body_mass_properties(b) for b in scene.bodies]
    rotations = [rotation_matrix(b.orientation) for b in scene.bodies]
    q0, v0 = initial_states(scene), np.zeros((nb, 12))
    for i, (body, rot) in enumerate(zip(scene.bodies, rotations)):
        if not body.fixed:
            v0[i, :3] = body.linear_velocity
            v0[i, 3:] = pm.matmul(_skew(body.angular_velocity), rot).reshape(9)
    fixed = np.array([b.fixed for b in scene.bodies], dtype=np.int32)
    mass = np.array([p.mass for p in props])
    joints = _joint_arrays(scene, rotations, q0, mass)
    parent, child = joints['joint_parent'], joints['joint_child']

    joint_hessian = np.zeros((nb, 12, 12))
    for k in range(len(parent)):
        blocks = _constant_blocks(joints, k)
        joint_hessian[parent[k]] += blocks[0]
        joint_hessian[child[k]] += blocks[2]
    elim_order, elim_parent, elim_offdiag, offdiag_body, offdiag_child = _elimination(
        scene, fixed, joints)
    _warn_com_on_axis(scene, fixed, joints)
    second_moment = np.array([p.second_moment for p in props])
    ortho_coeff = body_rigidity(scene, props)
    resolves_turns = _resolves_turns(scene, second_moment, ortho_coeff)
    _warn_unresolved_turns(scene, fixed, resolves_turns)

    gravity = np.asarray(scene.gravity, dtype=np.float64)
    has_free = np.array([not (fixed[parent[k]] and fixed[child[k]]) for k in range(len(parent))],
                        dtype=np.int32)
    free = not fixed.all()
    moving = has_free != 0
    state_terms = moving & (joints['joint_state_terms'] != 0)
    active = [term for term, on in (
        ('inertia', free), ('orthogonality', free), ('gravity', free and gravity.any()),
        ('joints', bool(moving.any())),
        ('limits', bool((moving & (joints['joint_limit_strength'] > 0)).any())),
        ('drives', bool((moving & (joints['joint_drive_stiffness'] > 0)).any())),
        ('damping', bool((moving & (joints['joint_damping'] > 0)).any())),
        ('friction', bool((moving & (joints['joint_friction'] > 0)).any())),
        ('mimic', bool(len(joints['mimic_follower'])))) if on]
    nonlinear = np.array([not JOINT_KINDS[code].linear for code in joints['joint_type']],
                         dtype=bool)
    state_coupling = bool((state_terms | (moving & nonlinear)).any())
    contact, static_names = contact_arrays(scene, q0, starts)
    active += ['contact'] * contact['has_contact']
    active += ['body contact'] * bool(len(contact['touch_a']))
    values = dict(
        dt=scene.dt, gravity=gravity, has_gravity=int(np.any(gravity != 0.0)),
        integrator=BDF2 if scene.solver.integrator == 'bdf2' else BDF1,
        newton_tol=scene.solver.newton_tol, newton_max_iter=scene.newton_max_iter,
        line_search=int(scene.solver.line_search),
        warm_start=int(scene.solver.warm_start), state_coupling=int(state_coupling),
        body_fixed=fixed, body_mass=mass,
        body_second_moment=second_moment, body_ortho_coeff=ortho_coeff,
        body_half_extent=np.array([p.half_extent for p in props]),
        body_resolves_turns=resolves_turns,
        body_joint_hessian=joint_hessian,
        elim_order=elim_order, elim_parent=elim_parent, elim_offdiag=elim_offdiag,
        joint_has_free=has_free, joint_offdiag_body=offdiag_body,
        joint_offdiag_child=offdiag_child, model_address=0, **joints, **contact)
    return HostModel(values, precision=scene.solver.precision, active_terms=active,
                     body_q0=q0, body_v0=v0, static_names=static_names)


def _joint_arrays(scene, rotations, q0, mass) -> dict:
    """Per-joint model fields: type, bodies, stiffness, rest points and frames per side, terms.

    Revolute and prismatic joints take their axis t from x1 − x0 and points x0, x1 as given;
    a fixed joint welds at the midpoint of its two body centres with world axes (libuipc's
    frame). Rest copies: ū = R⁻¹(x − p) for points and R⁻¹ v for directions (R = A at t = 0).
    """
    nj = len(scene.joints)
    out = {name: np.zeros((nj, 3)) for name in _SIDE_VECTORS}
    kinds = [joint_kind(j.type) for j in scene.joints]
    out['joint_type'] = np.array([kind.code for kind in kinds], dtype=np.int32)
    parent = np.array([scene.body_index(j.parent) for j in scene.joints], dtype=np.int32)
    child = np.array([scene.body_index(j.child) for j in scene.joints], dtype=np.int32)
    out['joint_parent'], out['joint_child'] = parent, child
    out['joint_stiffness'] = np.array([j.strength_ratio * (mass[parent[k]] + mass[child[k]])
                                       for k, j in enumerate(scene.joints)])
    for k, joint in enumerate(scene.joints):
        if not kinds[k].takes_axis:
            x0 = x1 = 0.5 * (q0[parent[k], :3] + q0[child[k], :3])
            t, n, b = np.eye(3)
        else:
            x0, x1 = np.asarray(joint.x0), np.asarray(joint.x1)
            t = (x1 - x0) / pm.norm(x1 - x0)
            n, b = _joint_frame(x1 - x0)
        for side, body in (('parent', parent[k]), ('child', child[k])):
            rot, p = rotations[body], q0[body, :3]
            for name, value in (('point0', x0 - p), ('point1', x1 - p), ('axis', t),
                                ('normal', n), ('binormal', b)):
                out[f'joint_{side}_{name}'][k] = pm.matmul(rot.T, value)
    out['joint_torque_model'] = np.array(
        [LEVER_ARM if j.torque_model == 'lever_arm' else GENERALIZED for j in scene.joints],
        dtype=np.int32)
    out['joint_angle_mode'] = np.array(
        [CONTINUOUS if j.angle_mode == 'continuous' or not kind.periodic else WRAPPED
         for j, kind in zip(scene.joints, kinds)], dtype=np.int32)
    limits = [j.limit for j in scene.joints]
    out['joint_limit_lower'] = np.array([lim.lower if lim else 0.0 for lim in limits])
    out['joint_limit_upper'] = np.array([lim.upper if lim else 0.0 for lim in limits])
    out['joint_limit_strength'] = np.array([lim.strength if lim else 0.0 for lim in limits])
    out['joint_damping'] = np.array([j.damping for j in scene.joints])
    out['joint_friction'] = np.array([j.friction for j in scene.joints])
    out['joint_initial_position'] = np.array([j.initial_position for j in scene.joints])
    out['joint_drive_stiffness'] = np.array(
        [j.drive.strength_ratio * (mass[parent[k]] + mass[child[k]]) if j.drive else 0.0
         for k, j in enumerate(scene.joints)])
    out.update(_mimic_arrays(scene, parent, child, mass))
    out['joint_limit_alone'] = np.array(
        [kind.name == 'revolute' and j.limit is not None and j.limit.upper > j.limit.lower
         and j.drive is None and j.damping == 0.0 and j.friction == 0.0
         for j, kind in zip(scene.joints, kinds)], dtype=np.int32)
    out['limits_alone'] = int(out['joint_limit_alone'].sum())
    out['joint_state_terms'] = np.array(
        [j.limit is not None or j.drive is not None or j.damping > 0.0 or j.friction > 0.0
         for j in scene.joints],
        dtype=np.int32)
    return out


def _mimic_arrays(scene, parent, child, mass) -> dict:
    """The mimic couplings' model fields, in the order of their followers."""
    followers = [k for k, j in enumerate(scene.joints) if j.mimic is not None]
    mimics = [scene.joints[k].mimic for k in followers]
    return {'mimic_follower': np.array(followers, dtype=np.int32),
            'mimic_leader': np.array([scene.joint_index(m.joint) for m in mimics],
                                     dtype=np.int32),
            'mimic_multiplier': np.array([m.multiplier for m in mimics], dtype=np.float64),
            'mimic_offset': np.array([m.offset for m in mimics], dtype=np.float64),
            'mimic_stiffness': np.array([m.strength_ratio * (mass[parent[k]] + mass[child[k]])
                                         for k, m in zip(followers, mimics)],
                                        dtype=np.float64)}


_SIDE_VECTORS = [f'joint_{side}_{what}' for side in ('parent', 'child')
                 for what in ('point0', 'point1', 'axis', 'normal', 'binormal')]


def direction_jacobian(u_bar) -> np.ndarray:
    """J̊(ū), the 3×12 map from q to the world direction A ū (no translation part)."""
    j = jacobian(u_bar)
    j[:, :3] = 0.0
    return j


def residual_jacobians(joints: dict, k: int):
    """(point, direction) of joint k: point(m) gives the (J_P, J_C) of anchor m's world
    points, direction(what) those of the world copies of its rest direction ``what`` ('axis',
    'normal', 'binormal'), for the type's ``linear_pairs`` and ``nonlinear_residuals``."""
    def point(m):
        return (jacobian(joints[f'joint_parent_point{m}'][k]),
                jacobian(joints[f'joint_child_point{m}'][k]))

    def direction(what):
        return (direction_jacobian(joints[f'joint_parent_{what}'][k]),
                direction_jacobian(joints[f'joint_child_{what}'][k]))

    return point, direction


def linear_pairs(joints: dict, k: int) -> list:
    """(J_P, J_C) of each residual J_P q_P − J_C q_C of joint k that is linear in q (its
    type's ``linear_pairs``)."""
    return host_functions(joints['joint_type'][k]).linear_pairs(*residual_jacobians(joints, k))


def _constant_blocks(joints: dict, k: int):
    """(H_PP, H_PC, H_CC) of joint k's linear residuals, K Σ J_Pᵀ J_P, −K Σ J_Pᵀ J_C,
    K Σ J_Cᵀ J_C [kg]: constant, computed once (docs/physics.md#joints)."""
    pairs = linear_pairs(joints, k)
    stiffness = joints['joint_stiffness'][k]
    return (stiffness * sum(pm.matmul(jp.T, jp) for jp, _ in pairs),
            -stiffness * sum(pm.matmul(jp.T, jc) for jp, jc in pairs),
            stiffness * sum(pm.matmul(jc.T, jc) for _, jc in pairs))


def _elimination(scene, fixed, joints):
    """Leaves-first order of the free bodies and each one's coupling block to its tree parent.

    Also returns, per joint, the body whose coupling slot holds the joint's block and whether
    that body is the child (the slot then holds H_CP = H_PCᵀ). Free bodies joined by joints
    form a forest. Each tree is rooted at a body jointed to a fixed
    body when there is one (else its first body) and listed breadth-first; the reversed list puts
    every body before its tree parent, so block elimination in that order has no fill-in.
    """
    nb = len(fixed)
    parent, child = joints['joint_parent'], joints['joint_child']
    neighbours = {b: [] for b in range(nb)}
    anchored = set()
    for k in range(len(parent)):
        p, c = int(parent[k]), int(child[k])
        if not fixed[p] and not fixed[c]:
            neighbours[p].append((c, k))
            neighbours[c].append((p, k))
        elif not fixed[p] or not fixed[c]:
            anchored.add(c if fixed[p] else p)
    free = [b for b in range(nb) if not fixed[b]]
    roots = sorted(free, key=lambda b: (b not in anchored, b))
    order, elim_parent = [], np.full(nb, -1, dtype=np.int32)
    offdiag_body = np.full(len(parent), -1, dtype=np.int32)
    offdiag_child = np.zeros(len(parent), dtype=np.int32)
    elim_offdiag, seen = np.zeros((nb, 12, 12)), set()
    for root in roots:
        if root in seen:
            continue
        seen.add(root)
        queue = [root]
        for body in queue:
            for other, k in neighbours[body]:
                if other in seen:
                    continue
                seen.add(other)
                queue.append(other)
                elim_parent[other] = body
                h_pc = _constant_blocks(joints, k)[1]
                elim_offdiag[other] = h_pc.T if other == child[k] else h_pc
                offdiag_body[k], offdiag_child[k] = other, int(other == child[k])
        order += queue
    return (np.array(order[::-1], dtype=np.int32), elim_parent, elim_offdiag, offdiag_body,
            offdiag_child)


def _warn_com_on_axis(scene, fixed, joints):
    """lever_arm applies no torque to a body whose centre of mass lies on the axis: say so."""
    for k, joint in enumerate(scene.joints):
        if (joints['joint_torque_model'][k] != LEVER_ARM
                or joint_kind(joint.type).command != 'torque'):
            continue
        for side in ('parent', 'child'):
            body = joints[f'joint_{side}'][k]
            a0, a1 = joints[f'joint_{side}_point0'][k], joints[f'joint_{side}_point1'][k]
            e = (a1 - a0) / pm.norm(a1 - a0)
            d = -a0
            r = d - pm.dot(d, e) * e
            if not fixed[body] and pm.dot(r, r) <= 1e-12:
                warnings.warn(
                    f'joint {joint.name!r}: the centre of mass of body '
                    f'{scene.bodies[body].name!r} lies on the joint axis, so torque_model '
                    'lever_arm applies no torque to it; use torque_model: generalized',
                    SimulationWarning, stacklevel=3)


def _resolves_turns(scene, second_moment, ortho_coeff) -> np.ndarray:
    """Per body, 1 if the scene's precision resolves its rotational inertia against its
    rigidity: its smallest second moment [kg·m²] above one rounding unit (ε) of its largest
    second moment or of the orthogonality energy's 8 dt² κ v̄ [J·s²]. A 2 mg, 2.7 mm link
    (1e-12 against 1.6e-3) passes in float64, not in float32; a 1 kg, 0.5 m link passes in
    both (2e-6). Joints are left out: their stiff entries constrain turns (a prismatic finger's
    all of them) rather than leave them free, and counting them flagged grippers that converge
    well in float32; a light link on a heavy parent's hinge can therefore pass and still
    converge badly in float32 (the per-step warning then says so)."""
    eps = np.finfo(np.float32 if scene.solver.precision == 'float32' else np.float64).eps
    stiffest = np.maximum(second_moment.max(axis=1), 8.0 * (scene.dt * scene.dt) * ortho_coeff)
    return (second_moment.min(axis=1) > eps * stiffest).astype(np.int32)


def _warn_unresolved_turns(scene, fixed, resolves_turns):
    """Name the moving bodies whose turns the precision does not resolve (their rotation is
    rounding noise: Newton does not follow it and may not converge)."""
    names = [b.name for b, f, r in zip(scene.bodies, fixed, resolves_turns) if not f and not r]
    if not names:
        return
    more = f' and {len(names) - 5} more' if len(names) > 5 else ''
    warnings.warn(
        f'{scene.solver.precision} does not resolve the rotational inertia of {len(names)} '
        f'moving bod{"y" if len(names) == 1 else "ies"} '
        f'({", ".join(repr(n) for n in names[:5])}{more}) against their rigidity (smallest '
        'second moment below the rounding of 8 dt² κ v̄): their turns are rounding noise and '
        'steps may not converge; use solver precision float64, or give them a realistic '
        'mass and inertia', SimulationWarning, stacklevel=3)


def largest_step_efforts(model: HostModel) -> np.ndarray:
    """Per joint, the largest |torque| [N·m] or |force| [N] one step can represent [(nj,)].

    A torque τ turns a body of inertia I about the axis by τ dt²/I in one step from rest:
    beyond 0.9π·I/dt² (I of the joint's lighter free body) the step is rejected as aliasing.
    A force f moves a body of mass m by f dt²/m: beyond m·d/dt² (d: the body's largest extent)
    one step throws it further than its own size. inf where no body of the joint is free; 0
    for a type that takes no command.
    """
    out = np.full(model.joint_count, np.inf)
    for k in range(model.joint_count):
        command = JOINT_KINDS[model.joint_type[k]].command
        if command is None:
            out[k] = 0.0
            continue
        for side in ('parent', 'child'):
            body = getattr(model, f'joint_{side}')[k]
            if model.body_fixed[body]:
                continue
            mass = model.body_mass[body]
            if command == 'force':
                bound = mass * 2.0 * model.body_half_extent[body].max() / (model.dt * model.dt)
            else:
                p0 = getattr(model, f'joint_{side}_point0')[k]
                axis = getattr(model, f'joint_{side}_point1')[k] - p0
                axis /= pm.norm(axis)
                s = model.body_second_moment[body]
                inertia_cm = s.sum() - pm.dot(s, axis ** 2)    # t̂ᵀ (tr(S) I − S) t̂
                arm = -p0 - pm.dot(-p0, axis) * axis          # COM (rest origin) from the axis
                bound = (0.9 * math.pi * (inertia_cm + mass * pm.dot(arm, arm))
                         / (model.dt * model.dt))
            out[k] = min(out[k], bound)
    return out
