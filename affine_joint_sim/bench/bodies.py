"""``bench bodies``: free bodies touching each other, beside MuJoCo, and how the cost grows.

Scenes, float64 on one CPU core, default contact settings (d̂ 1 mm, κ 1e9, μ 0.5) and
integrator (BDF2): two 0.1 m boxes colliding in zero gravity (1 kg at 1 m/s against 2 kg at
−0.5 m/s, 3 cm off centre: the momentum error, against 0), three boxes stacked on the ground
(the top box's drift over 3 s, against 0), piles of N = 8, 27, 64 and 125 boxes (0.08 m, 0.5 kg)
dropped into a bin (ground and four static walls) settling over 2 s, and a two-finger gripper
lifting a 0.1 kg box 5 cm, squeezed with 1.5 N per finger (μ 0.5: 2 μ F > m g) at dt 1e-3
(the box's rise, against 0.05 m), and the shipped arm's grasp (``bench.grasp``: the
cube's slip in the hand over a 12 cm lift, against 0). With the extra ``compare``, MuJoCo
(default Euler, its default soft contact, μ of every geom 0.5) runs the collision, the stack
and the piles from the same boxes, and the arm's grasp from the same URDF.

Per scene: µs/step (mean; the piles' over their last second), Newton and inner (conjugate
gradient) iterations per step over the same steps, contacts at the end, the nearest distance
(ours must stay > 0; MuJoCo's deepest contact, negative where it penetrates) and the scene's
error. The cost's growth: the exponent of µs/step, and of µs per Newton iteration, against
the piles' contacts (least squares in log-log). Then where a step of the largest pile and of
the grasp goes (``bench.stages``). Writes bodies.md and bodies.csv.
"""

import math
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from affine_joint_sim.bench import grasp, stages
from affine_joint_sim.bench.report import Column, markdown_table, publish, times
from affine_joint_sim.bench.section import add_section

__all__ = ['FULL', 'QUICK', 'Settings', 'add_parser', 'box', 'collision_scene', 'gripper_scene',
           'pile_scene', 'run', 'stack_scene']

G = 9.81
MU = 0.5
PILE_SIDE = 0.08            # m: a pile box's side
GRIP_FORCE = 1.5            # N per finger
GRIP_MASS = 0.1             # kg: the gripped box


@dataclass(frozen=True)
class Settings:
    piles: tuple
    pile_duration: float     # s
    repeats: int
    profile_steps: int       # steps timed and counted for the stage profile (bench.stages)
    profile_calls: int       # calls of a stage per timed launch there


FULL = Settings((8, 27, 64, 125), 2.0, 3, 50, 200)
QUICK = Settings((8,), 0.6, 1, 10, 20)


def box(name: str, position, size: float = 0.1, mass: float = 1.0, velocity=(0.0, 0.0, 0.0),
        rpy=(0.0, 0.0, 0.0), fixed: bool = False, half=None) -> dict:
    """A scene body: a box of side ``size`` (or half sides ``half``) [m] touching with it."""
    sides = [2.0 * h for h in half] if half is not None else [size] * 3
    return {'name': name, 'mass': mass, 'shape': {'box': sides}, 'position': list(position),
            'orientation': {'rpy': [float(a) for a in rpy]}, 'collision': 'shape',
            'fixed': fixed, 'linear_velocity': list(velocity)}


def collision_scene() -> dict:
    """Two free boxes colliding off centre in zero gravity, dt 0.01."""
    return {'dt': 0.01, 'gravity': [0.0, 0.0, 0.0], 'contact': {'friction': MU},
            'bodies': [box('a', (-0.2, 0.0, 0.0), velocity=(1.0, 0.0, 0.0)),
                       box('b', (0.2, 0.0, 0.03), mass=2.0, velocity=(-0.5, 0.0, 0.0))]}


