"""``bench contact``: ground contact against closed forms, beside MuJoCo, and what it costs.

Six scenes, each at several dt, float64 on one CPU core, one environment, default contact
settings (d̂ 1 mm, κ 1e9, ε_v 1 mm/s) and the default integrator (BDF2): a 1 kg, 0.1 m box resting
on the ground (its gap, against rigid contact's 0), the box slipping down a 20° incline at μ
0.2 (its acceleration against g (sin α − μ cos α)), sticking on it at μ 0.5 (its creep speed
against 0; ours creeps at ε_v (1 − √(1 − tan α / μ)) by design), stopping on flat ground from
2 m/s at μ 0.4 (its stopping distance against v0² / (2 μ g)), a solid 1 kg ball of radius
5 cm rolling down the incline at μ 0.5 (its acceleration against (5/7) g sin α, and its spin
ω r / v against 1), and the shipped quadruped standing under a PD law computed in Python each
step (its trunk height; no closed form). With the extra ``compare``, MuJoCo (default Euler)
runs the same scenes in MJCF: same masses, sizes and μ (MuJoCo combines the two geoms' μ by
max, ours by 2 μa μb / (μa + μb): both geoms get the scene's μ, so both pairs have it) and
the quadruped from the same URDF (``mujoco.MjSpec``, with a free base and a floor).

Per scene and dt: µs/step, Newton iterations, unconverged and rejected steps, the quantity
and its error, the nearest distance to the ground (ours must stay > 0; MuJoCo's is negative
where it penetrates) and its spread over the run's last quarter (a body still bouncing or
rocking on the ground). Speed ratios: a box far above the ground with contact against the
same box without it, a box resting against the same box falling freely, and the quadruped's
real-time factor. Writes contact.md, contact.csv, contact_ratios.csv and contact.png (error
against µs/step, one panel per scene).
"""

import math
import statistics
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from affine_joint_sim.bench import stages
from affine_joint_sim.bench.report import Column, markdown_table, publish, times, write_csv
from affine_joint_sim.bench.section import add_section

__all__ = ['CASES', 'FULL', 'QUICK', 'Settings', 'add_parser', 'measure', 'ratios', 'run']

G = 9.81                     # m/s²
TILT = math.radians(20.0)    # rad, the incline
HALF = 0.05                  # m: half the box's side, the ball's radius
EPS_VELOCITY = 1.0e-3        # m/s: contact.eps_velocity's default
REST_GAP = 6.39e-4           # m: a 1 kg box's rest on four corners (d̂ 1 mm, κ 1e9; README)
DROP = 2.0e-3                # m: the resting box starts this far above the ground
FAR = 200.0                  # m: the box that never touches starts this far above it
                             # (it falls 123 m in TIMED_STEPS of 0.01 s)
V0 = 2.0                     # m/s: the stopping box's start speed
KP, KD = 100.0, 10.0         # N·m/rad, N·m·s/rad: the quadruped's PD gains
STAND = {'hip': 0.0, 'thigh': 0.7, 'knee': -1.4}     # rad: its standing pose
TIMED_STEPS = 500            # steps per timed run at most
NORMAL = np.array([math.sin(TILT), 0.0, math.cos(TILT)])     # the incline's normal
DOWN = np.array([math.cos(TILT), 0.0, -math.sin(TILT)])      # down its slope


class Settings(NamedTuple):
    dts: tuple            # s, the box and ball scenes
    robot_dts: tuple      # s, the quadruped (its speed ratio is read at 1e-3)
    duration: float       # s per run (at least 0.55: the stopping box stops after 0.51 s)
    repeats: int          # timed runs (median reported)
    profile_steps: int    # steps timed and counted for the quadruped's stage profile
    profile_calls: int    # calls of a stage per timed launch there (bench.stages)


FULL = Settings((1e-2, 5e-3, 2e-3, 1e-3), (1e-2, 5e-3, 2e-3, 1e-3), 2.0, 5, 50, 200)
QUICK = Settings((1e-2,), (1e-3,), 0.6, 1, 10, 20)


