"""Newton's method on the incremental potential (docs/physics.md#newton-solver).

From q̃ before the commands (with solver.warm_start, a body whose prediction added shear starts
from the rotation of q̃ times the stretch of q_n: see ``warm_start``): assemble, tree-solve,
test convergence on the direction (largest box-corner displacement and largest affine entry
≤ newton_tol·dt, or ≤ their rounding floor where that is larger: see ``extent``; after the
first iteration first on the direction of the last factors for the new gradient alone, which
ends most steps without a second Hessian), then a line search on E:
the full step with the bodies' turns followed on their rotations (``moved``), else a
backtracking search on the straight path (≤ HALVINGS halvings); a trial is accepted on no
increase up to the rounding of E, its own and that from the coordinates' (see
``position_rounding``). Without contact the first iteration's full step (the search's first
trial) is taken before E is known at either end and checked by the next solve on the same
factors: where that ends Newton, no energy is computed at all (a robot's usual step: one
Hessian, one factorization, two gradients); else the step is judged as the search would have
judged it, and the iterates are the search's, bit for bit. With contact
(docs/physics.md#contact) the straight path starts at the step bound that keeps every point
clear of the static things, energies are +∞ on penetration, Newton starts from q_n where the
prediction touches (or, with static shapes, is not reached from q_n on a collision-free
straight path) or where E is lower at q_n (a resting body), converges only on a full step
that is collision-free, and searches unless its first update ends the step (E is computed
when first needed: at the start only to compare a resting body's start with q_n); with
static shapes or bodies that touch each other the search follows straight paths only. Where
friction is loaded every iteration assembles afresh (the last factors could not end Newton).
Runs inside the step kernel: no host sync.
"""

from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.stages.out_of_line import apart

__all__ = ['HALVINGS', 'build']

HALVINGS = 12       # line-search halvings on the straight path at most (α down to 1/4096)


