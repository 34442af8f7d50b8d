"""Kernel resources read from cubins that NVRTC compiles here for sm_90 (no GPU needed),
against what the kernels must need: a dynamically indexed float64 12×12 matrix lives in local
memory (exactly 12·12·8 = 1152 bytes of stack frame); an elementwise kernel needs none; a
function kept out of line (optimization level 2, as the GPU step kernel variant) brings its
frame and its code to the kernel's."""

import warp as wp

from affine_joint_sim.bench.cubin import _sections, kernel_resources

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


@wp.func(inline=False)
def scatter(a: wp.array(dtype=wp.float64), n: int, i: int):
    m = mat12()
    for k in range(n):
        m[k % 12, (k * 7) % 12] = a[k]
    return m[i % 12, n % 12]


@wp.kernel(module='unique', enable_backward=False, module_options={'optimization_level': 2})
def called(a: wp.array(dtype=wp.float64), n: int):
    i = wp.tid()
    a[i] = scatter(a, n, i) + scatter(a, n + 1, i)


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


def test_a_function_out_of_line_adds_its_frame_and_code_to_the_kernel(tmp_path):
    (path,) = wp.compile_aot_module(called.module, arch=90, module_dir=tmp_path)
    (found,) = kernel_resources(path)
    texts = {name: h[5] for name, h in _sections(path.read_bytes()) if name.startswith('.text.')}
    assert any('scatter' in name for name in texts), 'scatter was inlined'
    # the kernel's own frame and scatter's 12×12 matrix, its code and scatter's (and the
    # division helper's)
    assert found.frame_bytes > 12 * 12 * 8
    assert found.code_bytes == sum(texts.values())