class Slab(NamedTuple):
    """A 1 kg box (or solid ball) started ``gap`` [m] above a flat or tilted ground (normal
    ``NORMAL`` when ``tilt``; gap None: resting on it, ours REST_GAP up, MuJoCo's touching),
    at ``speed`` [m/s] along x, with Coulomb ``mu`` on both surfaces."""

    shape: str            # 'box' or 'ball'
    tilt: bool
    mu: float
    gap: float | None = None
    speed: float = 0.0

    def scene_dict(self, dt: float, contact: bool = True) -> dict:
        """Our scene (without ``ground`` and ``contact`` when not ``contact``)."""
        normal = NORMAL if self.tilt else np.array([0.0, 0.0, 1.0])
        body = {'name': 'body', 'mass': 1.0, 'collision': 'shape',
                'shape': ({'box': [2 * HALF] * 3} if self.shape == 'box'
                          else {'sphere': {'radius': HALF}}),
                'position': ((HALF + (REST_GAP if self.gap is None else self.gap))
                             * normal).tolist(),
                'orientation': {'rpy': [0.0, TILT if self.tilt else 0.0, 0.0]},
                'linear_velocity': [self.speed, 0.0, 0.0]}
        scene = {'dt': dt, 'bodies': [body]}
        if contact:
            scene['ground'] = {'point': [0.0, 0.0, 0.0], 'normal': normal.tolist()}
            scene['contact'] = {'friction': self.mu}
        return scene

    def mjcf(self, dt: float) -> str:
        """The same in MJCF (MuJoCo's default options, the time step ``dt`` [s])."""
        tilt = TILT if self.tilt else 0.0
        normal = NORMAL if self.tilt else np.array([0.0, 0.0, 1.0])
        gap = self.gap or 0.0
        geom = f'type="box" size="{HALF} {HALF} {HALF}"' if self.shape == 'box' else \
            f'type="sphere" size="{HALF}"'
        friction = f'friction="{self.mu} 0.005 0.0001"'
        position = ' '.join(repr(float(x)) for x in (HALF + gap) * normal)
        return (f'<mujoco><compiler angle="radian"/><option timestep="{dt!r}"/><worldbody>'
                f'<geom type="plane" size="0 0 1" euler="0 {tilt!r} 0" {friction}/>'
                f'<body pos="{position}" euler="0 {tilt!r} 0"><freejoint/>'
                f'<geom {geom} mass="1" {friction}/></body></worldbody></mujoco>')


class Trace(NamedTuple):
    """Per step of a run, of the tracked body: its centre p [m] and velocity v [m/s] (world),
    its angular speed |ω| [1/s]; and the nearest distance to the ground d [m] (ours: every
    point's; MuJoCo: its contacts', negative when they penetrate, +inf without contact)."""

    p: np.ndarray
    v: np.ndarray
    spin: np.ndarray
    d: np.ndarray


def _second_half(trace: Trace, dt: float, key: str) -> float:
    """Mean rate of change of ``trace.<key>`` along the slope over the run's second half."""
    values, half = getattr(trace, key), len(trace.p) // 2
    return float((values[-1] - values[half - 1]) @ DOWN) / ((len(trace.p) - half) * dt)


