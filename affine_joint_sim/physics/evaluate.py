"""Stages of the step launched one at a time on one environment: for tests and tools.

``Stages(scene)`` evaluates the incremental potential, its gradient and Newton blocks, and the
tree solve at any state the caller gives, through the same Warp functions the step kernel runs.
States are NumPy (n_bodies, 12) arrays [m, -]; gradients and Hessians cover the free bodies'
DOFs in scene order (12 per free body).
"""

import numpy as np
import warp as wp

from affine_joint_sim.physics.host.fields import (allocate, array_sizes, device_model,
                                                  held_structs)
from affine_joint_sim.physics.kernels import scalar_of, step_kernels
from affine_joint_sim.physics.host.model import build_model

__all__ = ['CONTACT_STAGES', 'STAGE_NAMES', 'Stages', 'stage_timer']

_PROBES = {}
_TIMERS = {}

# The stages ``stage_timer`` runs, in its ``which`` order: the incremental potential, the
# assembly with and without the Hessian, the solve with and without factoring, and with
# contact the step bound, the near list's gathering and the smallest distance
CONTACT_STAGES = ('step bound', 'near list', 'distances')
STAGE_NAMES = ('energy', 'assembly', 'gradient', 'factor and solve', 'factored solve',
               *CONTACT_STAGES)


ENERGY, NEWTON_SYSTEM, COORDINATES, WARM_START, MOVED, STEP_BOUND = range(6)


def _groups(t):
    """The Model, State, Control and Scratch struct types of the namespace ``t``."""
    return t.structs.Model, t.structs.State, t.structs.Control, t.structs.Scratch


def _probe_kernel(t):
    """One kernel that launches the stage ``which`` (ENERGY, ...) for the types namespace ``t``
    (built once: one module to compile per precision, not one per stage)."""
    key = (t.name, t.bodies)
    if key in _PROBES:
        return _PROBES[key]
    Model, State, Control, Scratch = _groups(t)
    vec12, scalar = t.vec12, t.scalar
    incremental_potential, assemble, solve = t.incremental_potential, t.assemble, t.solve
    joint_raw_coordinate, joint_coordinate_gradients = (t.joint_raw_coordinate,
                                                        t.joint_coordinate_gradients)
    warm_start, moved, full_step, step_bound = t.warm_start, t.moved, t.full_step, t.step_bound
    cover, gather_near = t.cover, t.gather_near
    one, salt = t.one, t.source_salt

    @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
    def probe(model: Model, state: State, control: Control, q: wp.array2d(dtype=vec12),
              scratch: Scratch, which: int,
              energy_out: wp.array(dtype=scalar), coordinate_out: wp.array(dtype=scalar),
              parent_gradient_out: wp.array(dtype=vec12),
              child_gradient_out: wp.array(dtype=vec12), q_out: wp.array(dtype=vec12)):
        wp.static(salt)     # its sources' digest, in the module hash (kernel_math)
        if which == ENERGY or which == NEWTON_SYSTEM:   # the edge and face pairs near q
            for b in range(q.shape[1]):
                scratch.body_margin[0, b] = model.contact_d_hat
            cover(model, q, scratch, 0, 0)
            scratch.near_count[0] = gather_near(model, scratch, 0, 0)
        if which == ENERGY:
            energy_out[0] = incremental_potential(model, state, control, q, scratch, 0, one, 0)
        elif which == NEWTON_SYSTEM:
            assemble(model, state, control, q, scratch, 0, one, 0, 1)
            iterations, stalled = solve(model, scratch, 0)
            energy_out[0] = scalar(iterations)
        elif which == COORDINATES:
            for k in range(model.joint_parent.shape[0]):
                coordinate_out[k] = joint_raw_coordinate(model, q, 0, k)
                g_parent, g_child = joint_coordinate_gradients(model, q, 0, k)
                parent_gradient_out[k] = g_parent
                child_gradient_out[k] = g_child
        elif which == WARM_START:
            for b in range(q.shape[1]):
                q_out[b] = warm_start(q[0, b], scratch.q_n[0, b])
        elif which == STEP_BOUND:
            for b in range(q.shape[1]):
                scratch.q_start[0, b] = q[0, b]
            energy_out[0] = step_bound(model, scratch, 0)
        else:
            for b in range(q.shape[1]):
                scratch.q_start[0, b] = q[0, b]
                q_out[b] = moved(q[0, b], scratch.dq[0, b], one)
            energy_out[0] = full_step(model, scratch, 0)

    _PROBES[key] = probe
    return probe


