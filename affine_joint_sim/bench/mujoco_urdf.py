"""MuJoCo (the optional extra ``compare``) on a URDF robot: the peer and the fine reference of
``bench robots``. Not a section itself.

MuJoCo reads the URDF itself, with its visuals and collisions stripped (meshes are never
needed); contacts are off, a URDF ``<mimic>`` is MuJoCo's joint equality (as hard as MuJoCo
allows, as our coupling is stiff), and each joint's friction loss is the one given
(none by default, whatever the URDF says), so both simulators see the same rigid tree, URDF
damping as joint damping, the same joint friction (MuJoCo's friction loss as hard as it
allows: on arm6_gripper an independent rigid-body RK4 with exact Coulomb friction agrees
with its RK4 reference to 3e-5 rad over 0.5 s on the joint that moves most, where the default
softness left it 0.046 rad off) and
the same joint limits. Torques enter as
generalized forces (``qfrc_applied``) per joint, in the scene's joint order.
"""

import re

import numpy as np

__all__ = ['HARD', 'available', 'MujocoRobot']

HARD = 1e-9    # s: friction loss's and equalities' solref time constant (MuJoCo raises it to 2 dt)

_STRIP = re.compile(r'<(visual|collision)\b.*?</\1>|<(visual|collision)\b[^>]*/>', re.S)


def available() -> bool:
    """Whether mujoco can be imported."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


class MujocoRobot:
    """A fixed-base URDF robot in MuJoCo, joints in the order of our scene's joints, with
    ``friction`` [N·m | N] per joint as its friction loss (None: none)."""

    def __init__(self, urdf_path, scene, friction=None):
        import mujoco

        self.mujoco = mujoco
        text = _STRIP.sub('', open(urdf_path, encoding='utf-8').read())
        text = re.sub(r'(<robot\b[^>]*>)', r'\1<mujoco><compiler discardvisual="true" '
                      r'fusestatic="false" balanceinertia="false"/></mujoco>', text, count=1)
        self.model = model = mujoco.MjModel.from_xml_string(text)
        flags = mujoco.mjtDisableBit
        model.opt.disableflags |= flags.mjDSBL_CONTACT
        model.eq_solref[:, 0] = HARD        # the mimics' equalities
        model.opt.gravity[:] = scene.gravity
        names = [model.joint(i).name for i in range(model.njnt)]
        joints = [names.index(j.name) for j in scene.joints]
        self.index = model.jnt_qposadr[joints]      # coordinates (hinges and slides: one each)
        self.dof = model.jnt_dofadr[joints]         # their generalized forces
        model.dof_frictionloss[:] = 0.0
        if friction is not None:
            model.dof_frictionloss[self.dof] = friction
            # as hard as MuJoCo allows: its time constant is raised to two steps (refsafe);
            # at the default 0.02 s the friction loss of a slowly sliding joint is a fraction
            # of its Coulomb force (an arm's joint slid 2.8 times as far in 0.5 s)
            model.dof_solref[self.dof, 0] = HARD
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
