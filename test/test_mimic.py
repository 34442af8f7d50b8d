"""Mimic joints (URDF ``<mimic>``, a scene joint's ``mimic``): the follower's coordinate is
multiplier · the leader's + offset, held by a stiff coupling inside the implicit step. Against
the closed forms of the rigid, constrained system: sliders pushed on their leader accelerate
as one body of mass m_l + Σ (multiplier² m_f), a revolute pair is a gear; a follower takes no
command; a bad mimic is an error naming its field."""

import numpy as np
import pytest

from affine_joint_sim.physics.evaluate import Stages
from affine_joint_sim.ros.commands import CommandBuffer
from affine_joint_sim.ros.joint_state import JointStateFiller
from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper

MASSES = (0.1, 0.3, 0.2)        # kg: leader, then followers
FORCE = 1.0                     # N on the leader
SECONDS = 0.5


def sliders(mimics, dt=1e-3, **first) -> dict:
    """A fixed hand with one prismatic finger per mass along x (the first the leader), each
    further finger given by ``mimics``: (leader name, multiplier, offset) or None."""
    bodies = [{'name': 'hand', 'fixed': True, 'shape': {'box': [0.2, 0.1, 0.05]}, 'mass': 1.0}]
    joints = []
    for k, mass in enumerate(MASSES[:len(mimics) + 1]):
        y = 0.05 * k
        bodies.append({'name': f'finger{k}', 'shape': {'box': [0.02, 0.02, 0.05]}, 'mass': mass,
                       'position': [0.0, y, -0.05]})
        joint = {'name': f'j{k}', 'type': 'prismatic', 'parent': 'hand', 'child': f'finger{k}',
                 'x0': [0.0, y, -0.05], 'x1': [0.1, y, -0.05]}
        if k and mimics[k - 1] is not None:
            lead, multiplier, offset = mimics[k - 1]
            joint['mimic'] = {'joint': lead, 'multiplier': multiplier, 'offset': offset}
        joints.append(joint)
    joints[0].update(first)
    return {'dt': dt, 'gravity': [0.0, 0.0, 0.0], 'bodies': bodies, 'joints': joints}


def run(scene: Scene, torques: dict) -> Stepper:
    sim = Stepper(scene)
    for name, value in torques.items():
        sim.set_torque(name, value)
    for _ in range(round(SECONDS / scene.dt)):
        sim.step()
        assert sim.stats['converged'] and sim.stats['newton_iterations'] <= 3
    return sim


@pytest.mark.parametrize('multiplier, offset', [(1.0, 0.0), (-0.5, 0.01)])
def test_sliders_pushed_on_their_leader_move_as_one_rigid_body(multiplier, offset):
    data = sliders([('j0', multiplier, offset)])
    data['joints'][1]['initial_position'] = offset       # where the coupling holds it
    sim = run(Scene.from_dict(data), {'j0': FORCE})
    x = sim.angles
    rigid = 0.5 * FORCE / (MASSES[0] + multiplier ** 2 * MASSES[1]) * SECONDS ** 2
    assert x[0] == pytest.approx(rigid, rel=1e-4)      # 6e-6 measured (the step's own error)
    assert abs(x[1] - (multiplier * x[0] + offset)) < 1e-8


def test_a_chain_of_mimics_follows_its_first_joint():
    """j2 mimics j1, which mimics j0: two couplings, the solve's 2×2 Woodbury system."""
    sim = run(Scene.from_dict(sliders([('j0', 2.0, 0.0), ('j1', -1.0, 0.0)])), {'j0': FORCE})
    x = sim.angles
    mass = MASSES[0] + 4.0 * MASSES[1] + 4.0 * MASSES[2]
    assert x[0] == pytest.approx(0.5 * FORCE / mass * SECONDS ** 2, rel=1e-4)
    assert abs(x[1] - 2.0 * x[0]) < 1e-8 and abs(x[2] + x[1]) < 1e-8


