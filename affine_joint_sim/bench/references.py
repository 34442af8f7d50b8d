"""Independent truth for the sweep and the robot bench: the scene as a rigid multibody tree,
integrated by RK4.

Nothing here uses the stepper or its kernels: each body is rigid (inertia from the primitive's
closed form, computed here), each revolute joint an exact hinge, each prismatic joint an exact
slider; a joint's torque is a couple about the hinge axis (child +, parent −), a prismatic
joint's force a pair of opposite forces along its axis, each joint's damping c a generalized
force −c q̇. The equations of motion M(q) q̈ + h(q, q̇) = τ − c q̇ are assembled from body
Jacobians: M = Σ m J_vᵀJ_v + J_ωᵀ I J_ω and h = Σ J_vᵀ m a⁰ + J_ωᵀ (I α⁰ + ω × Iω), where
a⁰, α⁰ are the bodies' accelerations at q̈ = 0 with the fixed bodies accelerating by −g (so h
carries gravity). World frame, z up, SI units; q_j is the right-hand rotation [rad] of joint
j's child relative to its parent about x1 − x0 (revolute), or its displacement [m] along
x1 − x0 (prismatic), equal to the joint's ``initial_position`` at t = 0 (as the stepper
reports it; every θ argument below is such a coordinate). Joint limits are not modelled:
cases stay inside them. Fixed joints are not modelled either (a URDF's are welded).
"""

import math

import numpy as np

from affine_joint_sim.physics.host.mass import body_mass_properties
from affine_joint_sim.rotations import axis_rotation, rotation_matrix

__all__ = ['RigidTree', 'rigid_inertia']


def rigid_inertia(shape, mass: float) -> np.ndarray:
    """Inertia tensor about the centre of mass in body axes [kg·m²] of a scene Shape."""
    if shape.kind == 'box':
        a, b, c = shape.box
        return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    if shape.kind == 'cylinder':
        r, h = shape.cylinder.radius, shape.cylinder.length
        side = mass * (3.0 * r * r + h * h) / 12.0
        return np.diag([side, side, mass * r * r / 2.0])
    return np.eye(3) * 0.4 * mass * shape.sphere.radius ** 2


def _body_inertia(body, mass: float) -> np.ndarray:
    """A scene body's inertia tensor about its COM in body axes: its principal moments when
    given (URDF links), the primitive's closed form otherwise, zero for a bare fixed body."""
    if body.inertia is not None:
        return np.diag(body.inertia)
    if body.shape is None:
        return np.zeros((3, 3))
    return rigid_inertia(body.shape, mass)