def stack_scene(count: int = 3) -> dict:
    """``count`` 0.1 m boxes stacked on the ground, 0.5 mm apart, dt 0.01."""
    return {'dt': 0.01, 'ground': {'height': 0.0}, 'contact': {'friction': MU},
            'bodies': [box(f'box{k}', (0.0, 0.0, 0.05 + k * 0.1005 + 0.0005))
                       for k in range(count)]}


def pile_scene(count: int, dt: float = 0.005) -> dict:
    """``count`` (a cube: 8, 27, 64) boxes in a jittered grid above a bin of four static walls
    on the ground (the bin 5 cm wider than the grid on each side), each shifted and turned by
    seeded random amounts so that they tumble into a pile, dt ``dt``; Newton may take 64
    iterations (about 30 while many boxes land at once)."""
    side = round(count ** (1.0 / 3.0))
    rng = np.random.default_rng(count)
    pitch = 0.13
    inner = 0.5 * side * pitch + 0.05
    walls = [box(f'wall{k}', (sx * (inner + 0.01), sy * (inner + 0.01), 0.15), fixed=True,
                 half=(0.01 if sx else inner + 0.02, 0.01 if sy else inner + 0.02, 0.15))
             for k, (sx, sy) in enumerate(((-1, 0), (1, 0), (0, -1), (0, 1)))]
    start = -0.5 * pitch * (side - 1)
    boxes = [box(f'box{i}_{j}_{k}', (start + i * pitch + rng.uniform(-0.01, 0.01),
                                     start + j * pitch + rng.uniform(-0.01, 0.01),
                                     0.06 + k * 0.13), size=PILE_SIDE, mass=0.5,
                 rpy=(rng.uniform(-0.15, 0.15), rng.uniform(-0.15, 0.15),
                      rng.uniform(-0.4, 0.4)))
             for k in range(side) for j in range(side) for i in range(side)]
    return {'dt': dt, 'ground': {'height': 0.0}, 'contact': {'friction': MU},
            'solver': {'newton_max_iter': 64}, 'bodies': walls + boxes}


def gripper_scene(force: float = GRIP_FORCE, dt: float = 1e-3) -> dict:
    """A hand on a vertical prismatic lift (a drive, joint ``lift``) with two prismatic
    fingers (``left_slide``, ``right_slide``) squeezing a 4 cm box of GRIP_MASS that rests on
    the ground, each with ``force`` [N]; μ 0.5. Bodies: base, hand, left, right, object."""
    finger = {'mass': 0.05, 'shape': {'box': [0.01, 0.03, 0.03]}, 'collision': 'shape'}
    reach = 0.02 + 0.005 + 0.0008          # the box's half side, a finger's, a gap
    bodies = [{'name': 'base', 'fixed': True, 'mass': 1.0, 'shape': {'box': [0.05] * 3},
               'position': [0.0, 0.0, 1.0]},
              {'name': 'hand', 'mass': 0.5, 'shape': {'box': [0.12, 0.04, 0.02]},
               'position': [0.0, 0.0, 0.07]},
              {'name': 'left', 'position': [-reach, 0.0, 0.03], **finger},
              {'name': 'right', 'position': [reach, 0.0, 0.03], **finger},
              box('object', (0.0, 0.0, 0.0206), size=0.04, mass=GRIP_MASS)]
    joints = [{'name': 'lift', 'type': 'prismatic', 'parent': 'base', 'child': 'hand',
               'x0': [0.0, 0.0, 0.07], 'x1': [0.0, 0.0, 0.17], 'drive': {'target': 0.0}},
              {'name': 'left_slide', 'type': 'prismatic', 'parent': 'hand', 'child': 'left',
               'x0': [-reach, 0.0, 0.03], 'x1': [1.0 - reach, 0.0, 0.03], 'torque': force},
              {'name': 'right_slide', 'type': 'prismatic', 'parent': 'hand', 'child': 'right',
               'x0': [reach, 0.0, 0.03], 'x1': [reach - 1.0, 0.0, 0.03], 'torque': force}]
    return {'dt': dt, 'ground': {'height': 0.0}, 'contact': {'friction': MU},
            'bodies': bodies, 'joints': joints}


