"""Terms on a joint's coordinate x(q) shared by joint types: limit, drive, damping, friction.

Each is a scalar function φ(x) inside the incremental potential (docs/physics.md#joint-terms),
entering Newton through φ'(x) ∇x and the Gauss–Newton Hessian φ''(x) ∇x ∇xᵀ (φ'' ≥ 0, so PSD;
the φ' ∇²x term is dropped). x is the multi-turn angle [rad] or the distance [m]: the last
committed coordinate plus the in-step increment, so limits and targets work across ±π.

- limit (UID 670 / 669): s((x−u)/(u−l))³ above u, s((l−x)/(u−l))³ below l, s|x−l|³ if u = l;
  entered from outside in one Newton step, its φ'' (zero at the limit) lets the iterate
  overshoot deep and then only halve its depth per iteration; once two iterates show that
  halving, ``limit_secant`` replaces φ'' by the secant towards the depth it heads for;
- drive (UID 19 and its prismatic analogue): K/2 (x − target)² while enabled;
- damping c (viscous, ours): the dissipation potential c/(2 dt)·(x − x_n)² of implicit Euler,
  which is c·dt/2·(x − x_n)² in this dt²-scaled potential; under BDF2 its velocity estimate
  (3x − 4x_n + x_{n−1})/(2dt) gives 3/2·c·dt/2·(x − (4x_n − x_{n−1})/3)². With a commanded
  speed v (a velocity drive, ``control.joint_velocity_target``) it pulls the velocity estimate
  toward v instead of 0: x − x_n − v dt, and x − (4x_n − x_{n−1})/3 − 2/3 v dt under BDF2;
- friction f (Coulomb, ours): IPC's smoothed friction on the slip s = x − x̂ of the same
  velocity estimate, dt² f f0(|s|), f0(y) = y beyond ε = SLIP_SPEED·(dt, or 2/3 dt under BDF2)
  and y²/ε − y³/(3ε²) + ε/3 below (C¹): a torque f against the motion beyond the slip speed,
  a stiff viscous law below it.
Like the joint energy, limit and drive carry no dt²: their physical stiffness is ∝ 1/dt².
"""

import math
from types import SimpleNamespace

import warp as wp

__all__ = ['SLIP_SPEED', 'build']

SLIP_SPEED = 1e-3   # rad/s | m/s: below it a joint's friction is viscous (IPC's ε_v)


