"""Generated scenes: a chain of ``links`` equal links hanging from a fixed base.

Chains of any length serve the scaling benchmark (cost per step against the number of joints)
and the extremes suite (a long chain falling). Every hinge turns about world x; link k spans
z = -k·link_length … -(k+1)·link_length at t = 0, so the chain hangs straight down.
"""

from affine_joint_sim import portable_math as pm
from affine_joint_sim.scene import Scene

__all__ = ['chain_scene']


def chain_scene(links: int, *, link_length: float = 0.5, link_mass: float = 1.0,
                section: float = 0.05, dt: float = 0.01, integrator: str = 'bdf1',
                precision: str = 'float64', torque_model: str = 'generalized',
                angle: float = 0.0) -> Scene:
    """A scene ``chain<links>`` of ``links`` box links of square section and as many joints.

    Args:
        links: number of moving links (= joints), at least 1.
        link_length: length of each link [m].
        link_mass: mass of each link [kg].
        section: side of each link's square section [m]; the joint axis spans it.
        dt: time step [s].
        integrator: ``bdf1`` | ``bdf2``.
        precision: ``float64`` | ``float32``.
        torque_model: ``generalized`` (default: a pure couple, right for chains) | ``lever_arm``.
        angle: initial tilt of the whole chain about world x [rad] (0 hangs straight down).
    """
    if int(links) != links or links < 1:
        raise ValueError(f'links must be a positive integer, got {links!r}')
    down = (0.0, pm.sin(angle), -pm.cos(angle))   # unit vector along the chain (body -z)

    def point(s):
        return [0.0, s * down[1], s * down[2]]

    bodies = [{'name': 'base', 'shape': {'box': [0.2, 0.2, 0.2]}, 'density': 1000.0,
               'fixed': True}]
    joints = []
    parent = 'base'
    for k in range(links):
        name = f'link{k}'
        bodies.append({'name': name, 'shape': {'box': [section, section, link_length]},
                       'mass': link_mass, 'position': point((k + 0.5) * link_length),
                       'orientation': {'rpy': [angle, 0.0, 0.0]}})
        hinge = point(k * link_length)
        joints.append({'name': f'joint{k}', 'parent': parent, 'child': name,
                       'x0': [-section / 2, hinge[1], hinge[2]],
                       'x1': [section / 2, hinge[1], hinge[2]],
                       'torque_model': torque_model})
        parent = name
    return Scene.from_dict({'name': f'chain{links}', 'dt': dt,
                            'solver': {'integrator': integrator, 'precision': precision},
                            'bodies': bodies, 'joints': joints}, source=f'chain_scene({links})')