def stage_timer(t):
    """A kernel that runs stage ``which`` (an index of STAGE_NAMES) ``reps`` times on every
    environment at the state it is given (state.q; the step bound along scratch.dq from
    scratch.q_start), for the step kernel's namespace ``t``: the launch's time over ``reps``
    is one call's. It overwrites the scratch a step rebuilds (the system, factors, near
    list); the contact stages are left out without contact. Built once per namespace."""
    key = (t.name, t.bodies, t.contact, t.shapes)
    if key in _TIMERS:
        return _TIMERS[key]
    Model, State, Control, Scratch = _groups(t)
    scalar, one = t.scalar, t.one
    incremental_potential, assemble, solve = t.incremental_potential, t.assemble, t.solve
    solve_factored = t.solve_factored
    contact, salt = t.contact, t.source_salt
    step_bound, gather_near, touching = t.step_bound, t.gather_near, t.touching

    @wp.kernel(module='unique', enable_backward=False, module_options=t.kernel_options)
    def repeat(model: Model, state: State, control: Control, scratch: Scratch, which: int,
               reps: int, out: wp.array(dtype=scalar)):
        wp.static(salt)     # its sources' digest, in the module hash (kernel_math)
        env = wp.tid()
        total = scalar(0.0)
        for r in range(reps):
            if which == 0:
                total += incremental_potential(model, state, control, state.q, scratch, env,
                                               one, 1)
            elif which == 1 or which == 2:
                total += scalar(assemble(model, state, control, state.q, scratch, env, one, 1,
                                         2 - which))
            elif which == 3:
                used, stalled = solve(model, scratch, env)
            elif which == 4:
                solve_factored(model, scratch, env)
            elif wp.static(contact):
                if which == 5:
                    total += step_bound(model, scratch, env)
                elif which == 6:
                    scratch.near_count[env] = wp.min(gather_near(model, scratch, env, 0),
                                                     scratch.near_pairs.shape[1])
                else:
                    nearest, active = touching(model, state.q, scratch, env, 0)
                    total += nearest
        out[env] = total

    _TIMERS[key] = repeat
    return repeat