def test_a_revolute_mimic_is_a_gear():
    """Two rods turning about z on a fixed base, the second at −2 times the first: under τ
    on the first, θ = ½ τ / (I₁ + 4 I₂) t² (I about each rod's axis through its centre)."""
    rods = [(0.2, 0.5), (0.12, 0.8)]        # length along x [m], mass [kg]
    bodies = [{'name': 'base', 'fixed': True, 'shape': {'box': [0.1, 0.1, 0.1]}, 'mass': 1.0}]
    joints = []
    for k, (length, mass) in enumerate(rods):
        y = 0.3 * k
        bodies.append({'name': f'rod{k}', 'shape': {'box': [length, 0.02, 0.02]}, 'mass': mass,
                       'position': [0.0, y, 0.2]})
        joints.append({'name': f'hinge{k}', 'parent': 'base', 'child': f'rod{k}',
                       'x0': [0.0, y, 0.15], 'x1': [0.0, y, 0.25],
                       'torque_model': 'generalized'})
    joints[1]['mimic'] = {'joint': 'hinge0', 'multiplier': -2.0}
    scene = Scene.from_dict({'dt': 1e-3, 'gravity': [0.0, 0.0, 0.0], 'bodies': bodies,
                             'joints': joints})
    sim = run(scene, {'hinge0': 0.01})
    inertia = [m * (length ** 2 + 0.02 ** 2) / 12.0 for length, m in rods]
    theta = 0.5 * 0.01 / (inertia[0] + 4.0 * inertia[1]) * SECONDS ** 2
    assert sim.angles[0] == pytest.approx(theta, rel=1e-3)
    assert abs(sim.angles[1] + 2.0 * sim.angles[0]) < 1e-8


def test_a_mimic_joint_takes_no_command():
    from sensor_msgs.msg import JointState

    sim = Stepper(Scene.from_dict(sliders([('j0', 1.0, 0.0)])))
    assert sim.command_joint_names == ['j0']
    assert JointStateFiller(sim, JointState).names == ['j0', 'j1']  # published like any joint
    with pytest.raises(ValueError, match="joint 'j1' is a mimic of 'j0': it takes no torque"):
        sim.set_torque('j1', 1.0)
    commands = CommandBuffer.for_stepper(sim)
    assert commands.joint_commands(['j1', 'j0'], efforts=[1.0, 2.0]) == [
        "joint 'j1' mimics 'j0': it follows it and takes no command (dropped)"]


@pytest.mark.parametrize('mimic, field, words', [
    ({'joint': 'ghost'}, 'joints[1].mimic.joint', "'ghost' is not another revolute or prismatic"),
    ({'joint': 'j1'}, 'joints[1].mimic.joint', "'j1' is not another"),
    ({'joint': 'weld'}, 'joints[1].mimic.joint', "'weld' is not another"),
])
def test_a_mimic_of_no_movable_joint_is_an_error_naming_the_field(mimic, field, words):
    data = sliders([None])
    data['bodies'].append({'name': 'plate', 'shape': {'box': [0.05, 0.05, 0.01]}, 'mass': 0.1,
                           'position': [0.0, -0.1, -0.05]})
    data['joints'].append({'name': 'weld', 'type': 'fixed', 'parent': 'hand', 'child': 'plate'})
    data['joints'][1]['mimic'] = mimic
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data)
    message = str(info.value)
    assert f'{field}: {words}' in message


def test_mimics_that_loop_and_a_commanded_mimic_are_refused():
    with pytest.raises(SceneError, match=r"joints\[0\]\.mimic\.joint: the mimics from 'j0' "
                                         r"through 'j1' form a loop"):
        Scene.from_dict(sliders([('j0', 1.0, 0.0)], mimic={'joint': 'j1'}))
    data = sliders([('j0', 1.0, 0.0)])
    data['joints'][1]['torque'] = 1.0
    with pytest.raises(SceneError, match="a mimic joint follows joint 'j0': it takes no torque"):
        Scene.from_dict(data)


