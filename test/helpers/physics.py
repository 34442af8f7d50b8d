"""Physics test helpers: random non-rigid states of a packaged scene for derivative checks of
the physics stages, and scenes that stress the solver."""

from pathlib import Path

import numpy as np

from affine_joint_sim import Scene
from affine_joint_sim.physics.evaluate import Stages

SCENES = Path(__file__).resolve().parents[2] / 'msg_configs' / 'scenes'


def random_rotation(rng):
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


class Probe:
    """A scene's Stages at a random state q0 (free bodies non-rigid) and prediction q_tilde."""

    def __init__(self, scene, rng, stretch):
        if isinstance(scene, str):
            scene = Scene.from_yaml(SCENES / f'{scene}.yaml')
        self.stages = Stages(scene)
        self.free = self.stages.free
        host = self.stages.host
        q = host.body_q0.copy()
        for b in self.free:
            # non-rigid: A = R1 diag(σ) R2 with σ all above 1 (stretch) or spread around 1
            sigma = rng.uniform(1.05, 1.3, 3) if stretch else rng.uniform(0.7, 1.3, 3)
            q[b, 3:] = (random_rotation(rng) @ np.diag(sigma) @ random_rotation(rng)).reshape(9)
            q[b, :3] += rng.normal(0, 0.01, 3)
        self.q0 = q
        self.q_tilde = q + rng.normal(0, 0.01, q.shape)

    def energy(self, q):
        return self.stages.energy(q, self.q_tilde)

    def newton_system(self, q):
        return self.stages.newton_system(q, self.q_tilde)

    def perturbed(self, dof, step):
        q = self.q0.copy()
        q[self.free[dof // 12], dof % 12] += step
        return q

    def fd_gradient(self, h=1e-6):
        """Central differences of E over the free DOFs at q0."""
        return np.array([(self.energy(self.perturbed(d, h)) - self.energy(self.perturbed(d, -h)))
                         / (2 * h) for d in range(12 * len(self.free))])

    def fd_hessian(self, h=1e-6):
        """Central differences of the assembled gradient over the free DOFs at q0."""
        columns = [(self.newton_system(self.perturbed(d, h))[0]
                    - self.newton_system(self.perturbed(d, -h))[0]) / (2 * h)
                   for d in range(12 * len(self.free))]
        return np.array(columns).T


def arm_with_fingers(precision):
    """A 1 kg arm on a hinge with three 2 mg finger links (2.7 mm cubes) in series at its tip,
    hinged like a URDF's joints (axis points 0.1 m either side): placeholder masses as NAO's."""
    bodies = [{'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 1000.0,
               'fixed': True},
              {'name': 'arm', 'shape': {'box': [0.05, 0.05, 0.5]}, 'mass': 1.0,
               'position': [0.0, 0.0, -0.25]}]
    joints = [{'name': 'shoulder', 'parent': 'base', 'child': 'arm', 'x0': [-0.1, 0.0, 0.0],
               'x1': [0.1, 0.0, 0.0]}]
    for k in range(3):
        z = -0.5 - 0.003 * k
        bodies.append({'name': f'finger{k}', 'shape': {'box': [0.0027] * 3}, 'mass': 2e-6,
                       'position': [0.0, 0.0, z - 0.0015]})
        joints.append({'name': f'knuckle{k}', 'parent': bodies[-2]['name'],
                       'child': f'finger{k}', 'x0': [-0.1, 0.0, z], 'x1': [0.1, 0.0, z]})
    return Scene.from_dict({'name': 'fingers', 'dt': 0.01, 'solver': {'precision': precision},
                            'bodies': bodies, 'joints': joints})
