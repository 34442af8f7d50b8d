"""Joint types: one module per type, and the one dispatch point on ``model.joint_type``.

Each type of ``physics.host.joint_kinds.JOINT_KINDS`` has a module here named after it whose
``build(t)`` provides every Warp function of ``PROTOCOL`` (a type without a coordinate or a
command provides explicit no-ops) and whose host functions ``linear_pairs`` and
``nonlinear_residuals`` give its residuals to the model build and the host energy. The
dispatchers here loop over the types at compile time (``wp.static``), so every dispatcher
covers every type and the stages (assembly, prediction, commit) never branch on types. A code
that names no type (the model build refuses one) takes every dispatcher's zero branch.
"""

import importlib
import math
from types import SimpleNamespace

import warp as wp

from affine_joint_sim.physics.host.joint_kinds import JOINT_KINDS

__all__ = ['build', 'PROTOCOL', 'HOST_PROTOCOL', 'type_module', 'host_functions']

# The Warp functions every type provides, each taking (model, qp, qc, k, ...):
PROTOCOL = ('energy',                # constraint energy [J·s²] (no dt²)
            'gradients',             # (∇_P, ∇_C) of the energy
            'state_blocks',          # Gauss–Newton blocks of non-linear terms, and 1; or 0
            'gap',                   # largest constraint gap [m]
            'coordinate',            # x(q) from its value at t = 0 [rad | m], 0 if none
            'coordinate_gradients',  # (∇_P x, ∇_C x)
            'apply_command')         # add scale·a_ext of a torque or force to q̃; 1 if dropped
# ... and the host (NumPy) functions of its residuals, for the model build and the energy:
HOST_PROTOCOL = ('linear_pairs', 'nonlinear_residuals')


def type_module(kind):
    """The module of joint type ``kind`` (a JointKind), ``physics/joints/<kind.name>.py``."""
    return importlib.import_module(f'{__name__}.{kind.name}')


def host_functions(code: int):
    """The module of the type whose code is ``code`` (for its host functions)."""
    return type_module(JOINT_KINDS[code])