def build(t) -> SimpleNamespace:
    """Warp functions of the coordinate terms for the types namespace ``t``."""
    vec12, scalar = t.vec12, t.scalar
    zero, half, one, three = t.zero, t.half, t.one, t.three
    minus_one = scalar(-1.0)
    six = scalar(6.0)
    two = t.two
    halving_low, halving_high = scalar(0.4), scalar(0.6)
    bdf2_x_n, bdf2_x_prev, bdf2_gain = scalar(4.0 / 3.0), scalar(1.0 / 3.0), scalar(1.5)
    bdf2_ahead = scalar(2.0 / 3.0)
    slip_speed = scalar(SLIP_SPEED)
    Model, State, Control = t.structs.Model, t.structs.State, t.structs.Control
    joint_coordinate_step = t.joint_coordinate_step

    @wp.func
    def joint_coordinate(model: Model, q: wp.array2d(dtype=vec12), state: State, env: int,
                         k: int):
        """x(q): the last committed coordinate plus the increment to q."""
        previous = state.joint_coordinate[env, k]
        return previous + joint_coordinate_step(model, q, env, k, previous)

    @wp.func
    def limit_penetration(model: Model, k: int, x: scalar):
        """(g, side) of a limit of width u − l > 0 at x: the penetration g = (x − u)/(u − l)
        above it (side +1) or (l − x)/(u − l) below it (side −1); (0, 0) inside."""
        lower = model.joint_limit_lower[k]
        upper = model.joint_limit_upper[k]
        width = upper - lower
        g = zero
        side = zero
        if x > upper:
            g = (x - upper) / width
            side = one
        elif x < lower:
            g = (lower - x) / width
            side = minus_one
        return g, side

    @wp.func
    def limit_term(model: Model, k: int, x: scalar):
        """(φ, φ', φ'') of the cubic limit penalty."""
        s = model.joint_limit_strength[k]
        lower = model.joint_limit_lower[k]
        width = model.joint_limit_upper[k] - lower
        e = zero
        d1 = zero
        d2 = zero
        if width > zero:
            g, side = limit_penetration(model, k, x)
            if side != zero:
                e = s * g * g * g
                d1 = side * (three * s * g * g / width)
                d2 = six * s * g / (width * width)
        else:
            g = wp.abs(x - lower)
            e = s * g * g * g
            d1 = three * s * g * (x - lower)
            d2 = six * s * g
        return e, d1, d2

    @wp.func
    def limit_secant(model: Model, k: int, x: scalar, previous: scalar):
        """(depth, Δφ'') of the limit at x: its penetration / (u − l), and the change that turns
        φ'' into the secant slope of φ' towards the depth Newton is heading for, when the last
        two iterates show the halving that a cubic penalty entered from outside causes (depth
        ≈ half the previous one: the solution depth ĝ then follows from ĝ² = p (2g − p)). Only
        the Hessian changes, never the gradient, so the solution does not; Δφ'' ≤ 0 keeps φ''
        positive (the secant 3s(g + ĝ)/(u − l)² against the tangent 6sg/(u − l)²)."""
        width = model.joint_limit_upper[k] - model.joint_limit_lower[k]
        depth = zero
        change = zero
        if width > zero:
            depth, side = limit_penetration(model, k, x)
            if depth > zero and previous > zero and depth < halving_high * previous and (
                    depth > halving_low * previous):
                target = wp.sqrt(wp.max(previous * (two * depth - previous), zero))
                change = three * model.joint_limit_strength[k] * (target - depth) / (
                    width * width)
        return depth, change

    @wp.func
    def friction_term(weight: scalar, slip: scalar, eps: scalar):
        """(φ, φ', φ'') of weight·f0(|slip|), IPC's smoothed friction with threshold eps [m |
        rad]: f0(y) = y beyond eps, y²/eps − y³/(3 eps²) + eps/3 below."""
        y = wp.abs(slip)
        e = weight * y
        d1 = weight
        d2 = zero
        if y < eps:
            e = weight * (y * y / eps - y * y * y / (three * eps * eps) + eps / three)
            d1 = weight * (two * y / eps - y * y / (eps * eps))
            d2 = weight * (two / eps - two * y / (eps * eps))
        if slip < zero:
            d1 = -d1
        return e, d1, d2

    @wp.func
    def coordinate_terms(model: Model, state: State, control: Control, env: int, k: int,
                         x: scalar, bdf2: int):
        """(φ, φ', φ'') of joint k's limit + drive + friction + damping (toward its commanded
        speed) at coordinate x."""
        e = zero
        d1 = zero
        d2 = zero
        if model.joint_limit_strength[k] > zero:
            e, d1, d2 = limit_term(model, k, x)
        stiffness = model.joint_drive_stiffness[k]
        if stiffness > zero and control.joint_drive_enabled[env, k] != 0:
            diff = x - control.joint_target[env, k]
            e += half * stiffness * diff * diff
            d1 += stiffness * diff
            d2 += stiffness
        damping = model.joint_damping[k]
        friction = model.joint_friction[k]
        if damping > zero or friction > zero:
            # x̂: where x would be at rest; ahead: how far x moves in the step at 1 rad/s | m/s
            x_hat = state.joint_coordinate[env, k]
            gain = damping * model.dt
            ahead = model.dt
            if bdf2 != 0:
                x_hat = bdf2_x_n * x_hat - bdf2_x_prev * state.joint_coordinate_prev[env, k]
                gain = bdf2_gain * gain
                ahead = bdf2_ahead * ahead
            if friction > zero:
                fe, fd1, fd2 = friction_term(friction * model.dt * model.dt, x - x_hat,
                                             slip_speed * ahead)
                e += fe
                d1 += fd1
                d2 += fd2
            if damping > zero:
                speed = control.joint_velocity_target[env, k]
                if speed != zero:
                    x_hat += ahead * speed
                diff = x - x_hat
                e += half * gain * diff * diff
                d1 += gain * diff
                d2 += gain
        return e, d1, d2

    Scratch = t.structs.Scratch
    affine, revolute_alignment = t.affine, t.revolute_alignment
    pi_ = scalar(math.pi)
    root_two = scalar(math.sqrt(2.0))
    slack = scalar(1.0e-6)

    @wp.func
    def prepare_limit_reach(model: Model, state: State, scratch: Scratch, env: int):
        """At the start of Newton, for every joint_limit_alone k: the largest D (see
        ``limit_idle``) for which its coordinate provably stays inside its limits this step,
        into scratch.limit_reach (≤ 0: none). With v = (c, s) its alignment (θ = atan2(s, c);
        ``revolute_alignment``), every iterate's |v − v_n| ≤ √2 D, so by the Dunkl–Williams
        inequality its angle from v_n is at most π √2 D / (2|v_n| − √2 D): at most the room
        r = min(x_n − l, u − x_n) (less rounding) for D ≤ √2 r |v_n| / (π + r)."""
        if model.limits_alone != 0:
            for b in range(model.body_fixed.shape[0]):
                a = affine(scratch.q_n[env, b])
                scratch.body_size[env, b] = wp.sqrt(wp.ddot(a, a))
            for k in range(model.joint_parent.shape[0]):
                if model.joint_limit_alone[k] != 0:
                    x = state.joint_coordinate[env, k]
                    room = wp.min(x - model.joint_limit_lower[k],
                                  model.joint_limit_upper[k] - x) - slack * (one + wp.abs(x))
                    reach = -one
                    if room > zero:
                        c, s = revolute_alignment(model, scratch.q_n, env, k)
                        reach = (one - slack) * root_two * room * wp.sqrt(c * c + s * s) / (
                            pi_ + room)
                    scratch.limit_reach[env, k] = reach

    @wp.func
    def measure_turns(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch, env: int):
        """‖A − A(q_n)‖_F of every free body at q into scratch.body_turn (where the model has
        joint_limit_alone joints; fixed bodies keep 0)."""
        if model.limits_alone != 0:
            for k in range(model.elim_order.shape[0]):
                b = model.elim_order[k]
                turn = affine(q[env, b]) - affine(scratch.q_n[env, b])
                scratch.body_turn[env, b] = wp.sqrt(wp.ddot(turn, turn))

    @wp.func
    def limit_idle(model: Model, scratch: Scratch, env: int, k: int):
        """1 if joint k is a joint_limit_alone whose coordinate provably stays inside its limits
        at the iterate of the last ``measure_turns`` (its limit's φ, φ', φ'' are exact zeros
        there: skipping it changes no bit): D = t_P (s_C + t_C) + s_P t_C ≤ its limit_reach,
        s = ‖A(q_n)‖_F and t = ‖A − A(q_n)‖_F of its bodies, each of |Δc|, |Δs| being at most D
        (c and s are sums of products of A_P and A_C columns with unit rest vectors)."""
        idle = int(0)
        if model.joint_limit_alone[k] != 0:
            reach = scratch.limit_reach[env, k]
            p = model.joint_parent[k]
            c = model.joint_child[k]
            t_p = scratch.body_turn[env, p]
            t_c = scratch.body_turn[env, c]
            bound = t_p * (scratch.body_size[env, c] + t_c) + scratch.body_size[env, p] * t_c
            if reach > zero and bound <= reach:
                idle = 1
        return idle

    return SimpleNamespace(joint_coordinate=joint_coordinate, coordinate_terms=coordinate_terms,
                           limit_penetration=limit_penetration, limit_secant=limit_secant,
                           prepare_limit_reach=prepare_limit_reach, measure_turns=measure_turns,
                           limit_idle=limit_idle)