def _spread(trace: Trace) -> float:
    """max − min of the nearest distance over the run's last quarter [m]: 0 once settled (or
    sliding steadily), the height of a bounce or a rocking otherwise, +inf when contact is
    lost in between (MuJoCo) or the run diverged."""
    last = trace.d[-max(1, len(trace.d) // 4):]
    return float(last.max() - last.min()) if np.isfinite(last).all() else math.inf


@dataclass(frozen=True)
class Case:
    """A scene: what is compared (``quantity``, with its unit), its closed form ``exact``
    (None: none) and our model's own where that differs (``model``), how it is read from a
    run (``value(trace, dt)``); a ``slab``, or (``robot``) the quadruped under ``_Stand``."""

    name: str
    quantity: str
    exact: float | None
    value: Callable
    slab: Slab | None = None
    model: float | None = None
    robot: bool = False

    def scene(self, dt: float):
        from affine_joint_sim.resources import scene_path
        from affine_joint_sim.scene import Scene

        if self.robot:
            return Scene.load(scene_path('quadruped'), dt=dt)
        return Scene.from_dict(self.slab.scene_dict(dt))


def _creep_model(mu: float) -> float:
    """Our creep speed on the incline [m/s]: ε_v (1 − √(1 − tan α / μ))."""
    return EPS_VELOCITY * (1.0 - math.sqrt(1.0 - math.tan(TILT) / mu))


CASES = (
    Case('box rest', 'resting distance [m]', 0.0, lambda t, dt: float(t.d[-1]),
         Slab('box', False, 0.5, gap=DROP), model=REST_GAP),
    Case('box slip μ 0.2', 'acceleration [m/s²]', G * (math.sin(TILT) - 0.2 * math.cos(TILT)),
         lambda t, dt: _second_half(t, dt, 'v'), Slab('box', True, 0.2)),
    Case('box stick μ 0.5', 'creep speed [m/s]', 0.0, lambda t, dt: _second_half(t, dt, 'p'),
         Slab('box', True, 0.5), model=_creep_model(0.5)),
    Case('box stop μ 0.4', 'stopping distance [m]', V0 * V0 / (2 * 0.4 * G),
         lambda t, dt: float(t.p[-1, 0]), Slab('box', False, 0.4, speed=V0)),
    Case('ball roll μ 0.5', 'acceleration [m/s²]', 5.0 / 7.0 * G * math.sin(TILT),
         lambda t, dt: _second_half(t, dt, 'v'), Slab('ball', True, 0.5)),
    Case('quadruped stand', 'trunk height [m]', None, lambda t, dt: float(t.p[-1, 2]),
         robot=True),
)


class _Stand:
    """The quadruped's PD law τ = KP (θ* − θ) − KD θ̇ [N·m] for ``names`` (θ* from STAND by
    the joint's kind), clamped to the joints' effort ``limits`` [N·m] as set_torques would."""

    def __init__(self, names, limits):
        self.target = np.array([STAND[name.split('_')[1]] for name in names])
        self.limits = np.asarray(limits, dtype=float)

    def __call__(self, angles, velocities) -> np.ndarray:
        return np.clip(KP * (self.target - angles) - KD * velocities, -self.limits,
                       self.limits)


def _angular_speed(a: np.ndarray, a_dot: np.ndarray) -> float:
    """|ω| [1/s] of an affine body from A and Ȧ (rows of q[3:], q̇[3:]): Ȧ Aᵀ ≈ [ω]×."""
    w = a_dot.reshape(3, 3) @ a.reshape(3, 3).T
    return 0.5 * math.hypot(w[2, 1] - w[1, 2], w[0, 2] - w[2, 0], w[1, 0] - w[0, 1])


def _ours(case: Case, dt: float, steps: int):
    """Our run: its Trace, its counts, and our contestant for ``timing.interleaved_us``."""
    from affine_joint_sim.stepper import Stepper

    sim = Stepper(case.scene(dt), threads=1)
    k = 0                                        # the box, the ball, the quadruped's trunk
    turn = sim.step
    if case.robot:
        joints = {j.name: j for j in sim.scene.joints}
        stand = _Stand(sim.command_joint_names,
                       [joints[name].effort_limit for name in sim.command_joint_names])

        def turn():
            sim.set_torques(stand(sim.angles, sim.velocities))
            sim.step()
    rows, iterations = [], 0
    for _ in range(steps):
        turn()
        stats, q, q_dot = sim.stats, sim.body_q[k], sim.body_qdot[k]
        rows.append((q[:3], q_dot[:3], _angular_speed(q[3:], q_dot[3:]),
                     stats['min_distance']))
        iterations += stats['newton_iterations']
    totals = sim.problem_totals
    counts = {'newton_iterations': iterations / steps, 'unconverged': totals['not_converged'],
              'rejected': totals['non_finite'] + totals['angle_aliased']}
    return Trace(*map(np.array, zip(*rows))), counts, (sim.reset, turn)


def _mujoco_robot(case: Case, dt: float):
    """The quadruped in MuJoCo from the scene's URDF, a free base at the trunk's start (its
    centre of mass is its frame's origin) on a floor; every geom μ = contact.friction, the
    robot's geoms touch the floor only (ours: no self-collision). (model, start, control),
    or None before MjSpec (MuJoCo 3.2)."""
    import mujoco

    if not hasattr(mujoco, 'MjSpec'):
        return None
    scene = case.scene(dt)
    spec = mujoco.MjSpec.from_string(scene.robot_description)
    trunk = spec.worldbody.first_body()
    trunk.add_freejoint()
    trunk.pos = scene.bodies[0].position
    mu = [scene.contact.friction, 0.005, 0.0001]
    for geom in spec.geoms:
        geom.friction, geom.contype, geom.conaffinity = mu, 1, 0
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], friction=mu)
    model = spec.compile()
    model.opt.timestep = dt
    ids = [model.joint(j.name).id for j in scene.joints]
    qpos, dof = model.jnt_qposadr[ids], model.jnt_dofadr[ids]
    stand = _Stand([j.name for j in scene.joints], [j.effort_limit for j in scene.joints])
    angles = [j.initial_position for j in scene.joints]

    def start(data):
        data.qpos[qpos] = angles

    def control(data):
        data.qfrc_applied[dof] = stand(data.qpos[qpos], data.qvel[dof])
    return model, start, control