def lift_target(t: float) -> float:
    """The gripper's lift target [m] at time t [s]: 0 for 0.2 s (squeezing), then up 5 cm
    over 0.5 s."""
    return 0.05 * min(max((t - 0.2) / 0.5, 0.0), 1.0)


def _momentum(masses, velocities) -> np.ndarray:
    return (np.asarray(masses)[:, None] * np.asarray(velocities)[:, :3]).sum(axis=0)


def _ours(name: str, spec: dict, duration: float, timed_from: float) -> dict:
    """Run a scene for ``duration`` [s]: µs/step over the steps after ``timed_from`` [s],
    iterations over the same steps, contacts, nearest distance and the scene's quantity."""
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(Scene.from_dict(spec))
    masses = [body['mass'] for body in spec['bodies']]
    steps = int(round(duration / spec['dt']))
    start_q, start_p = sim.body_q.copy(), _momentum(masses, sim.body_qdot)
    times, newton, inner, nearest, drift = [], [], [], math.inf, 0.0
    for k in range(steps):
        if name == 'gripper':
            sim.set_target('lift', lift_target(k * spec['dt']))
        began = time.perf_counter()
        sim.step()
        elapsed = time.perf_counter() - began
        stats = sim.stats
        if k * spec['dt'] >= timed_from:     # the iterations over the steps timed
            times.append(elapsed)
            newton.append(stats['newton_iterations'])
            inner.append(stats['inner_iterations'])
        nearest = min(nearest, stats['min_distance'])
        drift = max(drift, float(np.abs(_momentum(masses, sim.body_qdot) - start_p).max()))
    q = sim.body_q
    error = {'collision': drift,
             'stack': float(np.hypot(*(q[-1, :2] - start_q[-1, :2]))),
             'gripper': abs(q[-1, 2] - start_q[-1, 2] - 0.05)}.get(name.split()[0])
    return {'us_per_step': 1e6 * float(np.mean(times)), 'newton': float(np.mean(newton)),
            'inner': float(np.mean(inner)), 'contacts': stats['contacts'],
            'min_distance': nearest, 'error': error}


def _mjcf(spec: dict) -> str:
    """The boxes of a scene in MJCF: free boxes with a free joint, fixed ones as world geoms,
    the ground a plane; every geom μ 0.5."""
    friction = f'friction="{MU} 0.005 0.0001"'
    parts = []
    for body in spec['bodies']:
        half = ' '.join(repr(0.5 * s) for s in body['shape']['box'])
        pos = ' '.join(map(repr, body['position']))
        turn = ' '.join(map(repr, body['orientation']['rpy']))      # fixed-axis x, y, z
        geom = f'<geom type="box" size="{half}" {friction} mass="{body["mass"]}"/>'
        if body.get('fixed'):
            parts.append(f'<geom type="box" size="{half}" pos="{pos}" euler="{turn}" '
                         f'{friction}/>')
        else:
            parts.append(f'<body name="{body["name"]}" pos="{pos}" euler="{turn}">'
                         f'<freejoint/>{geom}</body>')
    if 'ground' in spec:
        parts.insert(0, f'<geom type="plane" size="0 0 1" {friction}/>')
    gravity = ' '.join(map(repr, spec.get('gravity', [0.0, 0.0, -G])))
    return (f'<mujoco><compiler angle="radian" eulerseq="XYZ"/><option timestep="{spec["dt"]!r}" '
            f'gravity="{gravity}"/><worldbody>{"".join(parts)}</worldbody></mujoco>')


