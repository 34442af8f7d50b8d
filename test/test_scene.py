"""Scene loading and validation: every bad input names the file, key path and valid values."""

import math
from pathlib import Path

import pytest

from affine_joint_sim import Scene, SceneError

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'

BASE = '''
name: test
bodies:
  - {name: base, shape: {box: [0.2, 0.2, 0.2]}, density: 1000.0, fixed: true}
  - {name: link, shape: {box: [0.1, 0.1, 1.0]}, mass: 1.0, position: [0, 0, -0.5]}
joints:
  - {name: hinge, parent: base, child: link, x0: [-0.05, 0, 0], x1: [0.05, 0, 0]}
'''


def load(text, source='scene.yaml'):
    return Scene.from_yaml_text(text, source=source)


def error_of(text):
    with pytest.raises(SceneError) as info:
        load(text)
    return str(info.value)


@pytest.mark.parametrize('path', sorted(SCENES.glob('*.yaml')), ids=lambda p: p.stem)
def test_packaged_scenes_load_and_round_trip(path):
    scene = Scene.from_yaml(path)
    assert Scene.from_yaml_text(scene.to_yaml()).model_dump() == scene.model_dump()


def test_defaults_and_exponent_without_sign():
    scene = load(BASE.replace('mass: 1.0,', 'mass: 1.0, kappa: 1.0e8,'))
    assert scene.bodies[1].kappa == 1.0e8 and isinstance(scene.bodies[1].kappa, float)
    assert scene.dt == 0.01 and scene.gravity == (0.0, 0.0, -9.81)
    joint = scene.joints[0]
    assert (joint.strength_ratio, joint.torque_model, joint.angle_mode, joint.enabled) == (
        1000.0, 'lever_arm', 'wrapped', True)
    assert joint.effort_limit == math.inf
    assert scene.solver.integrator == 'bdf2' and scene.solver.newton_tol == 1e-4
    assert (joint.type, joint.limit, joint.drive, joint.damping) == ('revolute', None, None, 0.0)


def test_newton_iterations_default_to_more_with_contact_unless_given():
    plain = load(BASE)
    assert plain.solver.newton_max_iter is None and plain.newton_max_iter == 32
    grounded = load(BASE + 'ground: {height: -5.0}\n')
    assert grounded.newton_max_iter == 256
    given = load(BASE + 'ground: {height: -5.0}\nsolver: {newton_max_iter: 40}\n')
    assert given.newton_max_iter == 40
    assert Scene.from_yaml_text(given.to_yaml()).newton_max_iter == 40     # round trip


@pytest.mark.parametrize('edit, path, hint', [
    (('parent: base', 'parent: nowhere'), 'joints[0].parent', 'valid: base, link'),
    (('child: link', 'child: base'), 'joints[0].child', 'must differ'),
    (('x1: [0.05, 0, 0]', 'x1: [-0.05, 0, 0]'), 'joints[0].x1', 'must differ from x0'),
    (('mass: 1.0', 'mass: -1.0'), 'bodies[1].mass', 'greater than 0'),
    (('mass: 1.0', 'mass: .nan'), 'bodies[1].mass', 'finite'),
    (('position: [0, 0, -0.5]', 'position: [0, .inf, -0.5]'), 'bodies[1].position[1]', 'finite'),
    (('density: 1000.0', 'density: 0'), 'bodies[0].density', 'greater than 0'),
    (('mass: 1.0,', 'mass: 1.0, density: 5.0,'), 'bodies[1]', 'exactly one of density'),
    (('mass: 1.0,', ''), 'bodies[1]', 'exactly one of density'),
    (('{box: [0.1, 0.1, 1.0]}', '{cone: [1, 2]}'), 'bodies[1].shape.cone',
     'valid keys here: box, cylinder, sphere'),
    (('fixed: true', 'fixd: true'), 'bodies[0].fixd', 'valid keys here: name, shape'),
    (('name: link', 'name: "my link"'), 'bodies[1].name', 'without whitespace'),
    (('name: link', 'name: base'), 'bodies[1].name', "duplicate name 'base'"),
    (('name: test', 'name: test\ndt: 0'), 'dt', 'greater than or equal to 0.000001'),
    (('name: test', 'name: test\nsolver: {integrator: rk4}'), 'solver.integrator', "'bdf2'"),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], torque_model: magic}'), 'joints[0].torque_model',
     "'generalized'"),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], type: ball}'), 'joints[0].type', "'prismatic'"),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], limit: {lower: 1, upper: -1}}'), 'joints[0].limit',
     'must be <= upper'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], limit: {lower: 0, upper: 1, strength: 0}}'),
     'joints[0].limit.strength', 'greater than 0'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], limit: {lower: .nan, upper: 1}}'),
     'joints[0].limit.lower', 'finite'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], damping: -1}'), 'joints[0].damping',
     'greater than or equal to 0'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], drive: {strength_ratio: -1}}'),
     'joints[0].drive.strength_ratio', 'greater than 0'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], drive: {target: 1, gain: 2}}'),
     'joints[0].drive.gain', 'valid keys here: target, strength_ratio, enabled'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], type: fixed}'), 'joints[0]',
     'it takes no x0, x1'),
    (('x0: [-0.05, 0, 0], x1: [0.05, 0, 0]}', 'type: fixed, torque: 1.0}'), 'joints[0]',
     'it takes no torque'),
    (('x0: [-0.05, 0, 0], x1: [0.05, 0, 0]}', 'type: fixed, drive: {}}'), 'joints[0]',
     'it takes no drive'),
    (('x0: [-0.05, 0, 0], ', 'type: prismatic, '), 'joints[0]', 'needs x0'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], type: prismatic, angle_mode: continuous}'),
     'joints[0]', 'angle_mode applies to revolute joints only'),
    (('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], limit: {lower: 0.5, upper: 1}}'), 'joints[0]',
     'initial_position 0 is outside the limit [0.5, 1]'),
])
def test_invalid_scenes_name_file_key_path_and_valid_values(edit, path, hint):
    message = error_of(BASE.replace(*edit))
    assert message.startswith('scene.yaml: invalid scene')
    assert f'  {path}: ' in message and hint in message, message