def _mujoco_slab(case: Case, dt: float):
    """A box or ball case in MuJoCo: (model, start, None)."""
    import mujoco

    def start(data):
        data.qvel[0] = case.slab.speed
    return mujoco.MjModel.from_xml_string(case.slab.mjcf(dt)), start, None


def _mujoco(case: Case, dt: float, steps: int):
    """MuJoCo's run (Euler, its defaults) as ``_ours``: (Trace, contestant), or None where
    MuJoCo is not installed or cannot build the case."""
    try:
        import mujoco
    except ImportError:
        return None
    built = (_mujoco_robot if case.robot else _mujoco_slab)(case, dt)
    if built is None:
        return None
    model, start, control = built
    data = mujoco.MjData(model)

    def restart():
        mujoco.mj_resetData(model, data)
        start(data)

    def turn():
        if control is not None:
            control(data)
        mujoco.mj_step(model, data)

    restart()
    rows = []
    for _ in range(steps):
        turn()
        nearest = data.contact.dist[:data.ncon].min() if data.ncon else math.inf
        rows.append((data.qpos[:3].copy(), data.qvel[:3].copy(),
                     float(np.linalg.norm(data.qvel[3:6])), nearest))
    return Trace(*map(np.array, zip(*rows))), (restart, turn)


def _error(value, exact):
    return None if value is None or exact is None else abs(value - exact)


def measure(case: Case, dt: float, settings: Settings) -> dict:
    """One table row: ``case`` at ``dt`` [s] in ours and in MuJoCo (None where absent).
    Our SimulationWarnings are silenced: the columns unconverged and rejected count them."""
    from affine_joint_sim.bench.timing import interleaved_us
    from affine_joint_sim.sim_warnings import SimulationWarning

    steps = round(settings.duration / dt)
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', SimulationWarning)
        trace, counts, contestant = _ours(case, dt, steps)
        contestants = {'ours': contestant}
        peer = _mujoco(case, dt, steps)
        if peer is not None:
            contestants['mujoco'] = peer[1]
        samples = interleaved_us(contestants, min(steps, TIMED_STEPS), settings.repeats)
    value = case.value(trace, dt)
    theirs = None if peer is None else case.value(peer[0], dt)
    row = {'scene': case.name, 'dt': dt, 'us_per_step': statistics.median(samples['ours']),
           'mujoco_us': statistics.median(samples['mujoco']) if peer else None, **counts,
           'quantity': case.quantity, 'exact': case.exact, 'model': case.model,
           'ours': value, 'mujoco': theirs, 'error': _error(value, case.exact),
           'mujoco_error': _error(theirs, case.exact),
           'spin': None, 'mujoco_spin': None,
           'min_distance': float(trace.d.min()),
           'mujoco_min_distance': None if peer is None else float(peer[0].d.min()),
           'spread': _spread(trace), 'mujoco_spread': None if peer is None else _spread(peer[0])}
    if case.slab is not None and case.slab.shape == 'ball':     # ω r / v: 1 when rolling
        row['spin'] = float(trace.spin[-1] * HALF / np.linalg.norm(trace.v[-1]))
        if peer is not None:
            row['mujoco_spin'] = float(peer[0].spin[-1] * HALF / np.linalg.norm(peer[0].v[-1]))
    if row['mujoco_min_distance'] == math.inf:
        row['mujoco_min_distance'] = None
    row['realtime'] = dt / (row['us_per_step'] * 1e-6)
    row['vs_mujoco'] = times(row['us_per_step'], row['mujoco_us'])
    return row


