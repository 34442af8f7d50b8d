"""A joint type is one unit (physics.host.joint_kinds, physics.joints): its descriptor, its module
with every function of the protocol, and dispatchers that reach every type."""

import ast
import inspect

import pytest
import warp as wp

from affine_joint_sim import Scene
from affine_joint_sim.physics import joints
from affine_joint_sim.physics.host.joint_kinds import JOINT_KIND_NAMES, JOINT_KINDS, joint_kind
from affine_joint_sim.physics.kernels import step_kernels
from test_joints import every_joint_type


def test_codes_are_the_positions_of_the_kinds_and_names_are_unique():
    assert [kind.code for kind in JOINT_KINDS] == list(range(len(JOINT_KINDS)))
    assert len(set(JOINT_KIND_NAMES)) == len(JOINT_KINDS)
    assert len({kind.uid for kind in JOINT_KINDS}) == len(JOINT_KINDS)


@pytest.mark.parametrize('kind', JOINT_KINDS, ids=JOINT_KIND_NAMES)
def test_every_type_module_provides_the_whole_protocol(kind):
    module = joints.type_module(kind)
    built = module.build(step_kernels(wp.float64))
    missing = [name for name in joints.PROTOCOL if not hasattr(built, name)]
    missing += [name for name in joints.HOST_PROTOCOL if not callable(getattr(module, name, None))]
    assert not missing, f'{kind.name} lacks {missing}'


def test_every_dispatcher_loops_over_every_type():
    """Each dispatcher that reads model.joint_type picks the type's function by a compile-time
    loop over JOINT_KINDS (so none can fall through to another type's function)."""
    tree = ast.parse(inspect.getsource(joints.build))
    dispatchers = [f for f in ast.walk(tree) if isinstance(f, ast.FunctionDef)
                   and 'joint_type' in ast.unparse(f)]
    assert len(dispatchers) >= 9
    for function in dispatchers:
        source = ast.unparse(function)
        assert 'range(wp.static(count))' in source, function.name
        assert 'wp.static(codes[i])' in source, function.name


def test_the_test_scene_has_every_type_so_the_dispatch_tests_cover_them():
    """test_physics_assemble checks energy, gradients and Hessians of every_joint_type() against
    finite differences, test_physics_joints its coordinates: through every dispatcher."""
    assert sorted({j.type for j in every_joint_type().joints}) == sorted(JOINT_KIND_NAMES)


def test_an_unknown_joint_type_is_refused_naming_the_valid_ones():
    with pytest.raises(ValueError, match='revolute, prismatic, fixed'):
        joint_kind('ball')
    data = every_joint_type().model_dump(exclude_none=True)
    data['joints'][0]['type'] = 'ball'
    with pytest.raises(ValueError, match="joints\\[0\\].type"):
        Scene.from_dict(data)