def build(t) -> SimpleNamespace:
    """Warp functions of the Newton loop for the types namespace ``t``."""
    with_contact = t.contact     # contact code compiled in (kernels.step_kernels)
    mat33, vec3, vec12, scalar = t.mat33, t.vec3, t.vec12, t.scalar
    zero, half, one, two = t.zero, t.half, t.one, t.two
    affine, ortho_energy, polar, mass_times = t.affine, t.ortho_energy, t.polar, t.mass_times
    stretch = t.stretch
    sin = t.sin
    rigid_strain, roundoff = t.rigid_strain, t.energy_roundoff
    update_roundoff, unit_roundoff = t.update_roundoff, t.unit_roundoff
    Model, State, Control, Scratch = (t.structs.Model, t.structs.State, t.structs.Control,
                                      t.structs.Scratch)
    # the big stages out of line (physics.stages.out_of_line)
    assemble, solve, solve_factored = apart(t, t.assemble), apart(t, t.solve), t.solve_factored
    incremental_potential = apart(t, t.incremental_potential)
    step_bound, touching, cover = apart(t, t.step_bound), apart(t, t.touching), t.cover
    friction_loaded = t.friction_loaded
    prepare_limit_reach = t.prepare_limit_reach
    max_turn = scalar(0.5)      # rad: the most one Newton update may turn a body
    smooth = scalar(0.2)        # the most a correction may change a step and be extrapolated

    @wp.func
    def warm_start(q_tilde: vec12, q_n: vec12):
        """q̃ with A = R̃ S_n: the rotation the prediction carries and the stretch of the last
        state, so that a torqued or spinning body's predicted shear is dropped while a loaded
        body keeps its equilibrium stretch. A q̃ that is a rotation to rounding stays as it is."""
        a = affine(q_tilde)
        a_n = affine(q_n)
        strain = ortho_energy(a)
        if strain <= rigid_strain or strain <= two * ortho_energy(a_n):
            return q_tilde
        r, s_tilde = polar(a)
        m = r @ stretch(a_n)
        return vec12(q_tilde[0], q_tilde[1], q_tilde[2], m[0, 0], m[0, 1], m[0, 2],
                     m[1, 0], m[1, 1], m[1, 2], m[2, 0], m[2, 1], m[2, 2])

    @wp.func
    def update_size(model: Model, scratch: Scratch, env: int):
        """Largest vertex displacement over box corners [m] and largest affine entry of dq."""
        disp = zero
        affine_max = zero
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            dq = scratch.dq[env, b]
            h = model.body_half_extent[b]
            for r in range(3):
                corner = wp.abs(dq[r])
                for c in range(3):
                    corner += wp.abs(dq[3 + 3 * r + c]) * h[c]
                    affine_max = wp.max(affine_max, wp.abs(dq[3 + 3 * r + c]))
                disp = wp.max(disp, corner)
        return disp, affine_max

    @wp.func
    def update_test(model: Model, scratch: Scratch, env: int, disp_tol: scalar,
                    affine_tol: scalar):
        """(residual [m/s]: the larger update size / dt, 1 if both sizes are within their
        tolerances and, with contact, the full step is collision-free) of the update
        scratch.dq from scratch.q_start (see ``update_size``, contact's ``step_bound``)."""
        disp, affine_max = update_size(model, scratch, env)
        small = int(0)
        if disp <= disp_tol and affine_max <= affine_tol:
            small = 1
            if wp.static(with_contact):     # converged on a full, collision-free step only
                if model.has_contact != 0 and step_bound(model, scratch, env) < one:
                    small = 0
        return wp.max(disp, affine_max) / model.dt, small

    @wp.func
    def extent(model: Model, q: wp.array2d(dtype=vec12), env: int):
        """(largest world coordinate of a free body's box corner [m], smallest largest half
        extent of a free body [m]): the scale of position rounding and the shortest lever that
        turns it into rounding of an affine entry."""
        size = zero
        lever = zero
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            p = q[env, b]
            h = model.body_half_extent[b]
            longest = wp.max(wp.max(h[0], h[1]), h[2])
            size = wp.max(size, wp.max(wp.max(wp.abs(p[0]), wp.abs(p[1])), wp.abs(p[2])) + longest)
            if k == 0:
                lever = longest
            lever = wp.min(lever, longest)
        return size, lever

    @wp.func
    def rotation_of(w: vec3):
        """exp([w]×): the rotation by |w| about w (Rodrigues, stable for small |w|)."""
        theta = wp.length(w)
        half_theta = half * theta
        sinc = one
        sinc_half = one
        if theta > zero:
            sinc = sin(theta) / theta
            sinc_half = sin(half_theta) / half_theta
        k = wp.skew(w)
        return wp.identity(n=3, dtype=scalar) + sinc * k + half * sinc_half * sinc_half * (k @ k)

    @wp.func
    def rates(q_start: vec12, dq: vec12):
        """(w, E, A) of an update: dA A⁻¹ = [w]× + E with E symmetric, A = A_start; w is the
        rotation [rad] the update turns the body by, E its strain."""
        a = affine(q_start)
        da = mat33(dq[3], dq[4], dq[5], dq[6], dq[7], dq[8], dq[9], dq[10], dq[11])
        m = da @ wp.inverse(a)
        w = half * vec3(m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1])
        return w, half * (m + wp.transpose(m)), a

    @wp.func
    def moved(q_start: vec12, dq: vec12, alpha: scalar):
        """q_start + α dq with the turn of dA followed on the rotations: A' = exp(α[w]×)(I + αE) A
        (see ``rates``), to first order A + α dA, but a turn adds no stretch for the
        orthogonality energy to fight (a light link spinning about its hinge crept a few
        milliradians per iteration before)."""
        w, e, a = rates(q_start, dq)
        turn = alpha * w
        if wp.dot(turn, turn) <= unit_roundoff:     # its stretch ½|αw|² is below rounding
            return q_start + alpha * dq
        n = rotation_of(turn) @ (wp.identity(n=3, dtype=scalar) + alpha * e) @ a
        return vec12(q_start[0] + alpha * dq[0], q_start[1] + alpha * dq[1],
                     q_start[2] + alpha * dq[2], n[0, 0], n[0, 1], n[0, 2], n[1, 0], n[1, 1],
                     n[1, 2], n[2, 0], n[2, 1], n[2, 2])

    @wp.func
    def full_step(model: Model, scratch: Scratch, env: int):
        """The step α ≤ 1 at which no body whose turns are followed turns by more than
        max_turn: an update that asks for more (far from the solution) is not trusted along
        turns, which, unlike the straight path, no stretch penalises."""
        turn = zero
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            if model.body_resolves_turns[b] != 0:
                w, e, a = rates(scratch.q_start[env, b], scratch.dq[env, b])
                turn = wp.max(turn, wp.length(w))
        alpha = one
        if turn > max_turn:
            alpha = max_turn / turn
        return alpha

    @wp.func
    def move(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int, alpha: scalar,
             turning: int):
        """q = q_start + α dq on the free bodies; with ``turning``, turns followed on the bodies
        whose turns the precision resolves (see ``moved``; model.body_resolves_turns)."""
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            if turning != 0 and model.body_resolves_turns[b] != 0:
                q[env, b] = moved(scratch.q_start[env, b], scratch.dq[env, b], alpha)
            else:
                q[env, b] = scratch.q_start[env, b] + alpha * scratch.dq[env, b]

    @wp.func
    def position_rounding(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                          env: int, kinetic_scale: scalar):
        """How far E [J·s²] moves when every coordinate of q and q̃ moves by its rounding
        (update_roundoff relative): the inertial force M (q − q̃), which the other forces
        balance near the solution, times those roundings, twice. Far from the origin in
        float32 this outgrows the relative rounding of E and a line search judging smaller
        changes compares noise."""
        noise = zero
        for k in range(model.elim_order.shape[0]):
            b = model.elim_order[k]
            x = q[env, b] - scratch.q_tilde[env, b]
            force = mass_times(model.body_mass[b], model.body_second_moment[b], x)
            for i in range(12):
                size = wp.max(wp.abs(q[env, b][i]), wp.abs(scratch.q_tilde[env, b][i]))
                noise += wp.abs(force[i]) * size
        return two * update_roundoff * kinetic_scale * noise

    @wp.func(inline=True)
    def passable(model: Model):
        """Whether the scene has things a point could pass through between two checks of its
        distance: static shapes, or bodies that may touch each other (unlike a half-space's,
        their distances are unsigned)."""
        return model.shape_kind.shape[0] > 0 or model.touch_a.shape[0] > 0

    # (a loop holding a wp.static expression is unrolled by Warp whatever its length: these
    # two keep the line search's switches out of its loop)
    @wp.func
    def contact_bound(model: Model, scratch: Scratch, env: int):
        """``step_bound`` where the scene has contact, else 1 (the full step)."""
        alpha = one
        if wp.static(with_contact):
            if model.has_contact != 0:
                alpha = step_bound(model, scratch, env)
        return alpha

    @wp.func
    def contact_cover(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int):
        """``cover`` of q where the scene has contact."""
        if wp.static(with_contact):
            if model.has_contact != 0:
                cover(model, q, scratch, env, 0)

    @wp.func
    def line_search(model: Model, state: State, control: Control, q: wp.array2d(dtype=vec12),
                    scratch: Scratch, env: int, kinetic_scale: scalar, bdf2: int,
                    energy: scalar):
        """First the full step along turns (``moved``, capped by ``full_step``); if E rises,
        the straight path q_start + α dq, halving α from 1 until E ≤ energy + its rounding
        (HALVINGS at most: a cubic limit entered deep needs many). Following turns saves
        iterations where links turn (figures: docs/physics.md#line-search and the README),
        but bends the path off the joints, which are linear in q: where that costs more
        than the turn saves, the straight path takes over. The rounding: near
        convergence E changes by less than it, and rejecting a step on that noise stalled
        Newton (float32 most).

        Returns (E at the last trial, halvings, 1 if a trial was accepted, energies
        evaluated)."""
        slack = roundoff * wp.abs(energy) + position_rounding(model, q, scratch, env,
                                                              kinetic_scale)
        bound = energy + slack
        accepted = int(0)
        halvings = int(0)
        trials = int(0)
        trial = energy
        alpha = one
        # trial 0 along turns, then the straight path (one call site of the energy, which a
        # GPU compile inlines at every call site)
        for ls in range(HALVINGS + 2):
            if ls == 1:     # no point comes closer than η of its gap (contact)
                alpha = contact_bound(model, scratch, env)
            if accepted != 0:
                break
            if ls == 0:
                # along turns points leave their straight lines: a check of its end is enough
                # against half-spaces (one free side), not against a static shape or a body a
                # point could pass
                if passable(model):
                    continue
                move(model, q, scratch, env, full_step(model, scratch, env), 1)
                contact_cover(model, q, scratch, env)   # of the turned end too
            else:
                move(model, q, scratch, env, alpha, 0)
            trial = incremental_potential(model, state, control, q, scratch, env,
                                          kinetic_scale, bdf2)
            trials += 1
            if trial <= bound:
                accepted = 1
            elif ls > 0 and ls <= HALVINGS:
                alpha = alpha * half
                halvings += 1
        return trial, halvings, accepted, trials

    @wp.func
    def resting(model: Model, scratch: Scratch, env: int):
        """Whether a listed pair was closer than d̂ at q_n (its lagged normal force is
        positive; only listed pairs hold one)."""
        found = int(0)
        for k in range(scratch.near_count[env]):
            if scratch.friction_normal[env, k] > zero:
                found = 1
        return found != 0

    @wp.func
    def reachable(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int):
        """Whether Newton may start from the prediction q: it touches nothing and, with static
        shapes or bodies that touch each other (``passable``), the straight path to it from
        q_n keeps every gap (``step_bound`` of 1 from q_n; scratch.q_start and dq are used as
        its input, before Newton sets them). The near pairs first cover q (``cover``: the
        commands and the warm start may have moved it beyond the margins)."""
        cover(model, q, scratch, env, 0)
        clear = True
        if passable(model):
            for k in range(model.elim_order.shape[0]):
                b = model.elim_order[k]
                scratch.q_start[env, b] = scratch.q_n[env, b]
                scratch.dq[env, b] = q[env, b] - scratch.q_n[env, b]
            clear = step_bound(model, scratch, env) >= one
        nearest, active = touching(model, q, scratch, env, 0)
        return clear and nearest > zero

    @wp.func
    def extrapolated(state: State, env: int, b: int):
        """Body b's correction for this step [m/s², 1/s²]: the last one c_n extrapolated
        linearly, 2 c_n − c_{n−1}, where it changed by at most ``smooth`` of itself since the
        step before (forces changing steadily: a robot speeding up), else c_n alone (an impact,
        a contact made or lost, a limit entered: docs/physics.md#newton-start)."""
        c = state.correction[env, b]
        change = c - state.correction_prev[env, b]
        if wp.dot(change, change) <= smooth * smooth * wp.dot(c, c):
            c = c + change
        return c

    @wp.func
    def newton(model: Model, state: State, control: Control, scratch: Scratch, env: int,
               kinetic_scale: scalar, bdf2: int, force_scale: scalar):
        """Minimise E from q̃ without the commands' push (scratch.q_start, see ``predict``),
        warm-started (kept in scratch.q_predicted), plus ``force_scale`` [s²] times the last
        step's correction where there is one (docs/physics.md#newton-start).
        Returns (iterations, halvings, line-search failures, converged, residual [m/s],
        inner iterations and stalls of the coupled solve, Hessians assembled and factored,
        gradients tried on the last factors, energies evaluated); the result is in
        state.q."""
        q = state.q
        n_free = model.elim_order.shape[0]
        dt = model.dt
        prepare_limit_reach(model, state, scratch, env)     # before any energy of this step
        uncorrected = int(0)    # bodies starting from their prediction alone
        for k in range(n_free):
            b = model.elim_order[k]
            q[env, b] = scratch.q_start[env, b]      # q̃ before the commands (prediction)
            if model.warm_start != 0:
                q[env, b] = warm_start(q[env, b], scratch.q_n[env, b])
            scratch.q_predicted[env, b] = q[env, b]
            # and the last step's forces besides inertia and gravity, applied once more,
            # extrapolated where they change smoothly
            if state.history_ready[env] != 0 and model.body_resolves_turns[b] != 0:
                q[env, b] += force_scale * extrapolated(state, env, b)
                if model.warm_start != 0:
                    q[env, b] = warm_start(q[env, b], scratch.q_n[env, b])
            else:
                uncorrected += 1
        compare = int(0)        # a resting body: q_n where it is lower in E
        if wp.static(with_contact):
            # from q_n (which touches nothing) where the prediction cannot be reached, or
            # where q_n is lower in E: a resting body's prediction sinks into the barrier
            # (not a corrected start, which carries the last step's support)
            if model.has_contact != 0:
                if not reachable(model, q, scratch, env):
                    for k in range(n_free):
                        b = model.elim_order[k]
                        q[env, b] = scratch.q_n[env, b]
                elif uncorrected > 0 and resting(model, scratch, env):
                    compare = 1
        # the start's E where a resting body compares it with E at q_n, else when first
        # needed (a step that converges on its first update needs none): one call site of
        # the energy, which a GPU compile inlines at every call site
        energy = zero
        at_n = zero
        energies = int(0)
        for e in range(2):
            if compare == 0:
                break
            at = q
            if e == 0:
                at = scratch.q_n
            energy = incremental_potential(model, state, control, at, scratch, env,
                                           kinetic_scale, bdf2)
            energies += 1
            if e == 0:
                at_n = energy
        if compare != 0 and at_n < energy:
            energy = at_n
            for k in range(n_free):
                b = model.elim_order[k]
                q[env, b] = scratch.q_n[env, b]
        for k in range(model.joint_parent.shape[0]):
            scratch.limit_depth[env, k] = -one
        # newton_tol·dt, or the rounding of an update if larger: below it Newton only cycles
        size, lever = extent(model, q, env)
        disp_tol = wp.max(model.newton_tol * dt, update_roundoff * size)
        affine_tol = wp.max(model.newton_tol * dt, update_roundoff * size / lever)
        iterations = int(0)
        halvings = int(0)
        failures = int(0)
        converged = int(0)
        residual = zero
        factored = int(0)
        inner = int(0)
        stalls = int(0)
        hessians = int(0)
        tries = int(0)
        known = compare                # whether ``energy`` holds E at the iterate
        unchecked = int(0)      # the last iteration's full step was taken before E judged it
        loaded = int(0)         # friction acts: every iteration assembles afresh
        if wp.static(with_contact):
            if model.has_contact != 0:
                loaded = friction_loaded(model, scratch, env)
        it = int(0)
        while it < model.newton_max_iter:
            iterations = it + 1
            for k in range(n_free):
                b = model.elim_order[k]
                scratch.q_start[env, b] = q[env, b]
            # first, with the last factors, the new gradient alone (converged already where
            # its update is small and the factors are trusted: no new Hessian), then a new
            # Hessian (at once where friction is loaded: the last factors could not end
            # Newton); one call site each (``assemble`` and ``update_test`` hold the contact
            # passes, which a GPU compile inlines at every call site)
            fresh = 1 - factored
            if loaded != 0:
                fresh = 1
            for attempt in range(2):
                untrusted = assemble(model, state, control, q, scratch, env, kinetic_scale,
                                     bdf2, fresh)
                if fresh != 0:
                    used, stalled = solve(model, scratch, env)
                    inner += used
                    stalls += stalled
                    factored = 1
                    hessians += 1
                else:
                    solve_factored(model, scratch, env)
                    tries += 1
                residual, small = update_test(model, scratch, env, disp_tol, affine_tol)
                if small != 0 and (fresh != 0 or untrusted == 0):
                    converged = 1
                    break
                if fresh != 0 or unchecked != 0:
                    break
                fresh = 1
            if converged != 0:
                move(model, q, scratch, env, one, 0)
                break
            if unchecked != 0:
                # the unchecked step did not end Newton: judge it as the line search would
                # have (back to its start, which the next pass takes again from the point
                # the search accepts: the iterates of a search at every step, bit for bit)
                unchecked = 0
                for k in range(n_free):
                    b = model.elim_order[k]
                    q[env, b] = scratch.q_before[env, b]
                    scratch.q_start[env, b] = scratch.q_before[env, b]
                    scratch.dq[env, b] = scratch.dq_before[env, b]
                it -= 1
            elif model.has_contact == 0 and (model.line_search == 0 or (
                    it == 0 and it + 2 <= model.newton_max_iter)):
                # without contact, the full step (without a line search, every one); with
                # one, the first full step (the search's first trial) is taken before E at
                # either end is known: where the next solve on these factors ends Newton
                # there, neither energy is needed (a robot's usual step)
                if model.line_search != 0:
                    for k in range(n_free):
                        b = model.elim_order[k]
                        scratch.q_before[env, b] = scratch.q_start[env, b]
                        scratch.dq_before[env, b] = scratch.dq[env, b]
                    unchecked = 1
                move(model, q, scratch, env, full_step(model, scratch, env), 1)
                it += 1
                continue
            if known == 0:      # at the iterate (q: scratch.q_start holds free bodies only)
                energy = incremental_potential(model, state, control, q, scratch, env,
                                               kinetic_scale, bdf2)
                energies += 1
                known = 1
            trial, used, accepted, trials = line_search(model, state, control, q, scratch,
                                                        env, kinetic_scale, bdf2, energy)
            halvings += used
            energies += trials
            failures += 1 - accepted
            energy = trial
            it += 1
        return (iterations, halvings, failures, converged, residual, inner, stalls, hessians,
                tries, energies)

    return SimpleNamespace(warm_start=warm_start, update_size=update_size,
                           update_test=update_test, extent=extent,
                           rotation_of=rotation_of, rates=rates, moved=moved,
                           full_step=full_step, move=move, reachable=reachable,
                           resting=resting,
                           line_search=line_search, newton=newton)
