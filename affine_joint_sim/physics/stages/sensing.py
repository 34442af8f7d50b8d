"""The sensor kernel: every reading of a scene's sensors (``Stepper.sensors``; README.md#sensors)
at the current state, one thread per environment, one row of readings each.

Sensor s sits on body ``body[s]`` at ``rotation[s]``, ``offset[s]`` in the body's rest frame;
its values fill its row's columns from ``column[s]`` in ``affine_joint_sim.sensors.FIELDS``
order. Its frame's world pose is rigid, as ``Stepper.link_transforms`` gives it (``frames``'s
``rigid``: the body's position p and the rotation R nearest to its A), axes R·rotation,
origin p + R·offset. Every vector is read out in the sensor's frame.

- ``imu``: the frame's orientation as a quaternion (x, y, z, w), w ≥ 0; ω [rad/s] from
  [ω]× = the skew part of Ȧ A⁻¹; the specific force a − g [m/s²], a the backward difference
  (v_n − v_{n−1}) / dt of the frame origin's velocity ṗ + Ȧ·offset over the last step (state.v
  and state.v_prev: equal at the start, after a reset or a placement, so the reading is −g
  there).
- ``contact``: the force [N] and moment [N·m about the frame's origin] of the active contacts
  of the sensor's body (``report``'s ``pair_contact``: normal force·n + friction force at the
  contact point), summed over the near list in its order; a pair whose other side is the
  sensor's body pushes it with the opposite force. Compiled only into the kernel of a scene
  with contact sensors (``contact``).

Built per precision, pair kind and whether contact sensors are read, in a Warp module of its
own (only scenes with sensors compile it).
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.sensors import IMU

__all__ = ['build']


def build(t, poses, pair_contact=None) -> SimpleNamespace:
    """The sensor kernel for the types namespace ``t``: ``poses`` the frame functions
    (``frames.build``), ``pair_contact`` the contact report's function of a pair, or None
    (no contact sensors: no contact code)."""
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    vec3, mat33, half = t.vec3, t.mat33, t.half
    affine, rigid, quaternion = t.affine, poses.rigid, poses.quaternion
    listed, listed_pair, pair_bodies = t.listed, t.listed_pair, t.pair_bodies
    contact = pair_contact is not None

    @wp.func
    def put(out: wp.array2d(dtype=wp.float64), env: int, column: int, x: vec3):
        for i in range(3):
            out[env, column + i] = wp.float64(x[i])

    @wp.func
    def imu(model: Model, state: State, env: int, body: int, offset: vec3, axes: mat33,
            out: wp.array2d(dtype=wp.float64), column: int):
        """An IMU's values from ``column``: ``axes`` its frame's in the world, ``offset`` its
        origin in the body [m]."""
        q, v, v_prev = state.q[env, body], state.v[env, body], state.v_prev[env, body]
        a_dot = affine(v)
        w = a_dot * wp.inverse(affine(q))
        omega = vec3(half * (w[2, 1] - w[1, 2]), half * (w[0, 2] - w[2, 0]),
                     half * (w[1, 0] - w[0, 1]))
        now = vec3(v[0], v[1], v[2]) + a_dot * offset
        before = vec3(v_prev[0], v_prev[1], v_prev[2]) + affine(v_prev) * offset
        specific = (now - before) / model.dt - model.gravity
        x, y, z, qw = quaternion(axes)
        out[env, column] = wp.float64(x)
        out[env, column + 1] = wp.float64(y)
        out[env, column + 2] = wp.float64(z)
        out[env, column + 3] = wp.float64(qw)
        put(out, env, column + 4, wp.transpose(axes) * omega)
        put(out, env, column + 7, wp.transpose(axes) * specific)

    @wp.func
    def wrench(model: Model, state: State, scratch: Scratch, env: int, body: int,
               origin: vec3):
        """(force [N], moment [N·m about ``origin``], world) of the active contacts of
        ``body``."""
        force = vec3()
        moment = vec3()
        if wp.static(contact):
            for k in range(listed(model, scratch, env)):
                p = listed_pair(model, scratch, env, k)
                first, second = pair_bodies(model, p)
                if first == body or second == body:
                    p, active, first, second, d, n, point, push, friction = pair_contact(
                        model, state, scratch, env, k)
                    if active:
                        f = push * n + friction
                        if first != body:
                            f = -f
                        force += f
                        moment += wp.cross(point - origin, f)
        return force, moment

    @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
    def sensor_readings(model: Model, state: State, scratch: Scratch,
                        kind: wp.array(dtype=int), body: wp.array(dtype=int),
                        rotation: wp.array(dtype=mat33), offset: wp.array(dtype=vec3),
                        column: wp.array(dtype=int), out: wp.array2d(dtype=wp.float64)):
        env = wp.tid()
        for s in range(kind.shape[0]):
            b = body[s]
            c, r = rigid(state.q[env, b])
            axes = r * rotation[s]
            if kind[s] == IMU:
                imu(model, state, env, b, offset[s], axes, out, column[s])
            else:
                force, moment = wrench(model, state, scratch, env, b, c + r * offset[s])
                put(out, env, column[s], wp.transpose(axes) * force)
                put(out, env, column[s] + 3, wp.transpose(axes) * moment)

    return SimpleNamespace(sensor_readings=sensor_readings)
