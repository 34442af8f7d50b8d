"""The near list (README.md#contact): the pairs a step evaluates, stored with their lagged
values for the listed pairs only, in a room that grows when a step needs more. A step whose list
outgrew its room is taken again with the bits it would have had with the room from the start
(outgrown at the step's start and in Newton's search, with contact damping on and off; in a
batch, only the environments whose list outgrew the room, each its own way); the list
is ascending and holds every pair closer than d̂ (the host's geometry, pair by pair); the
distance kept beside a pair less its bodies' drift bounds its distance from below; a pile of
64 boxes settles in its first room, whose lagged state stays below 200 KB in float32."""

import numpy as np
import pytest
import warp as wp

from affine_joint_sim.bench.bodies import pile_scene
from affine_joint_sim.physics.contact.pairs import near_pairs, pair_gap
from affine_joint_sim.physics.contact.terms import DRIFT_SLACK
from affine_joint_sim.physics.host.fields import FIELDS, array_sizes
from affine_joint_sim.physics.host.model import HostModel, build_model
from affine_joint_sim.physics.kernels import scalar_of, step_kernels
from affine_joint_sim.scene import Scene
from affine_joint_sim.stepper import Stepper

STEPS = 40      # the pile's boxes land in steps 9–31: its list grows seven times from 4 pairs


def _pile(damping: float | None = None) -> Scene:
    scene = Scene.from_dict(pile_scene(27))
    if damping is None:
        return scene
    return scene.model_copy(update={'contact': scene.contact.model_copy(
        update={'damping': damping})})


def _lift(sim, env=0):
    """The pile's last box 3 m up in environment ``env``: it lands later, so that this
    environment's lists outgrow their room in other steps."""
    pose = np.eye(4)
    pose[:3, 3] = [0.0, 0.0, 3.0]
    sim.set_body_state(sim.body_names[-1], pose, env=env)


def _run(scene, steps=STEPS, lifted=False, **options):
    sim = Stepper(scene, **options)
    if lifted:
        _lift(sim, env=options.get('num_envs', 1) - 1)
    rooms, qs = {sim.near_room}, []
    for _ in range(steps):
        sim.step()
        qs.append(sim.body_q.copy())
        rooms.add(sim.near_room)
    return np.array(qs), sorted(rooms), sim


@pytest.mark.parametrize('damping', [None, 0.0])
def test_a_step_taken_again_with_more_room_has_the_same_bits(monkeypatch, damping):
    scene = _pile(damping)
    wide, wide_rooms, _ = _run(scene)
    monkeypatch.setattr(HostModel, 'near_room', property(lambda self: 4))
    grown, rooms, sim = _run(scene)
    assert len(rooms) > 4 and rooms[0] == 4 and len(wide_rooms) == 1
    assert sim.problem_totals == dict.fromkeys(sim.problem_totals, 0)
    np.testing.assert_array_equal(grown, wide)


def test_the_list_is_ascending_and_holds_every_pair_closer_than_d_hat():
    qs, rooms, sim = _run(_pile(), steps=30)
    scratch, host = sim._scratch, sim._host
    listed = scratch.near_pairs.numpy()[0, :scratch.near_count.numpy()[0]]
    assert np.all(np.diff(listed) > 0)
    q_n = scratch.q_n.numpy()[0].astype(np.float64)
    model = vars(host)
    close = [int(p) for p in near_pairs(model, q_n, host.contact_d_hat)
             if pair_gap(model, q_n, int(p)).distance < host.contact_d_hat]
    assert len(close) > 20
    assert set(close) <= set(listed.tolist())
    # the lagged forces sit beside their pairs: on those closer than d̂ only, most of them
    lagged = scratch.friction_normal.numpy()[0, :len(listed)]
    near = np.isin(listed, close)
    assert np.all(lagged[~near] == 0.0) and np.count_nonzero(lagged[near]) > len(close) // 2


def test_a_listed_pair_is_skipped_only_where_it_is_beyond_d_hat():
    """What lets a pass skip a listed pair (docs/architecture.md, "Passes that skip what is
    surely far"): its distance at q_n kept beside it (the host's geometry) and each body's
    drift, which bounds how far its contact points moved since, so that the kept distance
    less both drifts is a lower bound of the distance at q; landing boxes give both pairs
    that the bound clears of d̂ and pairs it does not."""
    qs, rooms, sim = _run(_pile(), steps=30)
    scratch, host = sim._scratch, sim._host
    model = vars(host)
    count = scratch.near_count.numpy()[0]
    listed = scratch.near_pairs.numpy()[0, :count]
    kept = scratch.gap_n.numpy()[0, :count]
    drift = scratch.body_drift.numpy()[0]       # the statistics' pass: at q, from q_n
    q_n = scratch.q_n.numpy()[0].astype(np.float64)
    q = sim.body_q.astype(np.float64)
    assert np.count_nonzero(kept) > count // 2      # 0: listed since the lag (unknown)
    moved = np.linalg.norm(
        [q[b, :3] + q[b, 3:].reshape(3, 3) @ x - q_n[b, :3] - q_n[b, 3:].reshape(3, 3) @ x
         for b, x in zip(host.point_body, host.point_rest)], axis=1)
    assert np.all(moved <= drift[host.point_body] * (1 + 1e-9)) and moved.max() > 1e-4
    cleared = 0
    for p, d_n in zip(listed.tolist(), kept):
        if d_n == 0.0:
            continue
        at_n, at_q = pair_gap(model, q_n, p), pair_gap(model, q, p)
        assert d_n == pytest.approx(at_n.distance, rel=1e-9, abs=1e-12)
        bound = d_n - drift[at_q.body] - (0.0 if at_q.other is None else drift[at_q.other])
        assert at_q.distance >= bound - 1e-12
        cleared += bound > host.contact_d_hat * (1 + DRIFT_SLACK)
    assert 0 < cleared < np.count_nonzero(kept)


def test_a_pile_of_64_settles_in_its_first_room_below_200_kb_in_float32():
    scene = Scene.from_dict(pile_scene(64))
    qs, rooms, sim = _run(scene, steps=200)      # 1 s: the boxes land and settle
    assert rooms == [sim._host.near_room]
    host = build_model(scene)
    t = step_kernels(scalar_of('float32'), host.has_body_pairs)
    sizes = array_sizes(host, 1)
    size = {'scalar': wp.types.type_size_in_bytes(t.scalar), 'int32': 4}
    listed = sum(sizes['near'] * size[f.dtype] for f in FIELDS if 'near' in f.shape)
    assert listed < 200_000
    dense = sum(host.pair_count * size[f.dtype] for f in FIELDS if 'near' in f.shape)
    assert dense > 50 * listed      # the same state stored for every pair


def test_only_the_environments_whose_list_outgrew_its_room_are_taken_again(monkeypatch):
    scene = _pile()
    alone, lifted = _run(scene)[0], _run(scene, lifted=True)[0]
    monkeypatch.setattr(HostModel, 'near_room', property(lambda self: 4))
    both, rooms, sim = _run(scene, lifted=True, num_envs=2, threads=2)
    assert len(rooms) > 4
    np.testing.assert_array_equal(both[:, 0], alone)
    np.testing.assert_array_equal(both[:, 1], lifted)
    assert not np.array_equal(alone, lifted)