HAND = """<?xml version="1.0"?>
<robot name="hand">
  <link name="palm"><inertial><mass value="0.7"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="left"><inertial><mass value="0.02"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="right"><inertial><mass value="0.03"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="finger1" type="prismatic"><parent link="palm"/><child link="left"/>
    <origin xyz="0 0 0.06"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/></joint>
  <joint name="finger2" type="prismatic"><parent link="palm"/><child link="right"/>
    <origin xyz="0 0 0.06"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/>
    <mimic joint="finger1"{extra}/></joint>
</robot>
"""


def test_a_urdf_mimic_couples_the_fingers_from_where_their_leader_puts_them(tmp_path):
    """A parallel gripper as the Panda's: the second finger mimics the first; it starts where
    the first does (initial_positions names the first only) and closes with it."""
    path = tmp_path / 'hand.urdf'
    path.write_text(HAND.format(extra=''))
    scene = Scene.from_urdf(path, dt=1e-3, gravity=[0.0, 0.0, 0.0],
                            initial_positions={'finger1': 0.03})
    follower = scene.joints[scene.joint_index('finger2')]
    assert follower.mimic.joint == 'finger1' and follower.initial_position == 0.03
    sim = run(scene, {'finger1': -0.005})        # closing, to 0.0175 m
    x = sim.angles
    assert x[0] == pytest.approx(0.03 - 0.5 * 0.005 / 0.05 * SECONDS ** 2, rel=1e-4)
    assert abs(x[1] - x[0]) < 1e-8


def test_a_urdf_mimic_of_a_missing_joint_is_an_error(tmp_path):
    path = tmp_path / 'hand.urdf'
    path.write_text(HAND.format(extra='').replace('mimic joint="finger1"', 'mimic joint="ghost"'))
    with pytest.raises(SceneError, match=r'hand\.urdf: joint \'finger2\': <mimic '
                                         r'joint="ghost"> names no joint of the robot'):
        Scene.from_urdf(path)


def test_mimic_fingers_squeezing_a_box_hold_their_rule_through_the_coupled_solve():
    """A free gripper in zero gravity (its fingers and the box level with its centre: it does
    not turn) closing its two fingers on a free box (contact between
    bodies: the hand, its fingers and the box close a loop, so the coupled solve's conjugate
    gradients run, with the coupling in their matrix–vector product): the follower keeps to
    its leader, the box stays centred between them and nothing penetrates."""
    half = 0.01     # [m] the fingers' and the box's half width along x
    bodies = [{'name': 'hand', 'shape': {'box': [0.2, 0.05, 0.02]}, 'mass': 1.0},
              {'name': 'box', 'shape': {'box': [2 * half] * 3}, 'mass': 0.05,
               'collision': 'shape'}]
    joints = []
    for k, side in enumerate((1.0, -1.0)):
        x = side * 0.05
        bodies.append({'name': f'finger{k}', 'shape': {'box': [2 * half, 0.03, 0.06]},
                       'mass': (0.1, 0.3)[k], 'position': [x, 0.0, 0.0], 'collision': 'shape'})
        joints.append({'name': f'j{k}', 'type': 'prismatic', 'parent': 'hand',
                       'child': f'finger{k}', 'x0': [x, 0.0, 0.0], 'x1': [x - side * 0.1, 0.0,
                                                                          0.0]})
    joints[1]['mimic'] = {'joint': 'j0'}
    scene = Scene.from_dict({'dt': 1e-3, 'gravity': [0.0, 0.0, 0.0], 'bodies': bodies,
                             'joints': joints, 'contact': {'d_hat': 1e-3}})
    sim = Stepper(scene)
    sim.set_torque('j0', 1.0)       # closing: each finger has 0.03 m to go
    coupled = 0
    for _ in range(300):
        sim.step()
        stats = sim.stats
        assert stats['converged'] and stats['min_distance'] > 0.0
        coupled += stats['inner_iterations']
        x = sim.angles
        assert abs(x[1] - x[0]) < 1e-7     # Newton's tolerance, newton_tol·dt
    box, left, right = (sim.body_q[scene.body_index(name)][:3]
                        for name in ('box', 'finger0', 'finger1'))
    assert coupled > 0 and sim.contacts            # squeezed, through the coupled solve
    assert np.linalg.norm(box - 0.5 * (left + right)) < 1e-6 and 0.029 < x[0] < 0.03