def _mujoco(name: str, spec: dict, duration: float, timed_from: float) -> dict:
    """The same boxes in MuJoCo: µs/step, deepest contact distance, the scene's error."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(_mjcf(spec))
    data = mujoco.MjData(model)
    free = [b for b in spec['bodies'] if not b.get('fixed')]
    for k, body in enumerate(free):
        data.qvel[6 * k:6 * k + 3] = body.get('linear_velocity', [0.0, 0.0, 0.0])
    masses = [b['mass'] for b in free]
    start_p = _momentum(masses, data.qvel.reshape(-1, 6))
    start_xy = data.qpos.reshape(-1, 7)[-1, :2].copy()
    steps = int(round(duration / spec['dt']))
    times, deepest, drift = [], math.inf, 0.0
    for k in range(steps):
        began = time.perf_counter()
        mujoco.mj_step(model, data)
        if k * spec['dt'] >= timed_from:
            times.append(time.perf_counter() - began)
        if data.ncon:
            deepest = min(deepest, float(data.contact.dist[:data.ncon].min()))
        drift = max(drift, float(np.abs(_momentum(masses, data.qvel.reshape(-1, 6))
                                        - start_p).max()))
    error = {'collision': drift,
             'stack': float(np.hypot(*(data.qpos.reshape(-1, 7)[-1, :2] - start_xy)))
             }.get(name.split()[0])
    return {'mujoco_us': 1e6 * float(np.mean(times)), 'mujoco_contacts': int(data.ncon),
            'mujoco_min_distance': deepest, 'mujoco_error': error}


def _cases(settings: Settings) -> list[tuple]:
    """(name, scene, duration [s], timed from [s], quantity) of every scene."""
    cases = [('collision', collision_scene(), 1.0, 0.0, 'momentum error [kg·m/s]'),
             ('stack of 3', stack_scene(), 3.0, 0.0, 'top drift [m]')]
    cases += [(f'pile of {n}', pile_scene(n), settings.pile_duration,
               settings.pile_duration / 2.0, '—') for n in settings.piles]
    cases.append(('gripper', gripper_scene(), 1.0, 0.0, 'rise error [m]'))
    return cases


COLUMNS = [
    Column('scene', 'scene'),
    Column('dt', 'dt [s]', '{:g}'),
    Column('us_per_step', 'µs/step', '{:.0f}'),
    Column('realtime', '× real time', '{:.1f}'),
    Column('mujoco_us', 'MuJoCo µs', '{:.0f}'),
    Column('vs_mujoco', '× MuJoCo', '{:.1f}'),
    Column('newton', 'Newton it.', '{:.2f}'),
    Column('inner', 'inner it.', '{:.1f}'),
    Column('contacts', 'contacts'),
    Column('mujoco_contacts', 'MuJoCo contacts'),
    Column('min_distance', 'nearest [m]', '{:.1e}'),
    Column('mujoco_min_distance', 'MuJoCo [m]', '{:.1e}'),
    Column('quantity', 'quantity'),
    Column('error', 'error', '{:.1e}'),
    Column('mujoco_error', 'MuJoCo error', '{:.1e}'),
]


def _arm_grasp(repeats: int, peer: bool) -> dict:
    """The row of the shipped arm's grasp (``bench.grasp``): medians of ``repeats`` runs."""
    runs = [grasp.ours() for _ in range(repeats)]
    row = dict(runs[-1], us_per_step=statistics.median(r['us_per_step'] for r in runs),
               scene='arm6_gripper grasp',
               quantity=f'slip over a {runs[-1]["lift"]:.3f} m lift [m]',
               mujoco_us=None, mujoco_contacts=None, mujoco_min_distance=None,
               mujoco_error=None)
    row['realtime'] = row['dt'] / (1e-6 * row['us_per_step'])
    if peer:
        theirs = [grasp.mujoco() for _ in range(repeats)]
        row.update(theirs[-1], mujoco_us=statistics.median(r['mujoco_us'] for r in theirs))
        row['quantity'] += f' (MuJoCo lifts it {row.pop("mujoco_lift"):.3f} m)'
    row.pop('lift')
    return row


