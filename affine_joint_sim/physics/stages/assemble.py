"""Newton system of one environment: −∇E into scratch.rhs, diagonal blocks into scratch.hessian
(or the gradient alone, for a solve with the factors of an earlier iteration).

The diagonal blocks are kinetic_scale·M + dt² κ v̄ ∇²‖AAᵀ−I‖² (PSD-projected) + the joints'
constant blocks (a mimic coupling's Hessian stays out of them: physics.stages.mimic). The
coupling blocks of the tree are constant (model.elim_offdiag) unless the
model has state_coupling: then they and the diagonal get each iteration the state-dependent
Gauss–Newton blocks of prismatic axes and of limit, drive and damping terms, per environment
(scratch.offdiag, for the blocks such a term touched this iteration: scratch.offdiag_set).
Scenes without such terms pay nothing for them.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.stages.out_of_line import apart

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the assembly for the types namespace ``t``."""
    vec12, mat12, scalar, zero, half = t.vec12, t.mat12, t.scalar, t.zero, t.half
    Model, State, Control, Scratch = (t.structs.Model, t.structs.State, t.structs.Control,
                                      t.structs.Scratch)
    affine, mass_times, add_mass = t.affine, t.mass_times, t.add_mass
    ortho_gradient, add_ortho_hessian = t.ortho_gradient, t.add_ortho_hessian
    joint_gradients, joint_state_blocks = t.joint_gradients, t.joint_state_blocks
    joint_is_nonlinear = t.joint_is_nonlinear
    joint_coordinate, joint_coordinate_gradients = (t.joint_coordinate,
                                                    t.joint_coordinate_gradients)
    coordinate_terms, limit_secant = t.coordinate_terms, t.limit_secant
    limit_penetration = t.limit_penetration
    add_mimics = apart(t, t.add_mimics)      # out of line (physics.stages.out_of_line)
    measure_turns, limit_idle = t.measure_turns, t.limit_idle
    # each out of line (physics.stages.out_of_line)
    add_pairs = apart(t, t.add_pairs)

    @wp.func
    def add_gradients(model: Model, scratch: Scratch, env: int, k: int, g_parent: vec12,
                      g_child: vec12):
        """Joint k's gradients into the rhs of its free bodies."""
        bp = model.joint_parent[k]
        bc = model.joint_child[k]
        if model.body_fixed[bp] == 0:
            scratch.rhs[env, bp] -= g_parent
        if model.body_fixed[bc] == 0:
            scratch.rhs[env, bc] -= g_child

    @wp.func
    def add_blocks(model: Model, scratch: Scratch, env: int, k: int, g_parent: vec12,
                   g_child: vec12, h_pp: mat12, h_pc: mat12, h_cc: mat12):
        """Gradients into rhs (``add_gradients``), diagonal blocks into hessian and the coupling
        block into offdiag (transposed when its slot belongs to the child; the first such block
        of an iteration starts from the constant one) of joint k's free bodies."""
        add_gradients(model, scratch, env, k, g_parent, g_child)
        bp = model.joint_parent[k]
        bc = model.joint_child[k]
        if model.body_fixed[bp] == 0:
            scratch.hessian[env, bp] += h_pp
        if model.body_fixed[bc] == 0:
            scratch.hessian[env, bc] += h_cc
        slot = model.joint_offdiag_body[k]
        if slot >= 0:
            if scratch.offdiag_set[env, slot] == 0:     # first state term on this block
                scratch.offdiag[env, slot] = model.elim_offdiag[slot]
                scratch.offdiag_set[env, slot] = 1
            if model.joint_offdiag_child[k] != 0:
                scratch.offdiag[env, slot] += wp.transpose(h_pc)
            else:
                scratch.offdiag[env, slot] += h_pc

    @wp.func
    def add_nonlinear_blocks(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                             env: int, k: int):
        """Joint k's state-dependent blocks (prismatic axis terms), where it has any."""
        if joint_is_nonlinear(model, k) != 0:
            h_pp, h_pc, h_cc, has = joint_state_blocks(model, q, env, k)
            if has != 0:
                add_blocks(model, scratch, env, k, vec12(), vec12(), h_pp, h_pc, h_cc)

    @wp.func
    def add_coordinate_terms(model: Model, state: State, control: Control,
                             q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, k: int,
                             bdf2: int, hessian: int):
        """Joint k's coordinate terms' gradient and Gauss–Newton blocks, where they are not
        zero (the gradient alone without ``hessian``). Returns 1 if the joint's limit is
        entered at q or was at the last factorization (its stiffness then changed since: the
        last factors cannot be trusted for this gradient), else 0."""
        untrusted = int(0)
        x = joint_coordinate(model, q, state, env, k)
        e, d1, d2 = coordinate_terms(model, state, control, env, k, x, bdf2)
        if hessian == 0:
            if model.joint_limit_strength[k] > zero:
                depth, side = limit_penetration(model, k, x)
                if depth > zero or scratch.limit_depth[env, k] > zero:
                    untrusted = 1
            if d1 != zero:
                x_parent, x_child = joint_coordinate_gradients(model, q, env, k)
                add_gradients(model, scratch, env, k, d1 * x_parent, d1 * x_child)
            return untrusted
        if model.joint_limit_strength[k] > zero:
            depth, change = limit_secant(model, k, x, scratch.limit_depth[env, k])
            scratch.limit_depth[env, k] = depth
            d2 += change
        if d1 != zero or d2 != zero:     # e.g. an inactive limit alone costs no blocks
            x_parent, x_child = joint_coordinate_gradients(model, q, env, k)
            y_parent = d2 * x_parent
            add_blocks(model, scratch, env, k, d1 * x_parent, d1 * x_child,
                       wp.outer(y_parent, x_parent), wp.outer(y_parent, x_child),
                       wp.outer(d2 * x_child, x_child))
        return untrusted

    # each out of line (physics.stages.out_of_line): inlined together into the assembly,
    # their 12×12 blocks took 30 KB of its stack frame there (float64); called per joint,
    # their bodies are left to the compiler
    add_nonlinear_blocks = apart(t, add_nonlinear_blocks, inline_body=False)
    add_coordinate_terms = apart(t, add_coordinate_terms, inline_body=False)

    @wp.func
    def add_state_blocks(model: Model, state: State, control: Control,
                         q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, k: int,
                         bdf2: int, hessian: int):
        """Joint k's state-dependent blocks (``add_nonlinear_blocks``, with ``hessian``) and
        its coordinate terms (``add_coordinate_terms``). Returns the latter's."""
        if hessian != 0:
            add_nonlinear_blocks(model, q, scratch, env, k)
        untrusted = int(0)
        if model.joint_state_terms[k] != 0 and limit_idle(model, scratch, env, k) == 0:
            untrusted = add_coordinate_terms(model, state, control, q, scratch, env, k, bdf2,
                                             hessian)
        return untrusted

    @wp.func
    def assemble(model: Model, state: State, control: Control, q: wp.array2d(dtype=vec12),
                 scratch: Scratch, env: int, kinetic_scale: scalar, bdf2: int, hessian: int):
        """rhs = −∇E(q) and, with ``hessian``, hessian = the diagonal blocks of ∇²E(q) of the
        free bodies (and offdiag = their coupling blocks when the model has state_coupling).
        Returns the number of joints whose limit, and of contacts whose barrier, makes the
        last factors untrusted (gradient alone; see ``add_state_blocks``)."""
        dt2 = model.dt * model.dt
        n_free = model.elim_order.shape[0]
        for k in range(n_free):
            b = model.elim_order[k]
            qb = q[env, b]
            a = affine(qb)
            m = model.body_mass[b]
            s = model.body_second_moment[b]
            ortho = dt2 * model.body_ortho_coeff[b]
            scratch.rhs[env, b] = -(kinetic_scale * mass_times(m, s, qb - scratch.q_tilde[env, b])
                                    + ortho * ortho_gradient(a))
            if hessian != 0:
                scratch.hessian[env, b] = add_ortho_hessian(
                    add_mass(model.body_joint_hessian[b], m, s, kinetic_scale), ortho, a,
                    half * kinetic_scale * (s[0] + s[1] + s[2] - wp.max(wp.max(s[0], s[1]),
                                                                       s[2])))
                if model.state_coupling != 0:
                    scratch.offdiag_set[env, b] = 0     # model.elim_offdiag until a term adds
        untrusted = int(0)
        measure_turns(model, q, scratch, env)
        for k in range(model.joint_parent.shape[0]):
            if model.joint_has_free[k] == 0:
                continue
            g_parent, g_child = joint_gradients(model, q, env, k)
            add_gradients(model, scratch, env, k, g_parent, g_child)
            if model.state_coupling != 0:
                untrusted += add_state_blocks(model, state, control, q, scratch, env, k, bdf2,
                                              hessian)
        add_mimics(model, state, q, scratch, env, hessian)
        if wp.static(t.bodies):     # no contact couples two bodies until one adds its block
            if hessian != 0:
                for j in range(model.touch_a.shape[0]):
                    scratch.block_used[env, j] = 0
        if wp.static(t.contact):     # compiled in where the scene has contact
            if model.has_contact != 0 and scratch.near_count[env] > 0:   # pairs listed
                # an active barrier's or friction's curvature changes fast: no last factors
                untrusted += add_pairs(model, q, scratch, env, hessian)
        return untrusted

    return SimpleNamespace(assemble=assemble)
