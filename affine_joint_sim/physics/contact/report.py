"""The contact report kernel: the forces the last step balanced, per listed pair
(``Stepper.contacts``, contact sensors and markers; README.md#contact).

One thread per environment, over its near list (the pairs the last step evaluated,
``contact.terms.listed``, in their order): a pair is active when its distance d at the state is
positive and below d̂, or when friction was lagged for it at the step's start (it acts until
the step ends). Its row holds d [m], the unit normal n (from the other side towards the body),
the nearest point of the other side's surface [m, world], the normal force [N] (the barrier's
push −w db/dd at d, plus the contact damper's −c (d − min(d_n, d̂))/dt within d̂, the sum never
below 0: the damper never pulls) and the friction force [N, world, on the body] (the lagged
smoothed Coulomb friction −μ λ (f1(y)/y) u of the slip u since q_n, λ frozen at the step's
start). These are ``physics.contact.terms``'s own quantities, evaluated once more at the state. The
active pairs go to the environment's rows in turn, as many as there is room for; ``counts``
says how many there were (the caller makes room and launches again when that is more). Built
per precision and pair kind, in a Warp module of its own (only scenes whose contacts are read
compile it).
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['REPORT_COLUMNS', 'REPORT_ROOM', 'build']

REPORT_COLUMNS = 11     # d; n (3); point (3); normal force; friction force (3)
REPORT_ROOM = 64        # rows per environment at first (more are made when a read needs them)


def build(t) -> SimpleNamespace:
    Model, State, Scratch = t.structs.Model, t.structs.State, t.structs.Scratch
    scalar, vec3, zero = t.scalar, t.vec3, t.zero
    listed, listed_pair, pair_bodies, gap_at = t.listed, t.listed_pair, t.pair_bodies, t.gap_at
    barrier, pair_weight, other_state, damper = (t.barrier, t.pair_weight, t.other_state,
                                                  t.damper)
    pair_friction, slip, smooth_friction = t.pair_friction, t.slip, t.smooth_friction
    world_point = t.world_point

    @wp.func
    def normal_force(model: Model, state: State, scratch: Scratch, env: int, k: int, p: int,
                     d: scalar):
        """The barrier's push plus the damper's force [N] of the k-th listed pair p at
        distance d < d̂: minus
        their gradients along d (the step's own, ``contact.terms.damper``) over dt², never
        below 0."""
        body, other = pair_bodies(model, p)
        dt2 = model.dt * model.dt
        e, b1, b2 = barrier(model, d)
        force = -dt2 * pair_weight(model, scratch.q_n[env, body],
                                   other_state(scratch.q_n, env, body, other), p) * b1
        if scratch.normal_damping[env, k] > zero:
            psi, dpsi, ddpsi, n, rest, rest_o = damper(model, state.q, scratch, env, k)
            force -= dpsi
        return wp.max(force / dt2, zero)

    @wp.func
    def friction_force(model: Model, state: State, scratch: Scratch, env: int, k: int, p: int):
        """The lagged friction force [N, world, on the pair's first body] of the k-th listed
        pair p at state.q."""
        body, other = pair_bodies(model, p)
        dt2 = model.dt * model.dt
        mu = pair_friction(model, p, body, other)
        force = vec3()
        if mu > zero:
            u1, u2, t1, t2, rest, rest_o = slip(model, state.q, scratch, env, p, body, other)
            f0, f1_over_y = smooth_friction(wp.sqrt(u1 * u1 + u2 * u2),
                                            model.contact_eps_velocity * model.dt)
            force = (-mu * scratch.friction_normal[env, k] / dt2 * f1_over_y
                     * (u1 * t1 + u2 * t2))
        return force

    @wp.func
    def pair_contact(model: Model, state: State, scratch: Scratch, env: int, k: int):
        """(p, active, body, other, d [m], n, point [m, world], normal force [N], friction
        force [N, world, on ``body``]) of the k-th listed pair p at state.q; ``body``,
        ``other`` as ``pair_bodies`` gives them. An inactive pair's forces are 0."""
        p = listed_pair(model, scratch, env, k)
        body, other = pair_bodies(model, p)
        d, n, rest, radius, rest_o, radius_o = gap_at(model, state.q, env, p)
        lagged = scratch.friction_normal[env, k] > zero
        active = d > zero and (d < model.contact_d_hat or lagged)
        point = world_point(state.q[env, body], rest) - (radius + d) * n
        push = zero
        if active and d < model.contact_d_hat:
            push = normal_force(model, state, scratch, env, k, p, d)
        friction = vec3()
        if active and lagged:
            friction = friction_force(model, state, scratch, env, k, p)
        return p, active, body, other, d, n, point, push, friction

    @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
    def contact_report(model: Model, state: State, scratch: Scratch,
                       counts: wp.array(dtype=int), pairs: wp.array2d(dtype=int),
                       rows: wp.array3d(dtype=wp.float64)):
        env = wp.tid()
        found = int(0)
        for k in range(listed(model, scratch, env)):
            p, active, body, other, d, n, point, push, friction = pair_contact(
                model, state, scratch, env, k)
            if active:
                if found < pairs.shape[1]:
                    pairs[env, found] = p
                    rows[env, found, 0] = wp.float64(d)
                    for i in range(3):
                        rows[env, found, 1 + i] = wp.float64(n[i])
                        rows[env, found, 4 + i] = wp.float64(point[i])
                        rows[env, found, 8 + i] = wp.float64(friction[i])
                    rows[env, found, 7] = wp.float64(push)
                found += 1
        counts[env] = found

    return SimpleNamespace(contact_report=contact_report, pair_contact=pair_contact)