def _ratio(dt: float, settings: Settings, slab: Slab, name: str, target: float) -> dict:
    """µs/step of ``slab`` with contact over the same scene without ``ground`` and
    ``contact`` (the median of the ratios of runs timed together)."""
    from affine_joint_sim.bench.timing import interleaved_us
    from affine_joint_sim.scene import Scene
    from affine_joint_sim.stepper import Stepper

    contestants = {}
    for key, contact in (('with', True), ('without', False)):
        sim = Stepper(Scene.from_dict(slab.scene_dict(dt, contact)), threads=1)
        contestants[key] = (sim.reset, sim.step)
    samples = interleaved_us(contestants, TIMED_STEPS, settings.repeats)
    ratio = statistics.median(a / b for a, b in zip(samples['with'], samples['without']))
    return {'case': name, 'dt': dt, 'us_with': statistics.median(samples['with']),
            'us_without': statistics.median(samples['without']), 'ratio': ratio,
            'target': target, 'verdict': 'pass' if ratio <= target else 'FAIL'}


def ratios(settings: Settings) -> list[dict]:
    """Speed ratios at every dt of ``settings``: (a) a box FAR above the ground (it never
    touches it in a run), contact given against none; (b) a box resting on the ground against
    the same box falling freely."""
    rows = []
    for dt in settings.dts:
        rows.append(_ratio(dt, settings, Slab('box', False, 0.5, gap=FAR),
                           '(a) never touching: contact / none', 1.3))
        rows.append(_ratio(dt, settings, Slab('box', False, 0.5),
                           '(b) resting / falling freely', 3.0))
    return rows


COLUMNS = [
    Column('scene', 'scene'), Column('dt', 'dt [s]', '{:g}'),
    Column('us_per_step', 'µs/step', '{:.0f}'), Column('mujoco_us', 'MuJoCo µs', '{:.1f}'),
    Column('vs_mujoco', '× MuJoCo', '{:.1f}'),
    Column('newton_iterations', 'Newton it.', '{:.2f}'),
    Column('unconverged', 'unconverged'), Column('rejected', 'rejected'),
    Column('quantity', 'quantity'), Column('exact', 'exact', '{:.4g}'),
    Column('model', 'our model', '{:.4g}'), Column('ours', 'ours', '{:.4g}'),
    Column('mujoco', 'MuJoCo', '{:.4g}'), Column('error', 'error ours', '{:.2e}'),
    Column('mujoco_error', 'error MuJoCo', '{:.2e}'), Column('spin', 'ω r / v', '{:.3f}'),
    Column('mujoco_spin', 'MuJoCo ω r / v', '{:.3f}'),
    Column('min_distance', 'min distance ours [m]', '{:.2e}'),
    Column('mujoco_min_distance', 'MuJoCo [m]', '{:.2e}'),
    Column('spread', 'distance spread ours [m]', '{:.1e}'),
    Column('mujoco_spread', 'MuJoCo [m]', '{:.1e}')]
RATIO_COLUMNS = [
    Column('case', 'case'), Column('dt', 'dt [s]', '{:g}'),
    Column('us_with', 'µs/step', '{:.1f}'), Column('us_without', 'without contact µs', '{:.1f}'),
    Column('ratio', 'ratio', '{:.2f}'), Column('target', 'target', '≤ {:g}'),
    Column('verdict', '')]


