"""MuJoCo (the optional extra ``compare``) on a URDF robot: the peer and the fine reference of
``bench robots``. Not a section itself.

MuJoCo reads the URDF itself, with its visuals and collisions stripped (meshes are never
needed); contacts, friction loss and equality constraints are off (MuJoCo turns a URDF
``<mimic>`` into an equality, which this project does not model), so both simulators see the
same rigid tree, URDF damping as joint damping, and the same joint limits. Torques enter as
generalized forces (``qfrc_applied``) per joint, in the scene's joint order.
"""

import re

import numpy as np

__all__ = ['available', 'MujocoRobot']

_STRIP = re.compile(r'<(visual|collision)\b.*?</\1>|<(visual|collision)\b[^>]*/>', re.S)


def available() -> bool:
    """Whether mujoco can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


class MujocoRobot:
    """A fixed-base URDF robot in MuJoCo, joints in the order of our scene's joints."""

    def __init__(self, urdf_path, scene):
        import mujoco

        self.mujoco = mujoco
        text = _STRIP.sub('', open(urdf_path, encoding='utf-8').read())
        text = re.sub(r'(<robot\b[^>]*>)', r'\1<mujoco><compiler discardvisual="true" '
                      r'fusestatic="false" balanceinertia="false"/></mujoco>', text, count=1)
        self.model = model = mujoco.MjModel.from_xml_string(text)
        flags = mujoco.mjtDisableBit
        model.opt.disableflags |= flags.mjDSBL_CONTACT | flags.mjDSBL_EQUALITY
        model.opt.gravity[:] = scene.gravity
        model.dof_frictionloss[:] = 0.0
        names = [model.joint(i).name for i in range(model.njnt)]
        joints = [names.index(j.name) for j in scene.joints]
        self.index = model.jnt_qposadr[joints]      # coordinates (hinges and slides: one each)
        self.dof = model.jnt_dofadr[joints]         # their generalized forces
        self.start = np.array([j.initial_position for j in scene.joints])

    def _start(self, torques, dt: float, integrator: str):
        """MjData at the start pose under constant ``torques`` (scene joint order), the model
        set to ``dt`` [s] and ``integrator`` ('euler' or 'rk4')."""
        mujoco, model = self.mujoco, self.model
        model.opt.timestep = dt
        model.opt.integrator = (mujoco.mjtIntegrator.mjINT_RK4 if integrator == 'rk4'
                                else mujoco.mjtIntegrator.mjINT_EULER)
        data = mujoco.MjData(model)
        data.qpos[self.index] = self.start
        data.qfrc_applied[self.dof] = torques
        return data

    def run(self, torques, dt: float, integrator: str, steps: int, every: int = 1):
        """Joint coordinates every ``every`` steps, shape (steps // every, n_joints), of
        ``steps`` steps of ``dt`` [s] with ``integrator`` ('euler' or 'rk4') under constant
        ``torques`` (scene joint order)."""
        data = self._start(torques, dt, integrator)
        out = []
        for _ in range(steps // every):
            for _ in range(every):
                self.mujoco.mj_step(self.model, data)
            out.append(data.qpos[self.index].copy())
        return np.array(out)

    def timer(self, torques, dt: float, integrator: str):
        """(setup, run) for ``timing.interleaved_us``: setup starts a run as ``run`` does,
        run is one mj_step."""
        mujoco, model = self.mujoco, self.model
        state = {}

        def setup():
            state['data'] = self._start(torques, dt, integrator)

        def step():
            mujoco.mj_step(model, state['data'])
        return setup, step
