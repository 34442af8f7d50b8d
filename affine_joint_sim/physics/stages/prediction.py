"""Prediction q̃ of every free body (docs/physics.md#prediction).

BDF1: q̃ = q_n + dt v_n + dt² a_g. BDF2: q̃ = 4/3 q_n − 1/3 q_{n−1} + 2dt/9 (4 v_n − v_{n−1})
+ 4/9 dt² a_g; it starts with one BDF1 step (the first, and the first after a reset), and steps
with a contact they cannot resolve are BDF1 (docs/physics.md#impacts). The joint commands are
added afterwards by the command stage with the same force scale. Newton starts from the
prediction without them, warm-started, plus the last step's correction
(docs/physics.md#newton-start).
"""

import math
from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.host.codes import BDF2

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the prediction for the types namespace ``t``."""
    scalar, one, four = t.scalar, t.one, t.four
    vec12 = t.vec12
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    translation_part = t.translation_part
    bdf2_q_n, bdf2_q_prev, bdf2_v = scalar(4.0 / 3.0), scalar(1.0 / 3.0), scalar(2.0 / 9.0)
    bdf2_kinetic, bdf2_force = scalar(9.0 / 4.0), scalar(4.0 / 9.0)
    assert math.isclose(float(bdf2_q_n) - float(bdf2_q_prev), 1.0, rel_tol=1e-6)

    @wp.func
    def integrator_scales(model: Model, state: State, env: int, unresolved: int):
        """(bdf2 on this step, kinetic scale, force scale [s²]) of environment ``env``: BDF1
        where ``unresolved`` (a contact the step cannot resolve: docs/physics.md#impacts)."""
        dt2 = model.dt * model.dt
        bdf2 = int(0)
        if model.integrator == BDF2 and state.history_ready[env] != 0 and unresolved == 0:
            bdf2 = 1
        kinetic_scale = one
        force_scale = dt2
        if bdf2 != 0:
            kinetic_scale = bdf2_kinetic
            force_scale = bdf2_force * dt2
        return bdf2, kinetic_scale, force_scale

    @wp.func
    def predict(model: Model, state: State, scratch: Scratch, env: int, bdf2: int,
                force_scale: scalar):
        """q_n and q̃ (with gravity) of every free body into scratch, and q̃ again into
        scratch.q_start: Newton starts from there (and the last step's correction), before
        the commands move q̃."""
        dt = model.dt
        gravity = vec12()
        if model.has_gravity != 0:
            gravity = translation_part(model.gravity)
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            qn = state.q[env, b]
            scratch.q_n[env, b] = qn
            if bdf2 != 0:
                scratch.q_tilde[env, b] = (bdf2_q_n * qn
                                           - bdf2_q_prev * state.q_prev[env, b]
                                           + bdf2_v * dt * (four * state.v[env, b]
                                                            - state.v_prev[env, b])
                                           + force_scale * gravity)
            else:
                scratch.q_tilde[env, b] = qn + dt * state.v[env, b] + force_scale * gravity
            scratch.q_start[env, b] = scratch.q_tilde[env, b]

    return SimpleNamespace(integrator_scales=integrator_scales, predict=predict)
