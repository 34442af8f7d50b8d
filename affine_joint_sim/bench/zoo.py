"""The robot zoo of ``bench robots``: public URDFs from example-robot-data (the optional extra
``zoo``), each run fixed-base from a pose inside its limits, under gravity compensation plus a
small push. Not a section itself.

A case is a zoo name or a URDF path. Its pose puts every limited joint at 0 moved inside
[lower + MARGIN·range, upper − MARGIN·range] (so the push does not drive it into a limit
within the run), every unlimited joint at 0. Its torques are τ = h(q0) + M(q0)·PUSH per joint
[N·m | N]: the rigid tree's gravity load at the pose (``references.RigidTree``: the joints'
generalized forces that hold the pose) plus the accelerations PUSH [rad/s² | m/s²], held for
the whole run; a mimic joint's goes to its leader (``leaders_carry``).
"""

from pathlib import Path
from typing import NamedTuple

import numpy as np

__all__ = ['ROBOTS', 'MARGIN', 'PUSH', 'FRICTION_SHARE', 'ZooError', 'Robot', 'installed',
           'urdf_path', 'load', 'leaders_carry', 'frictions', 'with_friction']

MARGIN = 0.1     # of each limited joint's range kept free on either side of the pose
PUSH = 0.1       # rad/s² (revolute) or m/s² (prismatic) added to gravity compensation
FRICTION_SHARE = 0.5    # joint friction of the friction runs: this share of each joint's push


class Robot(NamedTuple):
    """A zoo robot: its URDF inside example-robot-data's robots/ and what it is."""

    path: str
    kind: str


ROBOTS = {
    'ur5': Robot('ur_description/urdf/ur5_robot.urdf', 'arm'),
    'kinova': Robot('kinova_description/robots/kinova.urdf', 'arm and gripper'),
    'panda': Robot('panda_description/urdf/panda.urdf', 'arm and gripper'),
    'solo12': Robot('solo_description/robots/solo12.urdf', 'quadruped'),
    'g1': Robot('g1_description/urdf/g1_29dof_rev_1_0.urdf', 'humanoid'),
    'talos': Robot('talos_data/robots/talos_reduced.urdf', 'humanoid'),
}


class ZooError(RuntimeError):
    """A zoo robot was asked for without example-robot-data installed."""


def _root() -> Path | None:
    """example-robot-data's robots/ directory, None where it is not installed."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        return Path(str(distribution('example-robot-data').locate_file(
            'cmeel.prefix/share/example-robot-data/robots')))
    except PackageNotFoundError:
        return None


def installed() -> bool:
    """Whether the zoo's URDFs (example-robot-data) are installed."""
    return _root() is not None


def urdf_path(name: str) -> Path:
    """The URDF of zoo robot ``name``, or ``name`` itself when it is a file."""
    if name not in ROBOTS:
        path = Path(name)
        if not path.is_file():
            raise ZooError(f'bench robots: {name!r} is neither a zoo robot '
                           f'({", ".join(ROBOTS)}) nor a URDF file')
        return path
    root = _root()
    if root is None:
        raise ZooError("bench robots: the zoo's URDFs come from example-robot-data, the extra "
                       "'zoo': .venv/bin/pip install -e '.[zoo]'")
    return root / ROBOTS[name].path


def load(name: str, dts) -> tuple[dict, np.ndarray]:
    """({dt: scene at dt in its pose} for each of ``dts`` [s], torques per scene joint) of
    case ``name``; the torques do not depend on dt."""
    from affine_joint_sim.bench.references import RigidTree
    from affine_joint_sim.scene import Scene

    path = urdf_path(name)
    pose = {j.name: _inside(j.limit) for j in Scene.from_urdf(path).joints
            if j.mimic is None}         # a mimic joint starts where its leader puts it
    scenes = {dt: Scene.from_urdf(path, dt=dt, initial_positions=pose) for dt in dts}
    scene = scenes[dts[0]]
    tree = RigidTree(scene)
    start = np.array([j.initial_position for j in scene.joints])
    still = np.zeros(len(start))
    mass = tree.mass_matrix(start)
    gravity_load = -mass @ tree.acceleration(start, still, still)     # h(q0)
    return scenes, leaders_carry(scene, gravity_load + mass @ np.full(len(start), PUSH))


def leaders_carry(scene, torques) -> np.ndarray:
    """``torques`` (per scene joint) with each mimic joint's moved to its leader, times the
    multiplier: the generalized force of the coupled pair (virtual work: τ_l + m τ_f), which a
    follower, taking no command, cannot receive itself. Followers of followers first."""
    out = np.array(torques, dtype=np.float64)
    leader = {k: scene.joint_index(j.mimic.joint) for k, j in enumerate(scene.joints)
              if j.mimic is not None}

    def depth(k):
        return 0 if k not in leader else 1 + depth(leader[k])
    for k in sorted(leader, key=depth, reverse=True):
        out[leader[k]] += scene.joints[k].mimic.multiplier * out[k]
        out[k] = 0.0
    return out


def _inside(limit) -> float:
    """0, moved inside the limit's range by MARGIN of it on either side."""
    if limit is None:
        return 0.0
    margin = MARGIN * (limit.upper - limit.lower)
    return min(max(0.0, limit.lower + margin), limit.upper - margin)


def frictions(scene) -> np.ndarray:
    """Coulomb friction per scene joint [N·m | N] of the friction runs: FRICTION_SHARE of the
    joint's share of the push, |M(q0) PUSH|, so that every joint still slides (at about half
    the push) and friction acts throughout."""
    from affine_joint_sim.bench.references import RigidTree

    start = np.array([j.initial_position for j in scene.joints])
    push = RigidTree(scene).mass_matrix(start) @ np.full(len(start), PUSH)
    return FRICTION_SHARE * np.abs(push)


def with_friction(scene, friction):
    """``scene`` with joint k's Coulomb friction ``friction[k]`` (0: none, whatever its URDF
    says)."""
    joints = [j.model_copy(update={'friction': float(f)}) for j, f in zip(scene.joints, friction)]
    return scene.model_copy(update={'joints': joints})
