"""Pinocchio (``pin`` on PyPI, the optional extra ``reference``) as an independent rigid-body
truth for URDF robots: it reads the URDF itself, so it checks our conversion of the URDF as well
as the dynamics. Joint space ABA (articulated-body algorithm) integrated by RK4 at a fine step,
joint damping as a torque −c q̇, gravity of the scene. Revolute and prismatic joints only (a
continuous joint is a unit-circle pair in Pinocchio's configuration).
"""

import numpy as np

__all__ = ['available', 'PinocchioArm']


def available() -> bool:
    """Whether pinocchio can be imported."""
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return False
    return True


class PinocchioArm:
    """A fixed-base URDF robot in Pinocchio, joints in the URDF's order of our scene."""

    def __init__(self, urdf_path, scene):
        import pinocchio as pin

        self.pin = pin
        self.model = pin.buildModelFromUrdf(str(urdf_path))
        self.model.gravity.linear = np.asarray(scene.gravity, dtype=float)
        self.data = self.model.createData()
        names = list(self.model.names)[1:]             # [0] is the universe
        if any(self.model.joints[i].nq != 1 for i in range(1, self.model.njoints)):
            raise ValueError('only revolute and prismatic joints (nq = 1) are compared')
        self.index = [names.index(j.name) for j in scene.joints if j.type != 'fixed']
        self.damping = np.array([j.damping for j in scene.joints if j.type != 'fixed'])
        self.start = np.array([j.initial_position for j in scene.joints if j.type != 'fixed'])

    def simulate(self, torques, times, step: float = 5e-4):
        """Joint coordinates at ``times`` [s] under constant torques (scene joint order)."""
        n = len(self.index)
        q, v = np.zeros(n), np.zeros(n)
        q[self.index] = self.start
        tau = np.zeros(n)
        tau[self.index] = torques
        damping = np.zeros(n)
        damping[self.index] = self.damping

        def rate(q, v):
            return v, self.pin.aba(self.model, self.data, q, v, tau - damping * v)

        out, done = [], 0
        for t in times:
            for _ in range(round(t / step) - done):
                k1 = rate(q, v)
                k2 = rate(q + step / 2 * k1[0], v + step / 2 * k1[1])
                k3 = rate(q + step / 2 * k2[0], v + step / 2 * k2[1])
                k4 = rate(q + step * k3[0], v + step * k3[1])
                q = q + step / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
                v = v + step / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            done = round(t / step)
            out.append(q[self.index].copy())
        return np.array(out)
