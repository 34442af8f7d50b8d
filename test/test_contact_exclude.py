"""Pairs that never touch (README.md#contact): ``contact.exclude`` in a scene, a URDF scene's
link names and its SRDF's ``<disable_collisions>``, and their bad input."""

import pytest

from affine_joint_sim.scene import Scene, SceneError
from affine_joint_sim.stepper import Stepper

TABLE = {'name': 'table', 'fixed': True, 'mass': 10.0, 'shape': {'box': [1.0, 1.0, 0.1]},
         'position': [0.0, 0.0, 0.5], 'collision': 'shape'}      # its top at z = 0.55


def _box_over_table(height=0.7, **contact) -> Scene:
    return Scene.from_dict({
        'dt': 0.01, 'ground': {'height': 0.0}, 'contact': contact,
        'bodies': [TABLE, {'name': 'box', 'mass': 1.0, 'shape': {'box': [0.1, 0.1, 0.1]},
                           'position': [0.0, 0.0, height], 'collision': 'shape'}]})


def test_an_excluded_pair_passes_through_and_the_ground_still_holds():
    held, ghost = Stepper(_box_over_table()), Stepper(_box_over_table(exclude=[['box', 'table']]))
    for _ in range(150):
        held.step()
        ghost.step()
    assert held.body_q[1][2] == pytest.approx(0.6, abs=1e-3)      # on the table
    assert ghost.body_q[1][2] == pytest.approx(0.05, abs=1e-3)    # through it, on the ground
    assert {c['other'] for c in ghost.contacts} == {'ground'}


def test_an_excluded_pair_may_start_inside_each_other():
    with pytest.raises(SceneError, match=r"body 'box' starts 0\.02 m inside table"):
        Stepper(_box_over_table(height=0.52))
    Stepper(_box_over_table(height=0.52, exclude=[['table', 'box']])).step()


def test_an_unknown_body_in_exclude_is_named():
    with pytest.raises(SceneError, match=r"contact\.exclude\[0\]: unknown body 'lid'; valid: "
                                         r'table, box'):
        _box_over_table(exclude=[['box', 'lid']])
    with pytest.raises(SceneError, match=r'contact\.exclude\[0\]\[1\]: Field required'):
        _box_over_table(exclude=[['box']])


URDF = '''<?xml version="1.0"?>
<robot name="folded">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0"
      iyz="0"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="upper">
    <inertial><origin xyz="0.2 0 0"/><mass value="1"/><inertia ixx="0.001" iyy="0.001"
      izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.2 0 0"/><geometry><box size="0.3 0.05 0.05"/></geometry>
    </collision>
  </link>
  <link name="lower">
    <inertial><origin xyz="-0.25 0 0"/><mass value="1"/><inertia ixx="0.001" iyy="0.001"
      izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="-0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry>
    </collision>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0.1 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1"
    velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <origin xyz="0.35 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1"
    velocity="1"/></joint>
</robot>
'''


def _folded(tmp_path, srdf_pairs=(('base', 'lower'),)):
    """A fixed base, an upper arm hinged to it and a forearm folded back over the base whose
    end starts 2.5 cm inside the base's box: a pair of one articulation, not jointed, that
    only ``self_collision`` makes touch; the SRDF disables ``srdf_pairs``."""
    urdf = tmp_path / 'folded.urdf'
    urdf.write_text(URDF)
    srdf = tmp_path / 'folded.srdf'
    srdf.write_text('<?xml version="1.0"?>\n<robot name="folded">\n' + ''.join(
        f'  <disable_collisions link1="{a}" link2="{b}" reason="Never"/>\n'
        for a, b in srdf_pairs) + '</robot>\n')
    return urdf, srdf


def test_an_srdf_disables_a_pair_that_self_collision_would_refuse(tmp_path):
    urdf, srdf = _folded(tmp_path)
    touching = Scene.from_urdf(urdf, gravity=[0.0, 0.0, 0.0],
                               contact={'self_collision': True})
    with pytest.raises(SceneError, match=r"body 'lower' starts .* inside base"):
        Stepper(touching)
    scene = Scene.from_urdf(urdf, gravity=[0.0, 0.0, 0.0], contact={'self_collision': True},
                            srdf=str(srdf))
    assert [list(pair) for pair in scene.contact.exclude] == [['base', 'lower']]
    Stepper(scene).step()
    by_link = Scene.from_urdf(urdf, gravity=[0.0, 0.0, 0.0],
                              contact={'self_collision': True, 'exclude': [['lower', 'base']]})
    Stepper(by_link).step()


def test_srdf_problems_name_the_file_and_line(tmp_path):
    urdf, srdf = _folded(tmp_path, srdf_pairs=(('base', 'lower'), ('base', 'hand')))
    with pytest.raises(SceneError, match=r"folded\.srdf:4: <disable_collisions>: unknown link "
                                         r"'hand'"):
        Scene.from_urdf(urdf, contact={}, srdf=str(srdf))
    with pytest.raises(SceneError, match=r"srdf: 'missing\.srdf' not found"):
        Scene.from_urdf(urdf, contact={}, srdf='missing.srdf')
    srdf.write_text('<robot><disable_collisions link1="base"/></robot>')
    with pytest.raises(SceneError, match=r'folded\.srdf:1: <disable_collisions> needs link1 '
                                         'and link2'):
        Scene.from_urdf(urdf, contact={}, srdf=str(srdf))
    Scene.from_urdf(urdf, srdf=str(srdf))       # no contact: the SRDF is not read
