"""Host-side model build: a Scene turned into the constant arrays the step kernel reads.

Everything here is NumPy float64 and runs once per scene. Frames: world z up; a body's rest
frame is centred at its centre of mass with the shape's axes (physics_spec preface §1), so its
state is q = [p, a1, a2, a3] with p the COM [m] and a_r the rows of A (physics_spec §1.1).
"""

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from affine_joint_sim.physics.mass import mass_properties

__all__ = ['HostModel', 'SimulationWarning', 'build_model', 'jacobian', 'rotation_matrix',
           'LEVER_ARM', 'GENERALIZED', 'WRAPPED', 'CONTINUOUS', 'BDF1', 'BDF2']

LEVER_ARM, GENERALIZED = 0, 1
WRAPPED, CONTINUOUS = 0, 1
BDF1, BDF2 = 0, 1


class SimulationWarning(UserWarning):
    """A scene or a step the simulator can run but whose result the user should know about."""


@dataclass
class HostModel:
    """Constant model data of one scene (shared by all environments), float64.

    Body arrays have one row per scene body, fixed ones included (their rows are unused by
    the solver). ``elim_order`` lists the free bodies leaves-first: eliminating them in that
    order factors the block-tree Newton system without fill-in.
    """

    dt: float
    gravity: np.ndarray
    integrator: int
    newton_tol: float
    newton_max_iter: int
    line_search: bool
    precision: str
    body_fixed: np.ndarray            # (nb,) int32
    body_mass: np.ndarray             # (nb,) [kg]
    body_second_moment: np.ndarray    # (nb, 3) diag of S [kg·m^2]
    body_ortho_coeff: np.ndarray      # (nb,) κ·v̄ [J]
    body_half_extent: np.ndarray      # (nb, 3) [m]
    body_joint_hessian: np.ndarray    # (nb, 12, 12) Σ of the joints' constant diagonal blocks
    body_q0: np.ndarray               # (nb, 12) initial state
    body_v0: np.ndarray               # (nb, 12) initial velocity
    elim_order: np.ndarray            # (nf,) int32
    elim_parent: np.ndarray           # (nb,) int32, -1 for a root
    elim_offdiag: np.ndarray          # (nb, 12, 12) H[b, elim_parent[b]]
    joint_parent: np.ndarray          # (nj,) int32 body index (libuipc left, i)
    joint_child: np.ndarray           # (nj,) int32 body index (libuipc right, j)
    joint_stiffness: np.ndarray       # (nj,) K = strength_ratio (m_P + m_C) [kg]
    joint_anchors: np.ndarray         # (nj, 4, 3) u0, u1 (parent rest), w0, w1 (child rest) [m]
    joint_frames: np.ndarray          # (nj, 4, 3) n̄_P, b̄_P, n̄_C, b̄_C (rest frames)
    joint_torque_model: np.ndarray    # (nj,) int32 LEVER_ARM | GENERALIZED
    joint_angle_mode: np.ndarray      # (nj,) int32 WRAPPED | CONTINUOUS
    joint_has_free: np.ndarray        # (nj,) int32, 0 when both bodies are fixed
    active_terms: list[str] = field(default_factory=list)

    @property
    def body_count(self) -> int:
        return len(self.body_fixed)

    @property
    def joint_count(self) -> int:
        return len(self.joint_parent)


def rotation_matrix(orientation) -> np.ndarray:
    """World-from-body rotation of a scene Orientation (None = identity)."""
    if orientation is None:
        return np.eye(3)
    if orientation.rpy is not None:
        r, p, y = orientation.rpy
        rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
        ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
        rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
        return rz @ ry @ rx
    x, y, z, w = np.asarray(orientation.quat_xyzw) / np.linalg.norm(orientation.quat_xyzw)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def jacobian(x_bar) -> np.ndarray:
    """J(x̄), the 3×12 map from q to the world point of rest point x̄ (physics_spec §1.2)."""
    j = np.zeros((3, 12))
    for r in range(3):
        j[r, r] = 1.0
        j[r, 3 + 3 * r:6 + 3 * r] = x_bar
    return j