def test_joint_types_round_trip_through_yaml():
    text = BASE.replace('x1: [0.05, 0, 0]}', 'x1: [0.05, 0, 0], limit: {lower: -1, upper: 2}, '
                        'damping: 0.5, drive: {target: 0.3}}')
    text += '  - {name: weld, type: fixed, parent: link, child: tip}\n'
    text = text.replace('joints:', '  - {name: tip, shape: {sphere: {radius: 0.1}}, mass: 1.0, '
                        'position: [0, 0, -1.1]}\njoints:')
    scene = load(text)
    assert scene.joints[0].limit.strength == 1.0e3 and scene.joints[0].drive.enabled
    assert scene.joints[1].x0 is None
    assert Scene.from_yaml_text(scene.to_yaml()) == scene


def test_closed_loop_is_rejected_with_its_joints():
    text = BASE + ('  - {name: back, parent: link, child: base, x0: [0, 0, -1], '
                   'x1: [0.1, 0, -1]}\n')
    message = error_of(text)
    assert 'joints[1]' in message and 'closed loop (hinge, back)' in message


@pytest.mark.parametrize('edit, path', [
    (('name: test', 'name: test\ndt: true'), 'dt'),
    (('mass: 1.0', 'mass: true'), 'bodies[1].mass'),
    (('position: [0, 0, -0.5]', 'position: [0, false, -0.5]'), 'bodies[1].position[1]'),
])
def test_booleans_are_not_numbers(edit, path):
    message = error_of(BASE.replace(*edit))
    assert f'  {path}: must be a number, not a boolean' in message, message


def test_dt_below_one_microsecond_is_refused():
    message = error_of(BASE.replace('name: test', 'name: test\ndt: 1.0e-7'))
    assert '  dt: Input should be greater than or equal to 0.000001' in message, message


def test_binary_deep_and_utf16_files_name_the_file(tmp_path):
    utf16 = tmp_path / 'utf16.yaml'
    utf16.write_bytes(BASE.encode('utf-16'))
    binary = tmp_path / 'binary.yaml'
    binary.write_bytes(bytes(range(256)))
    deep = tmp_path / 'deep.yaml'
    deep.write_text('a:\n' + ''.join('  ' * i + f'b{i}:\n' for i in range(1, 3000)))
    for path, why in ((utf16, 'not a UTF-8 text file'), (binary, 'not a UTF-8 text file'),
                      (deep, 'nested too deeply')):
        with pytest.raises(SceneError, match=why) as info:
            Scene.from_yaml(path)
        assert str(info.value).startswith(str(path))


def test_unreadable_and_non_mapping_sources():
    with pytest.raises(SceneError, match='missing.yaml: cannot read'):
        Scene.from_yaml('missing.yaml')
    with pytest.raises(SceneError, match='not valid YAML'):
        load('bodies: [')
    with pytest.raises(SceneError, match='must be a mapping'):
        load('- 1\n- 2')


def test_names_lookup_lists_valid_names():
    scene = load(BASE)
    assert scene.joint_index('hinge') == 0
    with pytest.raises(KeyError, match='valid: base, link'):
        scene.body_index('arm')
