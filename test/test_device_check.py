"""The GPU check script, run on the CPU: it must not fail for the first time on a lent GPU,
and the kernels compiled ahead of time must be exactly the modules a run loads."""

import json
import subprocess
import sys

import numpy as np

from affine_joint_sim.bench import device_check


def table(text: str) -> list[list[str]]:
    lines = [line for line in text.splitlines() if line.startswith('| ') and '---' not in line]
    return [[cell.strip() for cell in line.strip('|').split(' | ')] for line in lines[1:]]


def test_the_check_prints_one_table_of_every_scene_precision_and_n(tmp_path, capsys):
    ref = tmp_path / 'reference.npz'
    assert device_check.main(['reference', str(ref)]) == 0
    with np.load(ref) as data:
        assert sorted(data.files) == ['arm', 'chain6', 'gripper', 'pendulum', 'quadruped',
                                      'ramp']
        assert data['ramp'].shape == (device_check.STEPS, 6)     # two bodies' positions
        assert data['chain6'].shape == (device_check.STEPS, 6)
    capsys.readouterr()
    assert device_check.main(['run', '--device', 'cpu', '--reference', str(ref), '--envs', '1,3',
                              '--steps', '40', '--seconds', '0.001']) == 0
    rows = table(capsys.readouterr().out)
    columns = [c.header for c in device_check.COLUMNS]
    assert [(r[0], r[1], r[2]) for r in rows] == [
        (scene, precision, n) for precision in ('float64', 'float32')
        for scene in ('pendulum', 'chain6', 'arm', 'quadruped', 'ramp', 'gripper')
        for n in ('1', '3')]
    for row in rows:
        error = float(row[columns.index('largest Δq vs CPU f64 [rad, m]')])
        assert float(row[columns.index('batched − single')]) == 0.0
        assert float(row[columns.index('env-steps/s')]) > 0
        agreeing = int(row[columns.index('steps within 1e-09')])
        if row[1] == 'float64':
            assert error == 0.0          # the same CPU kernel: equal to the last bit
            assert agreeing == 40
        else:
            # float32 differs from float64, but not by much: 1.7e-6 on the pendulum, 0.037 on
            # the whirling arm (1 N·m on every joint), whose stiff joints float32 resolves coarsely
            assert 0.0 < error < (0.1 if row[0] == 'arm' else 1e-3)


def test_a_run_loads_only_registered_modules():
    code = '''
import json, warp as wp
from warp._src.context import user_modules
from affine_joint_sim.bench import device_check
wp.init()
device_check.register()
ids = lambda keep: sorted(m.get_module_identifier() for m in list(user_modules.values())
                          if m.kernels and not m.name.startswith('warp') and keep(m))
registered = ids(lambda m: True)
device_check.main(['run', '--device', 'cpu', '--envs', '1', '--steps', '2', '--seconds', '0'])
print(json.dumps([registered, ids(lambda m: m.execs)]))
'''
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True).stdout
    registered, loaded = json.loads(out.strip().splitlines()[-1])
    # every step kernel variant is registered (precisions × kinds of contact), and the run's
    # scenes load every one of them, nothing not registered
    assert len(registered) == 8 and sorted(loaded) == registered


def test_gpu_prep_compiles_every_step_kernel_variant_and_no_other(capsys):
    from warp._src.context import user_modules

    device_check.register()
    steps = {name for name, module in user_modules.items()
             if module.kernels and name.startswith('build__locals__step')}
    assert device_check.main(['modules']) == 0
    names = capsys.readouterr().out.split()
    # the variants without static shapes take their structs from those with them: building
    # them registers no step kernel that make gpu-prep would compile beside the eight
    assert names == [t.step.module.name for _, _, t in device_check.step_variants()]
    assert len(set(names)) == 8 and steps == set(names)


def test_resources_reads_the_step_kernel_cubins_of_each_precision(tmp_path, capsys):
    import warp as wp

    from affine_joint_sim.physics.kernels import step_kernels
    from test_cubin import doubled

    (cubin,) = wp.compile_aot_module(doubled.module, arch=90, module_dir=tmp_path / 'build')
    module = step_kernels(wp.float64).step.module
    folder = tmp_path / 'cache' / wp.config.version / module.get_module_identifier()
    folder.mkdir(parents=True)
    (folder / cubin.name).write_bytes(cubin.read_bytes())    # stands in for the step kernel
    (row,) = device_check.resources(tmp_path / 'cache')
    assert row['precision'] == 'float64' and row['stack'] == 0
    assert row['warps'] == device_check.warps_per_sm(row['registers'])
    assert device_check.main(['resources', str(tmp_path / 'cache')]) == 0
    assert cubin.name in capsys.readouterr().out


def test_register_limited_occupancy_matches_the_sm_90_allocation_rules():
    # 65536 registers per SM, allocated per warp in units of 256, at most 64 warps
    assert [device_check.warps_per_sm(r) for r in (22, 32, 64, 128, 168, 255)] == [
        64, 64, 32, 16, 12, 8]


def test_angles_that_pass_pi_in_one_run_only_differ_by_their_distance():
    before = np.array([[3.14, 0.5], [3.14, 0.5]])
    after = np.array([[-3.14, 0.5], [3.14, 0.5]])       # 0.0032 rad further on, wrapped
    np.testing.assert_allclose(device_check._angle_errors(after, before),
                               [2 * np.pi - 6.28, 0.0], atol=1e-15)
    assert device_check._agreeing_steps(np.array([0.0, 1e-10, 2e-9, 0.0])) == 2
    assert device_check._agreeing_steps(np.array([0.0, 1e-10])) == 2
