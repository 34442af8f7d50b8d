"""The GPU's step kernel variant (kernels.step_kernels(cuda=True): the functions a GPU compile
keeps out of line, its structs taken by reference through their addresses: physics.out_of_line)
run on the CPU, where CI can run it: the same steps, bit for bit, as the CPU's variant, with
every kind of contact."""

from pathlib import Path

import numpy as np
import pytest

from affine_joint_sim import Scene, Stepper

SCENES = Path(__file__).resolve().parents[1] / 'msg_configs' / 'scenes'


class _GpuVariant(Stepper):
    _gpu_variant_on_cpu = True


@pytest.mark.parametrize('name, contact', [('arm', 'none'), ('quadruped', 'half-spaces'),
                                           ('ramp', 'world'), ('stack', 'bodies')])
def test_the_gpu_variant_steps_the_same_bits_on_the_cpu(name, contact):
    scene = Scene.from_yaml(SCENES / f'{name}.yaml')
    cpu, gpu = Stepper(scene), _GpuVariant(scene)
    assert gpu._k.cuda and not cpu._k.cuda
    assert (gpu._k.contact, gpu._k.shapes, gpu._k.bodies) == (
        contact != 'none', contact in ('world', 'bodies'), contact == 'bodies')
    for step in range(80):
        cpu.step()
        gpu.step()
        if step % 20 == 19:
            np.testing.assert_array_equal(gpu.body_q, cpu.body_q)
    if contact != 'none':
        assert cpu.stats['contacts'] > 0
        assert ([c['normal_force'] for c in gpu.contacts]
                == [c['normal_force'] for c in cpu.contacts])
