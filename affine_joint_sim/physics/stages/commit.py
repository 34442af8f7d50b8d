"""End of a step: accept or reject the Newton result, velocities, history, joint outputs, stats.

A step whose state is non-finite, or in which a joint turns more than 0.9π (its multi-turn
angle would alias), is rejected: that environment keeps its start-of-step state and flags the
step. Otherwise velocities follow the integrator, the BDF2 history shifts, the correction of
the step's prediction is kept for the next step's Newton start (with the step before's) and
the joint coordinates advance by their unwrapped increments (docs/physics.md#end-of-step,
docs/physics.md#newton-start, docs/physics.md#joint-coordinate).
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.host.codes import CONTINUOUS
from affine_joint_sim.physics.host.fields import PROBLEM_COLUMNS, STAT_FLOAT_NAMES, STAT_INT_NAMES

__all__ = ['build']

_I = {name: i for i, name in enumerate(STAT_INT_NAMES)}
_F = {name: i for i, name in enumerate(STAT_FLOAT_NAMES)}
_P = {name: i for i, name in enumerate(PROBLEM_COLUMNS)}


def build(t) -> SimpleNamespace:
    """Warp functions of the commit stage for the types namespace ``t``."""
    with_contact = t.contact     # contact code compiled in (kernels.step_kernels)
    scalar, vec12, zero, two, three, four = t.scalar, t.vec12, t.zero, t.two, t.three, t.four
    affine, ortho_energy = t.affine, t.ortho_energy
    pi, two_pi = t.pi, t.two_pi
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    joint_increment, joint_raw_coordinate = t.joint_increment, t.joint_raw_coordinate
    joint_gap, joint_step_aliases = t.joint_gap, t.joint_step_aliases
    s_iterations, s_halvings, s_converged = (_I['newton_iterations'],
                                             _I['line_search_halvings'], _I['converged'])
    s_failures, s_aliased, s_dropped = (_I['line_search_failures'], _I['angle_aliased'],
                                        _I['torque_dropped'])
    s_non_finite, s_rejected = _I['non_finite'], _I['step_rejected']
    s_residual, s_gap, s_strain = _F['residual'], _F['joint_gap'], _F['rotation_strain']
    s_distance, s_contacts = _F['min_distance'], _I['contacts']
    s_inner, s_stalls = _I['inner_iterations'], _I['inner_stalls']
    s_hessians, s_tries, s_energies = _I['hessians'], _I['gradient_tries'], _I['energies']
    s_gathers = _I['near_gathers']
    touching = t.touching
    p_any, p_not_converged, p_non_finite = _P['any'], _P['not_converged'], _P['non_finite']
    p_aliased, p_dropped, p_failures = (_P['angle_aliased'], _P['torque_dropped'],
                                        _P['line_search_failures'])
    p_full = _P['near_full']

    @wp.func
    def count_problem(state: State, chunk: int, column: int, present: int):
        """Count this environment under problem ``column`` of its launch's row ``chunk`` if
        ``present``; returns present."""
        if present != 0:
            wp.atomic_add(state.problem_counts, chunk, column, 1)
        return present

    @wp.func
    def wrap_angle(x: scalar):
        """x wrapped into (−π, π] (x is θ ∈ (−π, π] plus an initial position)."""
        out = x
        while out > pi:
            out -= two_pi
        while out <= -pi:
            out += two_pi
        return out

    @wp.func
    def candidate_velocities(model: Model, state: State, scratch: Scratch, env: int, bdf2: int):
        """Velocities of the Newton result into scratch.velocity; 0 if any state is non-finite."""
        dt = model.dt
        finite = int(1)
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            qn = scratch.q_n[env, b]
            v_new = (state.q[env, b] - qn) / dt
            if bdf2 != 0:
                v_new = (three * state.q[env, b] - four * qn
                         + state.q_prev[env, b]) / (two * dt)
            scratch.velocity[env, b] = v_new
            if not (wp.isfinite(state.q[env, b]) and wp.isfinite(v_new)):
                finite = 0
        return finite

    @wp.func
    def aliasing(model: Model, state: State, scratch: Scratch, env: int):
        """1 if a joint turned more than 0.9π since the last committed coordinate; each joint's
        raw coordinate of the Newton result into scratch.joint_raw (for ``commit``)."""
        aliased = int(0)
        for k in range(model.joint_parent.shape[0]):
            raw = joint_raw_coordinate(model, state.q, env, k)
            scratch.joint_raw[env, k] = raw
            step = joint_increment(model, k, raw, state.joint_coordinate[env, k])
            aliased = aliased | joint_step_aliases(model, k, step)
        return aliased

    @wp.func
    def commit(model: Model, state: State, scratch: Scratch, env: int, force_scale: scalar,
               converged: int):
        """Accept the step: velocities, history and the correction of its prediction (over
        ``force_scale``, the step's [s²]; none where Newton did not converge, whose last
        iterate is no solution to carry on), the step before's kept beside it, joint
        coordinates (a wrapped angle is reported for revolute joints in WRAPPED mode, the
        coordinate otherwise)."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            state.q_prev[env, b] = scratch.q_n[env, b]
            state.v_prev[env, b] = state.v[env, b]
            state.v[env, b] = scratch.velocity[env, b]
            correction = vec12()
            if converged != 0:
                correction = (state.q[env, b] - scratch.q_predicted[env, b]) / force_scale
            # the step before's, or where this step started afresh this one's (no change yet)
            before = correction
            if state.history_ready[env] != 0:
                before = state.correction[env, b]
            state.correction_prev[env, b] = before
            state.correction[env, b] = correction
        state.history_ready[env] = 1
        for k in range(model.joint_parent.shape[0]):
            previous = state.joint_coordinate[env, k]
            raw = scratch.joint_raw[env, k]
            delta = joint_increment(model, k, raw, previous)
            state.joint_coordinate_prev[env, k] = previous
            state.joint_coordinate[env, k] = previous + delta
            state.joint_velocity[env, k] = delta / model.dt
            if model.joint_angle_mode[k] == CONTINUOUS:
                state.joint_position[env, k] = previous + delta
            else:
                state.joint_position[env, k] = wrap_angle(raw)

    @wp.func
    def finish(model: Model, state: State, scratch: Scratch, env: int, bdf2: int,
               force_scale: scalar, converged: int, full: int):
        """Commit or reject the step (``full`` ≠ 0: its near list outgrew its room; ``bdf2``
        and ``force_scale`` [s²] its integrator's, ``converged`` Newton's). Returns (finite,
        aliased, rejected)."""
        finite = candidate_velocities(model, state, scratch, env, bdf2)
        aliased = aliasing(model, state, scratch, env)
        rejected = int(0)
        if finite == 0 or aliased != 0 or full != 0:
            rejected = 1
            for k in range(model.elim_order.shape[0]):
                b = model.elim_order[k]
                state.q[env, b] = scratch.q_n[env, b]
        else:
            commit(model, state, scratch, env, force_scale, converged)
        return finite, aliased, rejected

    @wp.func
    def largest_gap(model: Model, state: State, env: int):
        """Largest constraint gap over the joints [m]."""
        gap = zero
        for k in range(model.joint_parent.shape[0]):
            gap = wp.max(gap, joint_gap(model, state.q, env, k))
        return gap

    @wp.func
    def largest_strain(model: Model, state: State, env: int):
        """Largest ‖AAᵀ − I‖_F over the free bodies [-]."""
        strain = zero
        for k in range(model.elim_order.shape[0]):
            a = affine(state.q[env, model.elim_order[k]])
            strain = wp.max(strain, wp.sqrt(ortho_energy(a)))
        return strain

    @wp.func
    def write_stats(model: Model, state: State, scratch: Scratch, env: int, chunk: int,
                    iterations: int, halvings: int, converged: int, failures: int, aliased: int,
                    dropped: int, finite: int, rejected: int, full: int, residual: scalar,
                    inner: int, stalls: int, hessians: int, tries: int, energies: int,
                    gap: scalar, strain: scalar):
        """The step's statistics, addressed by the names of physics.host.fields (with contact: the
        smallest distance to a static thing and the pairs closer than d̂ at the end), and the
        environment counted in state.problem_counts under each problem it had (a rejected
        step's Newton status does not count: its state was not kept; a step whose near list
        outgrew its room counts that alone: ``full``)."""
        state.stats_int[env, s_iterations] = iterations
        state.stats_int[env, s_halvings] = halvings
        state.stats_int[env, s_converged] = converged
        state.stats_int[env, s_failures] = failures
        state.stats_int[env, s_aliased] = aliased
        state.stats_int[env, s_dropped] = dropped
        state.stats_int[env, s_non_finite] = 1 - finite
        state.stats_int[env, s_rejected] = rejected
        state.stats_int[env, s_inner] = inner
        state.stats_int[env, s_stalls] = stalls
        state.stats_int[env, s_hessians] = hessians
        state.stats_int[env, s_tries] = tries
        state.stats_int[env, s_energies] = energies
        state.stats_float[env, s_residual] = residual
        state.stats_float[env, s_gap] = gap
        state.stats_float[env, s_strain] = strain
        if wp.static(with_contact):     # compiled in where the scene has contact
            if model.has_contact != 0:
                nearest, contacts = touching(model, state.q, scratch, env, 1)
                state.stats_float[env, s_distance] = nearest
                state.stats_int[env, s_contacts] = contacts
                state.stats_int[env, s_gathers] = scratch.near_gathers[env]
                state.nearest_seen[env] = wp.min(state.nearest_seen[env], nearest)
                state.most_contacts[env] = wp.max(state.most_contacts[env], contacts)
        not_converged = int(0)
        if converged == 0 and rejected == 0:
            not_converged = 1
        failed = int(0)
        if failures != 0:
            failed = 1
        problems = int(0)
        if full != 0:       # taken again with more room: that step counts its problems
            problems = count_problem(state, chunk, p_full, 1)
        else:
            problems += count_problem(state, chunk, p_not_converged, not_converged)
            problems += count_problem(state, chunk, p_non_finite, 1 - finite)
            problems += count_problem(state, chunk, p_aliased, aliased)
            problems += count_problem(state, chunk, p_dropped, dropped)
            problems += count_problem(state, chunk, p_failures, failed)
        any_problem = int(0)
        if problems != 0:
            any_problem = 1
        count_problem(state, chunk, p_any, any_problem)

    return SimpleNamespace(finish=finish, largest_gap=largest_gap,
                           largest_strain=largest_strain, write_stats=write_stats)
