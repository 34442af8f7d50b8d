"""Explicit joint commands into the prediction q̃ (docs/physics.md#explicit-commands).

A command is evaluated once at the start-of-step state q_n and enters only through q̃:
q̃ += scale·a_ext with scale = dt² (BDF1) or 4/9 dt² (BDF2).
"""

from types import SimpleNamespace

import warp as wp

__all__ = ['build']


def build(t) -> SimpleNamespace:
    """Warp functions of the command stage for the types namespace ``t``."""
    scalar, zero = t.scalar, t.zero
    Model, State, Control, Scratch = (t.structs.Model, t.structs.State, t.structs.Control,
                                      t.structs.Scratch)
    joint_takes_command, joint_apply_command = t.joint_takes_command, t.joint_apply_command

    @wp.func
    def apply_commands(model: Model, state: State, control: Control, scratch: Scratch,
                       env: int, scale: scalar):
        """Add scale·a_ext of every enabled joint's command to q̃; write efforts [N·m | N]
        (0 for disabled and fixed joints).

        Returns 1 if a near-singular body dropped a command."""
        dropped = int(0)
        for k in range(model.joint_parent.shape[0]):
            tau = control.joint_torque[env, k]
            if control.joint_enabled[env, k] == 0 or joint_takes_command(model, k) == 0:
                state.joint_effort[env, k] = zero
                continue
            state.joint_effort[env, k] = tau
            if tau == zero:
                continue
            # state.q is still q_n for every body, fixed ones included
            dropped = dropped | joint_apply_command(model, state.q, scratch, env, k, tau, scale)
        return dropped

    return SimpleNamespace(apply_commands=apply_commands)