def build(t) -> SimpleNamespace:
    """Dispatching Warp functions over joint types for the types namespace ``t``."""
    vec12, mat12, scalar = t.vec12, t.mat12, t.scalar
    zero, two_pi = t.zero, t.two_pi
    alias_limit = scalar(0.9 * math.pi)   # |Δθ| per step [rad] beyond which angles alias
    Model, Scratch = t.structs.Model, t.structs.Scratch
    impls = [type_module(kind).build(t) for kind in JOINT_KINDS]
    codes = [kind.code for kind in JOINT_KINDS]
    count = len(JOINT_KINDS)

    def per_type(flags):
        """A Warp function (model, k) -> flags[i] of joint k's type i (0 for no type)."""
        @wp.func
        def flag(model: Model, k: int):
            kind = model.joint_type[k]
            out = int(0)
            for i in range(wp.static(count)):
                if kind == wp.static(codes[i]):
                    out = wp.static(flags[i])
            return out
        return flag

    # 1 if joint k's coordinate is an angle (a revolute joint's)
    joint_is_periodic = per_type([int(kind.periodic) for kind in JOINT_KINDS])
    # 1 if joint k's constraint is not linear in q (it has state blocks: a prismatic joint's)
    joint_is_nonlinear = per_type([int(not kind.linear) for kind in JOINT_KINDS])
    # 1 if joint k takes a torque or force command (a weld takes none)
    joint_takes_command = per_type([int(kind.command is not None) for kind in JOINT_KINDS])

    @wp.func
    def joint_energy(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Constraint energy of joint k (incremental-potential units, no dt²) [J·s²]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        out = zero
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                out = wp.static(impls[i].energy)(model, qp, qc, k)
        return out

    @wp.func
    def joint_gradients(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(∇_P, ∇_C) of joint k's constraint energy."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        g_parent = vec12()
        g_child = vec12()
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                g_parent, g_child = wp.static(impls[i].gradients)(model, qp, qc, k)
        return g_parent, g_child

    @wp.func
    def joint_state_blocks(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(H_PP, H_PC, H_CC, 1) of joint k's constraint terms that are not linear in q (the
        linear ones are in the model's constant blocks), or zeros and 0 when it has none."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        h_pp = mat12()
        h_pc = mat12()
        h_cc = mat12()
        has = int(0)
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                h_pp, h_pc, h_cc, has = wp.static(impls[i].state_blocks)(model, qp, qc, k)
        return h_pp, h_pc, h_cc, has

    @wp.func
    def joint_gap(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Largest constraint gap of joint k [m]."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        out = zero
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                out = wp.static(impls[i].gap)(model, qp, qc, k)
        return out

    @wp.func
    def joint_raw_coordinate(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """Coordinate of joint k as the state shows it, from its initial position x₀: x₀ + θ(q)
        with θ ∈ (−π, π] [rad], x₀ + d(q) [m] (θ and d are 0 at t = 0)."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        out = zero
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                out = wp.static(impls[i].coordinate)(model, qp, qc, k)
        return out + model.joint_initial_position[k]

    @wp.func
    def joint_increment(model: Model, k: int, raw: scalar, previous: scalar):
        """Δx from the last committed coordinate ``previous`` to the raw coordinate ``raw`` of
        joint k (``joint_raw_coordinate``); an angle's Δθ is taken in (−π, π] (multi-turn
        unwrap, docs/physics.md#joint-coordinate)."""
        delta = raw - previous
        if joint_is_periodic(model, k) == 1:
            delta = delta - two_pi * wp.round(delta / two_pi)
        return delta

    @wp.func
    def joint_coordinate_step(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int,
                              previous: scalar):
        """Δx from the last committed coordinate ``previous`` to the state q
        (``joint_increment``)."""
        return joint_increment(model, k, joint_raw_coordinate(model, q, env, k), previous)

    @wp.func
    def joint_step_aliases(model: Model, k: int, step: scalar):
        """1 if a coordinate increment ``step`` cannot be told from one a turn apart: an
        angle's Δθ beyond 0.9π (docs/physics.md#joint-coordinate)."""
        out = int(0)
        if joint_is_periodic(model, k) == 1 and wp.abs(step) > alias_limit:
            out = 1
        return out

    @wp.func
    def joint_coordinate_gradients(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(∇_P x, ∇_C x) of joint k's coordinate."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        g_parent = vec12()
        g_child = vec12()
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                g_parent, g_child = wp.static(impls[i].coordinate_gradients)(model, qp, qc, k)
        return g_parent, g_child

    @wp.func
    def joint_apply_command(model: Model, q: wp.array2d(dtype=vec12), scratch: Scratch,
                            env: int, k: int, command: scalar, scale: scalar):
        """Add scale·a_ext of joint k's command (torque [N·m] or force [N]) at the
        start-of-step state q to q̃. Returns 1 if a near-singular body dropped it."""
        qp = q[env, model.joint_parent[k]]
        qc = q[env, model.joint_child[k]]
        kind = model.joint_type[k]
        dropped = int(0)
        for i in range(wp.static(count)):
            if kind == wp.static(codes[i]):
                dropped = wp.static(impls[i].apply_command)(model, qp, qc, scratch, env, k,
                                                            command, scale)
        return dropped

    revolute = impls[[kind.name for kind in JOINT_KINDS].index('revolute')]

    @wp.func
    def revolute_alignment(model: Model, q: wp.array2d(dtype=vec12), env: int, k: int):
        """(c, s) of revolute joint k at q (its type's ``alignment``): θ = atan2(s, c)."""
        return wp.static(revolute.alignment)(model, q[env, model.joint_parent[k]],
                                             q[env, model.joint_child[k]], k)

    return SimpleNamespace(revolute_alignment=revolute_alignment,
                           joint_energy=joint_energy, joint_gradients=joint_gradients,
                           joint_state_blocks=joint_state_blocks, joint_gap=joint_gap,
                           joint_raw_coordinate=joint_raw_coordinate,
                           joint_increment=joint_increment,
                           joint_coordinate_step=joint_coordinate_step,
                           joint_step_aliases=joint_step_aliases,
                           joint_coordinate_gradients=joint_coordinate_gradients,
                           joint_takes_command=joint_takes_command,
                           joint_is_nonlinear=joint_is_nonlinear,
                           joint_apply_command=joint_apply_command)