def test_the_newton_system_is_the_energys_with_the_couplings_hessian_solved_exactly():
    """At a state off the rule (a chain of two couplings): ∇E against central differences of
    E, and the Newton direction against a dense solve with every coupling's K g gᵀ added to
    the assembled blocks (the Woodbury formula on the tree's factors, exact)."""
    scene = Scene.from_dict(sliders([('j0', 2.0, 0.0), ('j1', -1.0, 0.0)]))
    stages = Stages(scene)
    rng = np.random.default_rng(7)
    q_tilde = stages.host.body_q0.copy()
    q = q_tilde.copy()
    for b in stages.free:
        q[b] += rng.normal(0.0, 1e-3, 12)
    gradient, hessian, dq = stages.newton_system(q, q_tilde)
    step = 1e-6
    for i in rng.choice(len(gradient), 8, replace=False):
        b, j = stages.free[i // 12], i % 12
        plus, minus = q.copy(), q.copy()
        plus[b, j] += step
        minus[b, j] -= step
        slope = (stages.energy(plus, q_tilde) - stages.energy(minus, q_tilde)) / (2 * step)
        assert slope == pytest.approx(gradient[i], rel=1e-5, abs=1e-9)
    _, parent_gradients, child_gradients = stages.joint_coordinates(q)
    where = {b: 12 * i for i, b in enumerate(stages.free)}
    host, full = stages.host, hessian.copy()
    for i, follower in enumerate(host.mimic_follower):
        g = np.zeros(len(gradient))
        for joint, factor in ((follower, 1.0), (host.mimic_leader[i], -host.mimic_multiplier[i])):
            for body, part in ((host.joint_parent[joint], parent_gradients[joint]),
                               (host.joint_child[joint], child_gradients[joint])):
                if body in where:
                    g[where[body]:where[body] + 12] += factor * part
        full += host.mimic_stiffness[i] * np.outer(g, g)
    assert np.allclose(dq, np.linalg.solve(full, -gradient), rtol=1e-8, atol=1e-14)


def test_passive_mimic_sliders_never_gain_energy():
    """The leader thrown at 0.5 m/s, its mirrored follower at rest (off the rule: the
    coupling is loaded at once): the mechanical energy, its spring included, never grows."""
    data = sliders([('j0', -1.0, 0.0)], dt=1e-3)
    data['bodies'][1]['linear_velocity'] = [0.5, 0.0, 0.0]
    sim = Stepper(Scene.from_dict(data))
    energies = []
    for _ in range(300):
        sim.step()
        energies.append(float(sim.energy))
    assert max(energies) <= energies[0] * (1.0 + 1e-9)
    assert abs(sim.angles[1] + sim.angles[0]) < 1e-7


def test_the_node_publishes_a_mimic_joint_and_drops_a_command_for_it(sim, ros_node, wait_for,
                                                                       tmp_path):
    """Over DDS: joint_states lists the follower beside its leader, and a joint_commands
    message naming both applies the leader's effort and drops the follower's, saying why."""
    from helpers.ros_client import Inbox, publisher
    from sensor_msgs.msg import JointState

    path = tmp_path / 'hand.urdf'
    path.write_text(HAND.format(extra=''))
    child = sim('--scene', path, '--mode', 'realtime')
    states = Inbox(ros_node, 'joint_states')
    assert wait_for(lambda: states.last is not None)
    assert list(states.last.name) == ['finger1', 'finger2']
    pub = publisher(ros_node, wait_for, 'joint_commands')
    pub.publish(JointState(name=['finger2', 'finger1'], effort=[1.0, 0.004]))
    assert wait_for(lambda: states.last.effort[0] == 0.004 and states.last.position[0] > 1e-4)
    last = states.last
    assert last.effort[1] == 0.0 and abs(last.position[1] - last.position[0]) < 1e-8
    output = child.stop()
    assert "joint 'finger2' mimics 'finger1': it follows it and takes no command" in output, \
        output
