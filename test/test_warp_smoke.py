"""Warp works here: a float64 kernel defined in a file compiles and runs on the CPU."""

import numpy as np
import warp as wp


@wp.kernel
def _scaled_sum(
    # Inputs:
    scale: wp.float64,
    x_in: wp.array[wp.float64],
    y_in: wp.array[wp.float64],
    # Outputs:
    z_out: wp.array[wp.float64],
):
    i = wp.tid()
    z_out[i] = scale * x_in[i] + y_in[i]


def test_float64_kernel_on_cpu():
    # Steps of 1e-12 vanish in float32 (eps 1.2e-7): a silent downcast fails the rtol check.
    x = 1.0 + 1.0e-12 * np.arange(8, dtype=np.float64)
    y = np.linspace(-1.0, 1.0, 8)
    z = wp.empty(8, dtype=wp.float64, device='cpu')
    wp.launch(
        _scaled_sum, dim=8,
        inputs=[wp.float64(3.0), wp.array(x, dtype=wp.float64, device='cpu'),
                wp.array(y, dtype=wp.float64, device='cpu')],
        outputs=[z], device='cpu')
    result = z.numpy()
    assert result.dtype == np.float64
    np.testing.assert_allclose(result, 3.0 * x + y, rtol=1e-15, atol=0.0)