def _cross(a, b) -> np.ndarray:
    """a × b of two 3-vectors (np.cross is slower: docs/architecture.md#measured-figures)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


class RigidTree:
    """A scene's bodies as rigid bodies on exact hinges, hanging from its fixed bodies.

    Every free body must be the child of exactly one joint, on a path of joints that starts at
    a fixed body, and every body must start at rest.
    """

    def __init__(self, scene):
        self.scene = scene
        self.gravity = np.asarray(scene.gravity, dtype=float)
        bodies = scene.bodies
        self.fixed = np.array([b.fixed for b in bodies])
        self.mass = np.array([body_mass_properties(b).mass for b in bodies])
        self.rotation0 = np.array([rotation_matrix(b.orientation) for b in bodies])
        self.com0 = np.array([b.position for b in bodies], dtype=float)
        self.inertia = np.array([_body_inertia(b, m) for b, m in zip(bodies, self.mass)])
        if any(np.any(b.linear_velocity) or np.any(b.angular_velocity) for b in bodies):
            raise ValueError('the rigid reference starts every body at rest')
        self.parent = np.array([scene.body_index(j.parent) for j in scene.joints])
        self.child = np.array([scene.body_index(j.child) for j in scene.joints])
        self.axis0 = np.array([np.subtract(j.x1, j.x0) / math.dist(j.x1, j.x0)
                               for j in scene.joints])
        self.point0 = np.array([j.x0 for j in scene.joints], dtype=float)
        self.sliding = np.array([j.type == 'prismatic' for j in scene.joints], dtype=bool)
        if any(j.type not in ('revolute', 'prismatic') for j in scene.joints):
            raise ValueError('the rigid reference models revolute and prismatic joints only')
        self.damping = np.array([j.damping for j in scene.joints], dtype=float)
        self.offset = np.array([j.initial_position for j in scene.joints], dtype=float)
        self.order = self._joint_order()
        # ancestors[b, j]: joint j lies on the path from a fixed body to body b
        self.ancestors = np.zeros((len(bodies), len(scene.joints)), dtype=bool)
        for j in self.order:
            self.ancestors[self.child[j]] = self.ancestors[self.parent[j]]
            self.ancestors[self.child[j], j] = True

    def _joint_order(self) -> list[int]:
        """Joints parents-first; checks that the free bodies form trees under fixed bodies."""
        placed = set(np.flatnonzero(self.fixed))
        order, pending = [], list(range(len(self.parent)))
        while pending:
            ready = [j for j in pending if self.parent[j] in placed]
            if not ready:
                raise ValueError('the rigid reference needs every joint chain to start at a '
                                 'fixed body')
            for j in ready:
                if self.child[j] in placed:
                    raise ValueError(f'body {self.scene.bodies[self.child[j]].name!r} is the '
                                     'child of two joints or fixed')
                placed.add(self.child[j])
                order.append(j)
                pending.remove(j)
        if len(placed) != len(self.fixed):
            raise ValueError('the rigid reference needs every free body on a joint')
        return order

    def _forward(self, theta, omega):
        """World pose and velocity-product accelerations of every body at θ, θ̇ (θ̈ = 0).

        Returns rotations R (nb, 3, 3), COMs c (nb, 3), joint axes e and points x (nj, 3),
        angular velocities ω (nb, 3), and a⁰ (COM, with −g on the fixed bodies) and α⁰.
        """
        nb = len(self.fixed)
        disp_rot = np.broadcast_to(np.eye(3), (nb, 3, 3)).copy()   # x ↦ D x + t from t = 0
        disp_t = np.zeros((nb, 3))
        axes, points = np.zeros_like(self.axis0), np.zeros_like(self.point0)
        w, alpha, acc = np.zeros((nb, 3)), np.zeros((nb, 3)), np.tile(-self.gravity, (nb, 1))
        com = self.com0.copy()
        for j in self.order:
            p, c = self.parent[j], self.child[j]
            axes[j] = disp_rot[p] @ self.axis0[j]
            points[j] = disp_rot[p] @ self.point0[j] + disp_t[p]
            rate = axes[j] * omega[j]
            if self.sliding[j]:
                disp_rot[c] = disp_rot[p]
                disp_t[c] = disp_t[p] + axes[j] * (theta[j] - self.offset[j])
            else:
                turn = axis_rotation(self.axis0[j], theta[j] - self.offset[j])
                disp_rot[c] = disp_rot[p] @ turn
                disp_t[c] = disp_rot[p] @ (self.point0[j] - turn @ self.point0[j]) + disp_t[p]
            com[c] = disp_rot[c] @ self.com0[c] + disp_t[c]
            if self.sliding[j]:     # the child COM as a point of the parent, plus Coriolis
                lever = com[c] - com[p]
                w[c], alpha[c] = w[p], alpha[p]
                acc[c] = (acc[p] + _cross(alpha[p], lever) + _cross(w[p], _cross(w[p], lever))
                          + 2.0 * _cross(w[p], rate))
                continue
            hinge_acc = acc[p] + _cross(alpha[p], points[j] - com[p]) + _cross(
                w[p], _cross(w[p], points[j] - com[p]))
            w[c] = w[p] + rate
            alpha[c] = alpha[p] + _cross(w[p], rate)
            arm = com[c] - points[j]
            acc[c] = hinge_acc + _cross(alpha[c], arm) + _cross(w[c], _cross(w[c], arm))
        return disp_rot @ self.rotation0, com, axes, points, w, acc, alpha

    def _jacobians(self, com, axes, points):
        """J_ω, J_v of every body's COM: (nb, 3, nj) each (a slider turns nothing and moves
        every body below it along its axis)."""
        jw = self.ancestors[:, None, :] * np.where(self.sliding[:, None], 0.0, axes).T[None]
        jv = np.cross(axes[None, :, :], com[:, None, :] - points[None, :, :])   # (nb, nj, 3)
        jv = np.where(self.sliding[None, :, None], axes[None], jv)
        return jw, self.ancestors[:, None, :] * np.swapaxes(jv, 1, 2)

    def _mass_matrix(self, rot, com, axes, points) -> np.ndarray:
        free = ~self.fixed
        jw, jv = self._jacobians(com, axes, points)
        inertia = rot @ self.inertia @ np.swapaxes(rot, 1, 2)            # world, about COM
        m = self.mass[:, None, None]
        return np.einsum('bki,bkj->ij', (m * jv)[free], jv[free]) + np.einsum(
            'bki,bkl,blj->ij', jw[free], inertia[free], jw[free])

    def mass_matrix(self, theta) -> np.ndarray:
        """Joint-space mass matrix M(θ) [kg·m²]: Σ m J_vᵀJ_v + J_ωᵀ I J_ω over free bodies."""
        rot, com, axes, points, *_ = self._forward(theta, np.zeros_like(theta))
        return self._mass_matrix(rot, com, axes, points)

    def acceleration(self, theta, omega, torque) -> np.ndarray:
        """θ̈ [rad/s²] of M(θ) θ̈ + h(θ, θ̇) = τ − c θ̇ (θ from the pose at t = 0)."""
        rot, com, axes, points, w, acc, alpha = self._forward(theta, omega)
        free = ~self.fixed
        jw, jv = self._jacobians(com, axes, points)
        inertia = rot @ self.inertia @ np.swapaxes(rot, 1, 2)
        spin = np.einsum('bij,bj->bi', inertia, alpha) + np.cross(
            w, np.einsum('bij,bj->bi', inertia, w))
        bias = np.einsum('bki,bk->i', jv[free], (self.mass[:, None] * acc)[free]) + np.einsum(
            'bki,bk->i', jw[free], spin[free])
        return np.linalg.solve(self._mass_matrix(rot, com, axes, points),
                               torque - self.damping * omega - bias)

    def energy(self, theta, omega) -> float:
        """Kinetic + gravity energy [J] of the free bodies."""
        rot, com, axes, points, *_ = self._forward(theta, np.zeros_like(omega))
        kinetic = 0.5 * omega @ self._mass_matrix(rot, com, axes, points) @ omega
        return float(kinetic - np.sum((self.mass * (com @ self.gravity))[~self.fixed]))

    def simulate(self, torques, times, step: float = 1e-3):
        """Joint coordinates [rad | m] (from the initial positions) and velocities at ``times``
        [s] under constant torques.

        Args:
            torques: τ per joint [N·m | N], couples about each hinge, forces along each slider.
            times: increasing sample times, multiples of ``step``.
            step: RK4 step [s].

        Returns:
            (angles, velocities), each of shape (len(times), n_joints).
        """
        torques = np.asarray(torques, dtype=float)
        self._check_couples(torques)
        n = len(self.parent)
        y = np.concatenate([self.offset, np.zeros(n)])

        def rate(state):
            return np.concatenate([state[n:], self.acceleration(state[:n], state[n:], torques)])

        out, done = [], 0
        for t in times:
            for _ in range(round(t / step) - done):
                k1 = rate(y)
                k2 = rate(y + step / 2 * k1)
                k3 = rate(y + step / 2 * k2)
                k4 = rate(y + step * k3)
                y = y + step / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            done = round(t / step)
            out.append(y.copy())
        out = np.array(out)
        return out[:, :n], out[:, n:]

    def _check_couples(self, torques):
        """A lever_arm torque is the couple modelled here only on a fixed parent, COM off axis."""
        for j, joint in enumerate(self.scene.joints):
            if torques[j] == 0.0 or self.sliding[j] or joint.torque_model != 'lever_arm':
                continue
            c = self.child[j]
            off_axis = np.cross(self.axis0[j], self.com0[c] - self.point0[j])
            if not self.fixed[self.parent[j]] or np.linalg.norm(off_axis) < 1e-6:
                raise ValueError(f'joint {joint.name!r}: a lever_arm torque is a couple only '
                                 'with a fixed parent and the child COM off the axis')
