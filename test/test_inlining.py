"""The step kernels as a GPU compile sees them (bench.inlining): the call tree expanded the way
NVVM inlines it, counted on small functions by hand, and bounded on every variant a Stepper can
load, so that the blow-up that kept the CUDA build from finishing cannot come back unnoticed."""

import warp as wp

from affine_joint_sim.bench.inlining import compiled, copies_of, expand
from affine_joint_sim.bench.device_check import step_variants

FLAG = True


@wp.func
def leaf(x: float):
    y = x * 2.0
    return y + 1.0


@wp.func
def looped(x: float):
    s = float(0.0)
    for _ in range(3):          # unrolled by Warp: three copies of leaf
        s += leaf(x)
    for i in range(3):          # a loop with a break stays a loop: one copy
        if i == 2:
            break
        s += leaf(x)
    for _ in range(20):         # longer than Warp's max_unroll: one copy
        s += leaf(x)
    return s


@wp.func(inline=False)
def apart(x: float):
    return looped(x) + leaf(x)


@wp.func
def top(x: float):
    if wp.static(FLAG):
        x = looped(x)
    else:
        x = leaf(x) + leaf(x) + leaf(x)
    return apart(x) + apart(x)


@wp.func
def other_leaf(x: float):
    return x - 1.0


KINDS = (leaf, other_leaf)


@wp.func
def dispatch(kind: int, x: float):
    out = float(0.0)
    for i in range(wp.static(len(KINDS))):      # unrolled: each kind's function once
        if kind == i:
            out = wp.static(KINDS[i])(x)
    return out


def test_a_dispatcher_over_kinds_reaches_each_kind_once():
    unit = expand(dispatch)
    assert unit.copies[leaf.key] == 1 and unit.copies[other_leaf.key] == 1
    # its own 3 (out, the loop, return) + the loop body's 2 twice, leaf's 2 and other_leaf's 1
    assert unit.statements == 3 + 2 * 2 + 2 + 1


def test_copies_follow_call_sites_unrolled_loops_static_branches_and_out_of_line_calls():
    assert expand(leaf).statements == 2 and not expand(leaf).copies
    inner = expand(looped)
    assert inner.copies[leaf.key] == 3 + 1 + 1
    # its own 12 (the unrolled loop body thrice) and five copies of leaf's 2
    assert inner.statements == 12 + 5 * 2
    # the wp.static branch taken alone; apart's body is compiled once on its own
    outer = expand(top)
    assert outer.copies[looped.key] == 1 and outer.copies[apart.key] == 2
    assert outer.copies[leaf.key] == 5
    units = compiled(top)
    assert set(units) == {top.key, apart.key}
    assert units[apart.key].copies[leaf.key] == 6
    # what marking looped out of line would give
    assert compiled(top, frozenset({looped.key}))[top.key].copies[leaf.key] == 0


# The largest function a GPU compile optimises at once, per kind of contact (statements after
# inlining, the joint types' dispatchers followed; copies of the distance of a pair in any one
# function compiled): measured 2026-12-05 at 1,656 (none: the assembly), 1,845 (half-spaces),
# 2,001 (world) and 2,267 (bodies: the step kernel itself), the stages out of line
# (physics.stages.out_of_line); the step kernel with contact was 33,264 statements with 62 copies
# (64,008 and 83 with pairs of bodies; dispatchers not followed), and 5,525 before contact
# existed, when NVRTC took 25–60 s.
BOUNDS = {'none': (1_800, 0), 'half-spaces': (2_100, 1), 'world': (2_300, 1),
          'bodies': (2_700, 1)}


def test_no_gpu_step_kernel_inlines_more_than_its_bound():
    for precision, contact, t in step_variants():
        statements, copies = BOUNDS[contact]
        for key, unit in compiled(t.step).items():
            assert unit.statements <= statements, (precision, contact, key)
            assert copies_of(unit, 'pair_gap') <= copies, (precision, contact, key)
