"""The one table of fields (physics.host.fields): structs, host model and allocation follow it."""

import numpy as np
import pytest
import warp as wp

from affine_joint_sim.physics.host.fields import FIELDS, GROUPS, allocate, env_bytes, fields_of
from affine_joint_sim.physics.kernels import step_kernels
from affine_joint_sim.physics.host.model import HostModel, build_model
from test_joints import every_joint_type

SIZES = {'env': 3, 'chunk': 2, 'body': 5, 'free': 4, 'joint': 3, 'stat_int': 8, 'stat_float': 3,
         'problem': 6, 'point': 6, 'plane': 2, 'pair': 12, 'edge': 4, 'face': 2,
         'static_edge': 3, 'static_vertex': 2, 'surface': 1, 'near': 16, 'static_pair': 10,
         'touch': 2, 'body_end': 6, 'mimic': 2, 'mimic_body': 10, 'mimic_square': 4}


@pytest.mark.parametrize('scalar', [wp.float64, wp.float32])
def test_structs_and_allocation_follow_the_table(scalar):
    t = step_kernels(scalar)
    assert len({f.name for f in FIELDS}) == len(FIELDS), 'a field name is used twice'
    per_env = 0
    for group in GROUPS:
        struct = getattr(t.structs, group.capitalize())
        assert list(struct.vars) == [f.name for f in fields_of(group)]
        if group == 'model':
            continue
        instance = allocate(t, struct, group, SIZES, 'cpu')
        for f in fields_of(group):
            assert f.unit and f.doc
            if f.shape == ():       # a plain member: the struct's address, 0 until held
                assert getattr(instance, f.name) == 0, f.name
                continue
            array = getattr(instance, f.name)
            assert array.shape == tuple(SIZES[d] for d in f.shape), f.name
            if 'env' in f.shape:
                per_env += array.capacity / SIZES['env']
    assert env_bytes(t, SIZES) == per_env


def test_the_host_model_carries_exactly_the_model_fields_with_their_shapes():
    scene = every_joint_type()
    host = build_model(scene)
    sizes = dict(SIZES, body=len(scene.bodies), joint=len(scene.joints),
                 free=int(np.sum(host.body_fixed == 0)), point=0, plane=0, shape=0,
                 pair=0, edge=0, face=0, static_edge=0, static_vertex=0, surface=0, static_pair=0,
                 touch=0, touch_end=1, touch_chunk=1, body_end=len(scene.bodies) + 1,  # no contact
                 mimic=0)
    for f in fields_of('model'):
        value = np.asarray(getattr(host, f.name))
        trailing = {'vec3': (3,), 'mat33': (3, 3), 'vec12': (12,),
                    'mat12': (12, 12)}.get(f.dtype, ())
        if f.shape == ():
            assert value.shape in ((), (3,)), f.name
        else:
            assert value.shape == tuple(sizes[d] for d in f.shape) + trailing, f.name
    values = {f.name: getattr(host, f.name) for f in fields_of('model')}
    del values['dt']
    with pytest.raises(ValueError, match=r"missing \['dt'\]"):
        HostModel(values)