def _plot(path: Path, rows: list[dict]) -> None:
    """Error against µs/step over dt, one panel per scene with a closed form: ours and MuJoCo
    as two marker series, each point labelled with its dt."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    names = [c.name for c in CASES if c.exact is not None]
    columns = 3
    fig, axes = plt.subplots(-(-len(names) // columns), columns, figsize=(11.0, 7.0),
                             squeeze=False)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    for ax, name in zip(axes.flat, names):
        mine = [row for row in rows if row['scene'] == name]
        for label, us, error, marker in (('ours', 'us_per_step', 'error', 'o-'),
                                         ('MuJoCo', 'mujoco_us', 'mujoco_error', 'x--')):
            points = [(r[us], r[error], r['dt']) for r in mine
                      if r[us] is not None and r[error]]
            if points:
                ax.loglog(*zip(*[p[:2] for p in points]), marker, label=label)
                for x, y, dt in points:
                    ax.annotate(f'{dt:g}', (x, y), fontsize=6)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel('µs/step')
        ax.set_ylabel(f'|error| of {mine[0]["quantity"]}' if mine else '', fontsize=8)
        ax.grid(True, which='both', alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _summary(rows: list[dict], ratio_rows: list[dict]) -> str:
    """The findings in a few lines: penetration, ratios, the quadruped's real-time factor."""
    def deepest(key):
        row = min((r for r in rows if r[key] is not None), key=lambda r: r[key], default=None)
        return row and f'{row[key]:.2e} m ({row["scene"]}, dt {row["dt"]:g})'

    nearest = min(row['min_distance'] for row in rows)
    theirs = deepest('mujoco_min_distance')
    lines = [f'- Nearest approach to the ground, ours: {deepest("min_distance")}: '
             + ('never penetrates' if nearest > 0 else 'PENETRATES')
             + (f'; MuJoCo: {theirs}.' if theirs else '.')]
    lines += [f'- {r["case"]} at dt {r["dt"]:g}: × {r["ratio"]:.2f} (target ≤ {r["target"]:g}, '
              f'{r["verdict"]})' for r in ratio_rows]
    lines += [f'- (c) quadruped standing at dt 1e-3: {r["us_per_step"]:.0f} µs/step, '
              f'× {r["realtime"]:.1f} real time on one core'
              + (f' (MuJoCo {r["mujoco_us"]:.1f} µs/step)' if r['mujoco_us'] else '')
              for r in rows if r['scene'] == 'quadruped stand' and r['dt'] == 1e-3]
    return '\n'.join(lines)


def run(results: Path, devices: list[str], settings: Settings) -> None:
    """Measure every case at its dts (CPU only: ``devices`` is not used), write contact.md,
    contact.csv, contact_ratios.csv and contact.png, print the tables and a summary."""
    from affine_joint_sim.bench import mujoco_urdf

    rows = [measure(case, dt, settings) for case in CASES
            for dt in (settings.robot_dts if case.robot else settings.dts)]
    ratio_rows = ratios(settings)
    _plot(results / 'contact.png', rows)
    write_csv(results / 'contact_ratios.csv', ratio_rows)
    peer = ('' if mujoco_urdf.available() else
            "MuJoCo is not installed (extra 'compare'): no MuJoCo columns.\n\n")
    text = (f'## Contact: {settings.duration:g} s runs, float64, one CPU core\n\n{peer}'
            f'µs: median of {settings.repeats} runs of up to {TIMED_STEPS} steps, ours and '
            "MuJoCo's (Euler) timed in turn; the quadruped's include the PD law "
            f'τ = {KP:g} (θ* − θ) − {KD:g} θ̇ computed in Python each step. Error: |value − '
            'exact|, in the unit of the quantity. Accelerations and the creep speed: over the '
            "run's second half. Our model: what our IPC contact gives by design (a rest above "
            'the ground, a creep below ε_v). Min distance: the nearest any point came to the '
            "ground (ours) or the deepest contact distance (MuJoCo's: negative = "
            'penetration).\n\n' + markdown_table(rows, COLUMNS)
            + '\n\n## Speed ratios (µs/step with contact over the same box without it)\n\n'
            + markdown_table(ratio_rows, RATIO_COLUMNS) + '\n\n## Summary\n\n'
            + _summary(rows, ratio_rows) + '\n\n## Where a step goes (the quadruped '
            'standing)\n\n' + stages.profile_text(stages.profile_rows(
                ('quadruped',), settings.profile_steps, settings.profile_calls)))
    publish(results, 'contact', text, rows, plots=('contact_ratios.csv', 'contact.png'))


def add_parser(sections) -> None:
    add_section(
        sections, 'contact', run, FULL, QUICK,
        help='ground contact against closed forms and MuJoCo, and what contact costs',
        description='Run a box resting, slipping, sticking and stopping, a ball rolling and '
                    'the quadruped standing at several dt, against closed forms and MuJoCo '
                    '(extra compare); write contact.md, contact.csv, contact_ratios.csv and '
                    'contact.png into --results.',
        quick_help=f'dt {", ".join(map(str, QUICK.dts))} (quadruped '
                   f'{", ".join(map(str, QUICK.robot_dts))}), {QUICK.duration:g} s runs, '
                   f'{QUICK.repeats} timed run')
