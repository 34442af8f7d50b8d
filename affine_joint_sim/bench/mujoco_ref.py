"""A reference measured in the same run: MuJoCo on a hinge chain like ``chain_scene``.

MuJoCo is not a dependency of this package; where ``mujoco`` cannot be imported, the bench
prints the reference figures of issue 7 alone. Not a section itself.
"""

from typing import NamedTuple

__all__ = ['MujocoChain', 'mujoco_us']


class MujocoChain(NamedTuple):
    """A chain of ``links`` box links (square ``section`` [m], ``link_length`` [m],
    ``link_mass`` [kg]) hanging from a world hinge about x, tilted by ``angle`` [rad], with a
    constant ``torque`` [N·m] on the first hinge; time step ``dt`` [s]."""

    links: int
    link_length: float
    section: float
    link_mass: float
    angle: float = 0.0
    torque: float = 0.0
    dt: float = 0.01

    def mjcf(self) -> str:
        """The chain as an MJCF document (MuJoCo's default solver options; angles in radians,
        where MJCF's default unit is degrees)."""
        half = (self.section / 2, self.section / 2, self.link_length / 2)
        body = ''
        for k in reversed(range(self.links)):
            frame = f'euler="{self.angle} 0 0"' if k == 0 else f'pos="0 0 {-self.link_length}"'
            body = (f'<body {frame}><joint type="hinge" axis="1 0 0"/>'
                    f'<geom type="box" size="{half[0]} {half[1]} {half[2]}" '
                    f'pos="0 0 {-half[2]}" mass="{self.link_mass}"/>{body}</body>')
        return (f'<mujoco><compiler angle="radian"/><option timestep="{self.dt}"/>'
                f'<worldbody>{body}</worldbody></mujoco>')


def mujoco_us(chain: MujocoChain, steps: int, repeats: int) -> float | None:
    """µs per ``mujoco.mj_step`` call on ``chain`` (median of ``repeats`` runs of ``steps``
    steps from the initial state), or None where MuJoCo is not installed."""
    try:
        import mujoco
    except ImportError:
        return None
    from affine_joint_sim.bench.timing import median_us

    model = mujoco.MjModel.from_xml_string(chain.mjcf())
    data = mujoco.MjData(model)

    def start():
        mujoco.mj_resetData(model, data)
        data.qfrc_applied[0] = chain.torque

    return median_us(lambda: mujoco.mj_step(model, data), steps, repeats, setup=start)
