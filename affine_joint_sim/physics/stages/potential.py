"""The incremental potential E(q) of one environment, for the line search.

E(q) = Σ_free kinetic_scale/2 ‖q − q̃‖²_M + dt² κ v̄ ‖AAᵀ − I‖² + Σ_joints E_joint(q)
+ Σ_joints φ(x(q)) (limit, drive, damping: physics.stages.joint_terms) + Σ_mimics K/2 r²
(physics.stages.mimic) + dt² Σ b(d) (contact with
static half-spaces: physics.contact.terms, +∞ on penetration) + Σ μ dt²λ f0(|u|) (lagged friction);
the joint terms carry no dt².
kinetic_scale is 1 (BDF1) or 9/4 (BDF2). See docs/physics.md#incremental-potential.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.stages.out_of_line import apart

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the incremental potential for the types namespace ``t``."""
    with_contact = t.contact     # contact code compiled in (kernels.step_kernels)
    vec12, scalar, zero, half = t.vec12, t.scalar, t.zero, t.half
    Model, State, Control, Scratch = (t.structs.Model, t.structs.State, t.structs.Control,
                                      t.structs.Scratch)
    affine, mass_times, ortho_energy = t.affine, t.mass_times, t.ortho_energy
    joint_energy, joint_coordinate, coordinate_terms = (t.joint_energy, t.joint_coordinate,
                                                        t.coordinate_terms)
    # each out of line (physics.stages.out_of_line)
    pairs_energy = apart(t, t.pairs_energy)
    mimic_energy = apart(t, t.mimic_energy)
    measure_turns, limit_idle = t.measure_turns, t.limit_idle

    @wp.func
    def incremental_potential(model: Model, state: State, control: Control,
                              q: wp.array2d(dtype=vec12), scratch: Scratch, env: int,
                              kinetic_scale: scalar, bdf2: int):
        """E(q) of environment ``env`` against scratch.q_tilde [J·s²]."""
        energy = zero
        dt2 = model.dt * model.dt
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            x = q[env, b] - scratch.q_tilde[env, b]
            energy += half * kinetic_scale * wp.dot(
                x, mass_times(model.body_mass[b], model.body_second_moment[b], x))
            energy += dt2 * model.body_ortho_coeff[b] * ortho_energy(affine(q[env, b]))
        measure_turns(model, q, scratch, env)
        for k in range(model.joint_parent.shape[0]):
            if model.joint_has_free[k] != 0:
                energy += joint_energy(model, q, env, k)
                if model.joint_state_terms[k] != 0 and limit_idle(model, scratch, env, k) == 0:
                    e, d1, d2 = coordinate_terms(model, state, control, env, k,
                                                 joint_coordinate(model, q, state, env, k), bdf2)
                    energy += e
        energy += mimic_energy(model, state, q, env)
        if wp.static(with_contact):     # compiled in where the scene has contact
            if model.has_contact != 0 and scratch.near_count[env] > 0:   # pairs listed
                energy += pairs_energy(model, q, scratch, env)
        return energy

    return SimpleNamespace(incremental_potential=incremental_potential)