def growth(rows: list[dict], per_iteration: bool = False) -> float | None:
    """The exponent k of µs/step ∝ contacts^k over the piles (least squares in log-log), or
    with ``per_iteration`` of µs per Newton iteration; None with fewer than two piles."""
    piles = [r for r in rows if r['scene'].startswith('pile')]
    if len(piles) < 2:
        return None
    cost = [r['us_per_step'] / (r['newton'] if per_iteration else 1.0) for r in piles]
    return float(np.polyfit(np.log([r['contacts'] for r in piles]), np.log(cost), 1)[0])


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Measure every scene (CPU only: ``devices`` is not used), write bodies.md and
    bodies.csv, print the table and the cost's growth."""
    from affine_joint_sim.bench import mujoco_urdf

    peer = mujoco_urdf.available()
    rows = []
    for name, spec, duration, timed_from, quantity in _cases(settings):
        runs = [_ours(name, spec, duration, timed_from) for _ in range(settings.repeats)]
        row = dict(runs[-1], us_per_step=statistics.median(r['us_per_step'] for r in runs),
                   scene=name, dt=spec['dt'], quantity=quantity)
        row['realtime'] = spec['dt'] / (1e-6 * row['us_per_step'])
        row.update(mujoco_us=None, mujoco_contacts=None, mujoco_min_distance=None,
                   mujoco_error=None)
        if peer and name != 'gripper':
            theirs = [_mujoco(name, spec, duration, timed_from) for _ in range(settings.repeats)]
            row.update(theirs[-1], mujoco_us=statistics.median(r['mujoco_us'] for r in theirs))
        rows.append(row)
    rows.append(_arm_grasp(settings.repeats, peer))
    for row in rows:
        row['vs_mujoco'] = times(row['us_per_step'], row['mujoco_us'])
    fit = growth(rows)
    text = ('## Bodies touching each other: float64, one CPU core\n\n'
            + ('' if peer else "MuJoCo is not installed (extra 'compare'): no MuJoCo "
               'columns.\n\n')
            + f'µs and iterations: means over the steps (the piles: over their last '
            f'{settings.pile_duration / 2:g} s), µs the median of {settings.repeats} runs. '
            'Contacts at the end: ours counts primitive pairs closer than d̂ (a face on a face is '
            "several point–face and edge–edge pairs), MuJoCo's its contacts. Nearest: the "
            'smallest distance of any pair over the run (ours, > 0: nothing penetrated) or the '
            "deepest contact (MuJoCo's; negative: penetration).\n\n"
            + markdown_table(rows, COLUMNS) + '\n')
    if fit is not None:
        text += (f'\nCost growth over the piles: µs/step ∝ contacts^{fit:.2f}, µs per Newton '
                 f'iteration ∝ contacts^{growth(rows, per_iteration=True):.2f} (least squares '
                 f'in log-log over {len(settings.piles)} piles).\n')
    profiled = stages.profile_rows((f'pile of {max(settings.piles)}', 'arm6_gripper grasp'),
                                   settings.profile_steps, settings.profile_calls)
    text += ('\n### Where a step goes (the largest pile and the grasp)\n\n'
             + stages.profile_text(profiled))
    publish(results, 'bodies', text, rows)


def add_parser(sections) -> None:
    add_section(
        sections, 'bodies', run, FULL, QUICK,
        help='bodies touching each other: a collision, a stack, piles and a grasp',
        description='Run two boxes colliding, a stack of three, piles of boxes settling in a '
                    'bin and a gripper lifting a box, beside MuJoCo (extra compare); write '
                    'bodies.md and bodies.csv into --results.',
        quick_help=f'piles of {", ".join(map(str, QUICK.piles))} boxes, '
                   f'{QUICK.pile_duration:g} s, {QUICK.repeats} run')