def _skew(w) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _joint_frame(axis) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal (n, b) with (t̂, n, b) right-handed, per physics_spec §5.1."""
    t = axis / np.linalg.norm(axis)
    s = np.array([1.0, 0.0, 0.0]) if abs(t[0]) <= 0.9 else np.array([0.0, 1.0, 0.0])
    n = np.cross(t, s)
    n /= np.linalg.norm(n)
    b = np.cross(t, n)
    return n, b / np.linalg.norm(b)


def build_model(scene) -> HostModel:
    """Precompute the constant arrays of ``scene``; warn about torques that cannot act."""
    nb, nj = len(scene.bodies), len(scene.joints)
    props = [mass_properties(b.shape, b.density, b.mass) for b in scene.bodies]
    rotations = [rotation_matrix(b.orientation) for b in scene.bodies]
    q0, v0 = np.zeros((nb, 12)), np.zeros((nb, 12))
    for i, (body, rot) in enumerate(zip(scene.bodies, rotations)):
        q0[i, :3], q0[i, 3:] = body.position, rot.reshape(9)
        if not body.fixed:
            v0[i, :3] = body.linear_velocity
            v0[i, 3:] = (_skew(body.angular_velocity) @ rot).reshape(9)
    fixed = np.array([b.fixed for b in scene.bodies], dtype=np.int32)
    mass = np.array([p.mass for p in props])

    parent = np.array([scene.body_index(j.parent) for j in scene.joints], dtype=np.int32)
    child = np.array([scene.body_index(j.child) for j in scene.joints], dtype=np.int32)
    stiffness = np.array([j.strength_ratio * (mass[parent[k]] + mass[child[k]])
                          for k, j in enumerate(scene.joints)])
    anchors, frames = np.zeros((nj, 4, 3)), np.zeros((nj, 4, 3))
    for k, joint in enumerate(scene.joints):
        x0, x1 = np.asarray(joint.x0), np.asarray(joint.x1)
        for side, body in enumerate((parent[k], child[k])):
            rot, p = rotations[body], q0[body, :3]
            anchors[k, 2 * side] = rot.T @ (x0 - p)      # rest point of x0 (A⁻¹ = Aᵀ at t = 0)
            anchors[k, 2 * side + 1] = rot.T @ (x1 - p)
        n, b = _joint_frame(x1 - x0)
        frames[k] = [rotations[parent[k]].T @ n, rotations[parent[k]].T @ b,
                     rotations[child[k]].T @ n, rotations[child[k]].T @ b]

    joint_hessian = np.zeros((nb, 12, 12))
    for k in range(nj):
        u0, u1, w0, w1 = anchors[k]
        joint_hessian[parent[k]] += stiffness[k] * (
            jacobian(u0).T @ jacobian(u0) + jacobian(u1).T @ jacobian(u1))
        joint_hessian[child[k]] += stiffness[k] * (
            jacobian(w0).T @ jacobian(w0) + jacobian(w1).T @ jacobian(w1))
    elim_order, elim_parent, elim_offdiag = _elimination(scene, fixed, parent, child,
                                                         stiffness, anchors)
    torque_model = np.array([LEVER_ARM if j.torque_model == 'lever_arm' else GENERALIZED
                             for j in scene.joints], dtype=np.int32)
    _warn_com_on_axis(scene, fixed, anchors, torque_model, parent, child)

    gravity = np.asarray(scene.gravity, dtype=np.float64)
    has_free = np.array([not (fixed[parent[k]] and fixed[child[k]]) for k in range(nj)],
                        dtype=np.int32)
    free = not fixed.all()
    active = [term for term, on in (
        ('inertia', free), ('orthogonality', free), ('gravity', free and gravity.any()),
        ('joints', bool(has_free.any()))) if on]
    return HostModel(
        dt=scene.dt, gravity=gravity,
        integrator=BDF2 if scene.solver.integrator == 'bdf2' else BDF1,
        newton_tol=scene.solver.newton_tol, newton_max_iter=scene.solver.newton_max_iter,
        line_search=scene.solver.line_search, precision=scene.solver.precision,
        body_fixed=fixed, body_mass=mass,
        body_second_moment=np.array([p.second_moment for p in props]),
        body_ortho_coeff=np.array([b.kappa * p.volume for b, p in zip(scene.bodies, props)]),
        body_half_extent=np.array([p.half_extent for p in props]),
        body_joint_hessian=joint_hessian, body_q0=q0, body_v0=v0,
        elim_order=elim_order, elim_parent=elim_parent, elim_offdiag=elim_offdiag,
        joint_parent=parent, joint_child=child, joint_stiffness=stiffness,
        joint_anchors=anchors, joint_frames=frames, joint_torque_model=torque_model,
        joint_angle_mode=np.array([int(j.angle_mode == 'continuous') for j in scene.joints],
                                  dtype=np.int32),
        joint_has_free=has_free, active_terms=active)


def _elimination(scene, fixed, parent, child, stiffness, anchors):
    """Leaves-first order of the free bodies and each one's coupling block to its tree parent.

    Free bodies joined by joints form a forest. Each tree is rooted at a body jointed to a fixed
    body when there is one (else its first body) and listed breadth-first; the reversed list puts
    every body before its tree parent, so block elimination in that order has no fill-in.
    """
    nb = len(fixed)
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
                u0, u1, w0, w1 = anchors[k]
                h_pc = -stiffness[k] * (jacobian(u0).T @ jacobian(w0) +
                                        jacobian(u1).T @ jacobian(w1))
                elim_offdiag[other] = h_pc.T if other == child[k] else h_pc
        order += queue
    return np.array(order[::-1], dtype=np.int32), elim_parent, elim_offdiag


def _warn_com_on_axis(scene, fixed, anchors, torque_model, parent, child):
    """lever_arm applies no torque to a body whose centre of mass lies on the axis: say so."""
    for k, joint in enumerate(scene.joints):
        if torque_model[k] != LEVER_ARM:
            continue
        for body, a0, a1 in ((parent[k], anchors[k, 0], anchors[k, 1]),
                             (child[k], anchors[k, 2], anchors[k, 3])):
            e = (a1 - a0) / np.linalg.norm(a1 - a0)
            d = -a0
            r = d - (d @ e) * e
            if not fixed[body] and r @ r <= 1e-12:
                warnings.warn(
                    f'joint {joint.name!r}: the centre of mass of body '
                    f'{scene.bodies[body].name!r} lies on the joint axis, so torque_model '
                    'lever_arm applies no torque to it; use torque_model: generalized',
                    SimulationWarning, stacklevel=3)
