"""Kernel resources read from cubins that NVRTC compiles here for sm_90 (no GPU needed),
against what the kernels must need: a dynamically indexed float64 12×12 matrix lives in local
memory (exactly 12·12·8 = 1152 bytes of stack frame); an elementwise kernel needs none."""

import warp as wp

from affine_joint_sim.bench.cubin import kernel_resources

mat12 = wp.types.matrix(shape=(12, 12), dtype=wp.float64)


@wp.kernel(module='unique', enable_backward=False)
def doubled(a: wp.array(dtype=wp.float64)):
    i = wp.tid()
    a[i] = a[i] * wp.float64(2.0)


@wp.kernel(module='unique', enable_backward=False)
def scattered(a: wp.array(dtype=wp.float64), n: int):
    i = wp.tid()
    m = mat12()
    for k in range(n):
        m[k % 12, (k * 7) % 12] = a[k]
    a[i] = m[i % 12, n % 12]


def resources(kernel, tmp_path):
    (path,) = wp.compile_aot_module(kernel.module, arch=90, module_dir=tmp_path)
    (found,) = kernel_resources(path)
    return found


def test_a_local_matrix_indexed_at_run_time_takes_its_size_of_stack(tmp_path):
    plain = resources(doubled, tmp_path)
    local = resources(scattered, tmp_path)
    assert plain.name.startswith('doubled') and local.name.startswith('scattered')
    assert plain.frame_bytes == 0 and local.frame_bytes == 12 * 12 * 8
    assert 0 < plain.registers <= 255 and 0 < local.registers <= 255
    assert 0 < plain.code_bytes < local.code_bytes
