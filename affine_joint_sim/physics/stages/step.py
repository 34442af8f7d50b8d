"""The step kernel: one launch steps every environment by dt (docs/architecture.md#the-step-kernel).

One thread per environment (environments first_env, first_env + 1, ...: the CPU steps a batch
in several launches at once, each counting its problems in its own row ``chunk``): prediction,
friction's lagged normal forces (with contact), explicit commands, Newton with line search,
then commit or reject and the statistics. A step whose near list outgrew its room is
rejected before Newton or as soon as it does (scratch.near_full): the Stepper takes it again
with more room. Under BDF2 a step with a contact that it cannot resolve
is BDF1, and so is the step after it or after an impact (docs/physics.md#impacts).
No host sync inside a step. The kernel gets a Warp module of its own per precision
(``module="unique"``) and no adjoint: nothing differentiates the step, and Warp's generated
backward pass made it compile several times slower (docs/architecture.md#measured-figures).
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.host.codes import BDF2

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """The step kernel for the types namespace ``t``."""
    with_contact = t.contact     # contact code compiled in (kernels.step_kernels)
    Model, State, Control, Scratch = (t.structs.Model, t.structs.State, t.structs.Control,
                                      t.structs.Scratch)
    integrator_scales, predict, apply_commands = t.integrator_scales, t.predict, t.apply_commands
    newton, finish, write_stats = t.newton, t.finish, t.write_stats
    lag_friction, impact = t.lag_friction, t.impact
    largest_gap, largest_strain = t.largest_gap, t.largest_strain
    salt, zero = t.source_salt, t.zero

    @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
    def step(model: Model, state: State, control: Control, scratch: Scratch, first_env: int,
             chunk: int):
        wp.static(salt)     # its sources' digest, in the module hash (kernel_math)
        env = first_env + wp.tid()
        bdf2, kinetic_scale, force_scale = integrator_scales(model, state, env, 0)
        predict(model, state, scratch, env, bdf2, force_scale)
        unresolved = int(0)     # −1: the near list outgrew its room (the step is rejected)
        if wp.static(with_contact):     # compiled in where the scene has contact
            if model.has_contact != 0:     # pairs arriving within d̂, or deep in the barrier
                scratch.near_gathers[env] = 0
                unresolved = lag_friction(model, state, scratch, env)
                if bdf2 != 0 and unresolved > 0:
                    bdf2, kinetic_scale, force_scale = integrator_scales(model, state, env, 1)
                    predict(model, state, scratch, env, bdf2, force_scale)
        dropped = apply_commands(model, state, control, scratch, env, force_scale)
        iterations, halvings, failures, converged = int(0), int(0), int(0), int(0)
        residual = zero
        inner, stalls, hessians, tries, energies = int(0), int(0), int(0), int(0), int(0)
        if unresolved >= 0:
            (iterations, halvings, failures, converged, residual, inner, stalls, hessians, tries,
             energies) = newton(model, state, control, scratch, env, kinetic_scale, bdf2,
                                force_scale)
        full = int(0)
        restart = unresolved
        if wp.static(with_contact):
            if model.has_contact != 0:
                full = scratch.near_full[env]
                if restart == 0 and full == 0 and model.integrator == BDF2:
                    restart = impact(model, state, scratch, env)
        finite, aliased, rejected = finish(model, state, scratch, env, bdf2, force_scale,
                                           converged, full)
        if restart > 0 and full == 0:     # the next step is BDF1: BDF2 would carry an
            state.history_ready[env] = 0    # impact's turn on
        if finite == 0:
            converged = 0
        write_stats(model, state, scratch, env, chunk, iterations, halvings, converged,
                    failures, aliased, dropped, finite, rejected, full, residual, inner, stalls,
                    hessians, tries, energies, largest_gap(model, state, env),
                    largest_strain(model, state, env))

    return SimpleNamespace(step=step)
