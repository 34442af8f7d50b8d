"""The shipped arm's grasp in ``bench bodies``: scene ``grasp`` under control script ``grasp``
(README.md#grasping), ours and MuJoCo's. Not a section itself.

Both run the same PD law from the same script in Python every step (its cost is not timed:
µs/step times the step alone). MuJoCo reads the same URDF with its collision geometry, the
table and the cube added as world geoms and a free box, every geom μ 0.8 (the scene's), the
robot's links colliding with the objects only (as ours: no self-collision). The quantities: the
cube's lift over the run, and its slip in the hand over the lift (how far the cube's rise falls
behind the left finger's from the start of the lift to the end; 0 for a firm grasp).
"""

import math
import re
import tempfile
import time
from pathlib import Path

import numpy as np

from affine_joint_sim.control_script import ControlScript, command_stepper, pd_torques
from affine_joint_sim.resources import config_dir, scene_path

__all__ = ['ours', 'mujoco', 'DURATION', 'LIFT_START']

DURATION = 3.0          # s: the script ends its lift at 2.8 s
LIFT_START = 1.8        # s: the script starts lifting


def _scene():
    from affine_joint_sim.scene import Scene
    return Scene.load(scene_path('grasp'))


def ours() -> dict:
    """Run the grasp: µs/step (mean), Newton and inner iterations per step, contacts at the
    end, the nearest distance over the run, the cube's lift and slip [m]."""
    from affine_joint_sim.stepper import Stepper

    sim, script = Stepper(_scene()), ControlScript.load('grasp')
    cube, finger = sim.link_names.index('cube'), sim.link_names.index('left_finger')
    heights = lambda: sim.link_transforms[[cube, finger], 2, 3]     # noqa: E731
    start = heights()
    times, newton, inner, nearest, at_lift = [], [], [], math.inf, None
    for _ in range(int(round(DURATION / sim.dt))):
        if at_lift is None and sim.time >= LIFT_START - 1e-9:
            at_lift = heights()
        command_stepper(sim, script)
        began = time.perf_counter()
        sim.step()
        times.append(time.perf_counter() - began)
        stats = sim.stats
        newton.append(stats['newton_iterations'])
        inner.append(stats['inner_iterations'])
        nearest = min(nearest, stats['min_distance'])
    end = heights()
    return {'us_per_step': 1e6 * float(np.mean(times)), 'newton': float(np.mean(newton)),
            'inner': float(np.mean(inner)), 'contacts': stats['contacts'],
            'min_distance': nearest, 'lift': float(end[0] - start[0]),
            'error': _slip(at_lift, end), 'dt': sim.dt}


def _slip(at_lift, end) -> float:
    """How far the cube's rise fell behind the finger's since the lift began [m]."""
    return float((end[1] - at_lift[1]) - (end[0] - at_lift[0]))


def _mjcf(scene) -> str:
    """The grasp scene in MJCF: MuJoCo's reading of the URDF (collisions kept), the robot's
    geoms colliding with the objects only, the table and the cube added."""
    import mujoco

    urdf = config_dir() / 'robots' / 'arm6_gripper.urdf'
    text = re.sub(r'(<robot\b[^>]*>)', r'\1<mujoco><compiler discardvisual="true" '
                  r'fusestatic="false" balanceinertia="false"/></mujoco>',
                  urdf.read_text(encoding='utf-8'), count=1)
    robot = mujoco.MjModel.from_xml_string(text)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / 'grasp.xml'
        mujoco.mj_saveLastXML(str(path), robot)
        mjcf = path.read_text(encoding='utf-8')
    mu = scene.contact.friction
    mjcf = re.sub(r'<geom\b', f'<geom contype="1" conaffinity="2" friction="{mu} 0.005 0.0001"',
                  mjcf)
    objects = []
    for body in scene.bodies[-2:]:                      # the table and the cube
        half = ' '.join(repr(0.5 * s) for s in body.shape.box)
        pos = ' '.join(map(repr, body.position))
        geom = (f'<geom type="box" size="{half}" contype="3" conaffinity="3" '
                f'friction="{mu} 0.005 0.0001"')
        objects.append(f'{geom} pos="{pos}"/>' if body.fixed else
                       f'<body name="{body.name}" pos="{pos}"><freejoint/>{geom} '
                       f'mass="{body.mass}"/></body>')
    return mjcf.replace('</worldbody>', ''.join(objects) + '</worldbody>', 1)


def mujoco() -> dict:
    """The grasp in MuJoCo (default Euler, soft contact): µs/step of mj_step, contacts at
    the end, the deepest contact distance, the cube's lift and slip [m]."""
    import mujoco as mj

    scene, script = _scene(), ControlScript.load('grasp')
    model = mj.MjModel.from_xml_string(_mjcf(scene))
    model.opt.timestep = scene.dt
    data = mj.MjData(model)
    joints = [model.joint(name) for name in script.joints]
    qpos = np.array([model.jnt_qposadr[j.id] for j in joints])
    dof = np.array([model.jnt_dofadr[j.id] for j in joints])
    for joint in scene.joints:
        data.qpos[model.jnt_qposadr[model.joint(joint.name).id]] = joint.initial_position
    mj.mj_forward(model, data)
    cube, finger = model.body('cube').id, model.body('left_finger').id
    heights = lambda: data.xpos[[cube, finger], 2].copy()           # noqa: E731
    start, at_lift = heights(), None
    times, deepest = [], math.inf
    for _ in range(int(round(DURATION / scene.dt))):
        if at_lift is None and data.time >= LIFT_START - 1e-9:
            at_lift = heights()
        data.qfrc_applied[dof] = pd_torques(script.kp, script.kd, script.targets_at(data.time),
                                            data.qpos[qpos], data.qvel[dof])
        began = time.perf_counter()
        mj.mj_step(model, data)
        times.append(time.perf_counter() - began)
        if data.ncon:
            deepest = min(deepest, float(data.contact.dist[:data.ncon].min()))
    end = heights()
    return {'mujoco_us': 1e6 * float(np.mean(times)), 'mujoco_contacts': int(data.ncon),
            'mujoco_min_distance': deepest, 'mujoco_lift': float(end[0] - start[0]),
            'mujoco_error': _slip(at_lift, end)}