class Stages:
    """One environment of ``scene`` whose stages can be evaluated at arbitrary states."""

    def __init__(self, scene, device: str = 'cpu'):
        self.host = build_model(scene)
        self.t = step_kernels(scalar_of(scene.solver.precision), self.host.has_body_pairs)
        self.device = device
        nb = self.host.body_count
        sizes = array_sizes(self.host, 1, near_room=self.host.pair_count)   # every pair
        self.model = device_model(self.t, self.t.structs.Model, self.host, device)
        self.state, self.control, self.scratch = (
            allocate(self.t, getattr(self.t.structs, group.capitalize()), group, sizes, device)
            for group in ('state', 'control', 'scratch'))
        self._held = held_structs(self.t, device, model=self.model, state=self.state,
                                  control=self.control, scratch=self.scratch)
        self.free = [b for b in range(nb) if not self.host.body_fixed[b]]
        nj = max(self.host.joint_count, 1)
        self._q = wp.zeros((1, nb), dtype=self.t.vec12, device=device)
        self._outputs = [wp.zeros(1, dtype=self.t.scalar, device=device),
                         wp.zeros(nj, dtype=self.t.scalar, device=device),
                         wp.zeros(nj, dtype=self.t.vec12, device=device),
                         wp.zeros(nj, dtype=self.t.vec12, device=device),
                         wp.zeros(nb, dtype=self.t.vec12, device=device)]
        self._probe = _probe_kernel(self.t)

    def set_joint_inputs(self, coordinate=None, coordinate_prev=None, target=None,
                         drive_enabled=None):
        """Per-joint inputs of the coordinate terms: the last committed coordinates x_n and
        x_{n−1} [rad | m], drive targets and drive switches (each (n_joints,), default 0)."""
        for array, value in ((self.state.joint_coordinate, coordinate),
                             (self.state.joint_coordinate_prev, coordinate_prev),
                             (self.control.joint_target, target),
                             (self.control.joint_drive_enabled, drive_enabled)):
            if value is not None:
                array.assign(np.asarray(value, dtype=array.numpy().dtype)[None])

    def _load(self, q, q_tilde):
        self._q.assign(np.asarray(q)[None])
        self.scratch.q_tilde.assign(np.asarray(q_tilde)[None])

    def _launch(self, which):
        wp.launch(self._probe, dim=1, inputs=[self.model, self.state, self.control, self._q,
                                              self.scratch, which, *self._outputs],
                  device=self.device)

    def energy(self, q, q_tilde) -> float:
        """E(q) against the prediction q_tilde (BDF1 scales) [J·s²]."""
        self._load(q, q_tilde)
        self._launch(ENERGY)
        return float(self._outputs[0].numpy()[0])

    def newton_system(self, q, q_tilde):
        """(∇E, dense ∇²E as assembled (PSD-projected), the Newton direction dq of the tree
        solve or, where contact couples bodies, of the coupled solve) over the free DOFs at
        q."""
        self._load(q, q_tilde)
        self._launch(NEWTON_SYSTEM)
        self.inner_iterations = int(self._outputs[0].numpy()[0])   # of the coupled solve
        rhs, blocks = self.scratch.rhs.numpy()[0], self.scratch.hessian.numpy()[0]
        offdiag = self.host.elim_offdiag
        if self.host.state_coupling:     # the blocks a state term touched this iteration
            touched = self.scratch.offdiag_set.numpy()[0] != 0
            offdiag = np.where(touched[:, None, None], self.scratch.offdiag.numpy()[0], offdiag)
        dq = self.scratch.dq.numpy()[0]
        index = {b: i for i, b in enumerate(self.free)}
        hessian = np.zeros((12 * len(self.free),) * 2)
        for b, i in index.items():
            hessian[12 * i:12 * i + 12, 12 * i:12 * i + 12] = blocks[b]
            p = self.host.elim_parent[b]
            if p >= 0:
                j, off = index[p], offdiag[b]
                hessian[12 * i:12 * i + 12, 12 * j:12 * j + 12] = off
                hessian[12 * j:12 * j + 12, 12 * i:12 * i + 12] = off.T
        used = self.scratch.block_used.numpy()[0]
        for j, block in enumerate(self.scratch.contact_block.numpy()[0]):
            if used[j]:
                a, c = index[self.host.touch_a[j]], index[self.host.touch_b[j]]
                hessian[12 * a:12 * a + 12, 12 * c:12 * c + 12] = block
                hessian[12 * c:12 * c + 12, 12 * a:12 * a + 12] = block.T
        gradient = -np.concatenate([rhs[b] for b in self.free])
        return gradient, hessian, np.concatenate([dq[b] for b in self.free])

    def joint_coordinates(self, q):
        """(raw coordinates θ(q) ∈ (−π, π] or d(q) [rad | m], ∇_P x, ∇_C x) of every joint at
        q, shapes (n_joints,), (n_joints, 12), (n_joints, 12)."""
        self._q.assign(np.asarray(q)[None])
        self._launch(COORDINATES)
        n = self.host.joint_count
        return tuple(a.numpy()[:n].copy() for a in self._outputs[1:4])

    def moved(self, q, dq):
        """(q + dq with every body's turn followed, the line search's full step α ≤ 1 for dq
        on the bodies whose turns the precision resolves)."""
        self._q.assign(np.asarray(q)[None])
        self.scratch.dq.assign(np.asarray(dq)[None])
        self._launch(MOVED)
        return self._outputs[4].numpy().copy(), float(self._outputs[0].numpy()[0])

    def step_bound(self, q, dq) -> float:
        """Contact's step bound: the largest α ≤ 1 keeping every contact point at least η of
        its gap along q + α dq."""
        self._q.assign(np.asarray(q)[None])
        self.scratch.dq.assign(np.asarray(dq)[None])
        self._launch(STEP_BOUND)
        return float(self._outputs[0].numpy()[0])

    def warm_start(self, q_tilde, q_n):
        """The Newton start of every body from the prediction q_tilde and the last state q_n."""
        self._q.assign(np.asarray(q_tilde)[None])
        self.scratch.q_n.assign(np.asarray(q_n)[None])
        self._launch(WARM_START)
        return self._outputs[4].numpy().copy()
