"""What the accuracy sweep simulates, and the independent truth each case is judged by.

A case is a scene, constant joint torques and a duration; every run of the sweep replaces only
the scene's ``dt`` and ``solver`` settings. The truth is the scene as a rigid multibody tree
(``references.RigidTree``) integrated by RK4, sampled every ``SAMPLE_EVERY`` seconds (for the
wheel it reproduces the closed form θ = τt²/(2I), for the 3-D arm it is the only independent
truth at hand). Where the system is a chain of boxes on hinges about world x, ``mujoco`` holds
the same system for MuJoCo (``bench.mujoco_ref``). For a URDF robot the reference is built from
our scene of it; with Pinocchio installed (extra ``reference``), Pinocchio's own reading of the
URDF checks it (``bench.pinocchio_ref``), and their difference joins the error estimate.
"""

from pathlib import Path
from typing import NamedTuple

import numpy as np

from affine_joint_sim.bench import pinocchio_ref
from affine_joint_sim.bench.mujoco_ref import MujocoChain
from affine_joint_sim.bench.references import RigidTree
from affine_joint_sim.chain import chain_scene
from affine_joint_sim.resources import config_dir, scene_path
from affine_joint_sim.scene import Scene

__all__ = ['Case', 'Reference', 'SAMPLE_EVERY', 'cases', 'custom_case', 'reference',
           'with_settings']

SAMPLE_EVERY = 0.1       # s between the samples where angles are compared
REFERENCE_STEP = 2e-3    # s, RK4 step of the reference (checked against half of it)


class Case(NamedTuple):
    name: str
    scene: Scene
    torques: dict            # joint name -> constant torque [N·m]
    duration: float          # simulated time [s]
    mujoco: MujocoChain | None = None
    urdf: Path | None = None  # the robot's URDF, for Pinocchio

    @property
    def times(self) -> np.ndarray:
        """Sample times [s]: every SAMPLE_EVERY up to the duration."""
        return SAMPLE_EVERY * np.arange(1, round(self.duration / SAMPLE_EVERY) + 1)

    def torque_vector(self) -> np.ndarray:
        """Torques in scene joint order [N·m]."""
        return np.array([self.torques.get(j.name, 0.0) for j in self.scene.joints])


class Reference(NamedTuple):
    label: str
    angles: np.ndarray       # (samples, joints) [rad]
    error_estimate: float    # largest change of the angles when the RK4 step halves [rad]
    energy_scale: float      # largest kinetic energy along the way [J]


def _packaged(name: str) -> Scene:
    return Scene.load(scene_path(name))


def cases() -> list[Case]:
    """The sweep's cases: the packaged scenes under constant torques, and a falling chain."""
    return [
        Case('pendulum', _packaged('pendulum'), {'shoulder': 2.0}, 1.0,
             MujocoChain(1, 1.0, 0.1, 1.0, torque=2.0)),
        Case('double_pendulum', _packaged('double_pendulum'), {'shoulder': 2.0}, 1.0,
             MujocoChain(2, 1.0, 0.1, 1.0, torque=2.0)),
        Case('chain8', chain_scene(8, angle=0.5), {}, 1.0,
             MujocoChain(8, 0.5, 0.05, 1.0, angle=0.5)),
        Case('wheel', _packaged('wheel'), {'spin': 1.0}, 1.0),
        Case('arm', _packaged('arm'), {'yaw': 0.3, 'shoulder': 1.0, 'elbow': -0.5}, 0.5),
        # falling from its bent start (inside every limit for 0.4 s) while panning
        Case('arm6', _packaged('arm6'), {'shoulder_pan': 0.5}, 0.4,
             urdf=config_dir() / 'robots' / 'arm6.urdf'),
    ]


def custom_case(scene: str, torques: tuple, duration: float) -> Case:
    """A case of any scene file (YAML or URDF) or packaged scene under constant ``torques``
    ((joint, N·m) pairs) for ``duration`` [s], named ``scene[joint=τ,...]``; its truth is the
    rigid tree (revolute joints, every body on a path from a fixed one, starting at rest)."""
    path = scene_path(scene)
    loaded = Scene.load(path)
    other = [f'{j.name} ({j.type})' for j in loaded.joints if j.type != 'revolute']
    if other:
        raise ValueError(f'scene {scene!r}: the rigid reference takes revolute joints only, '
                         f'not {", ".join(other)}')
    name = Path(scene).stem + (
        '[' + ','.join(f'{joint}={value:g}' for joint, value in torques) + ']' if torques
        else '')
    return Case(name, loaded, dict(torques), duration,
                urdf=path if path.suffix.lower() == '.urdf' else None)


def with_settings(scene: Scene, dt: float, integrator: str, newton_tol: float,
                  precision: str) -> Scene:
    """``scene`` with time step ``dt`` [s] and the given solver knobs."""
    data = scene.model_dump(exclude_none=True)
    data['dt'] = dt
    data['solver'] = dict(data.get('solver', {}), integrator=integrator,
                          newton_tol=newton_tol, precision=precision)
    return Scene.from_dict(data, source=f'{scene.name} at dt {dt}')


def reference(case: Case) -> Reference:
    """The rigid-body truth of ``case`` at its sample times (RK4, with its own error estimate)."""
    tree = RigidTree(case.scene)
    torque = case.torque_vector()
    coarse, _ = tree.simulate(torque, case.times, step=REFERENCE_STEP)
    angles, velocities = tree.simulate(torque, case.times, step=REFERENCE_STEP / 2)
    kinetic = [tree.energy(a, w) - tree.energy(a, 0 * w) for a, w in zip(angles, velocities)]
    label = f'rigid-body ODE, RK4 at {REFERENCE_STEP / 2:g} s'
    estimate = np.abs(angles - coarse).max()
    if case.urdf is not None and pinocchio_ref.available():
        other = pinocchio_ref.PinocchioArm(case.urdf, case.scene).simulate(torque, case.times)
        gap = np.abs(angles - other).max()
        label += f'; Pinocchio on the URDF agrees to {gap:.1e} rad'
        estimate = max(estimate, gap)
    return Reference(label, angles, float(estimate), max(kinetic))
