"""The ``affine-joint-sim`` command line (usage: README.md; docs/architecture.md#command-line).

Subcommands: ``run`` (the node), ``torque`` / ``enable`` / ``echo`` (talk to a running node
without the ``ros2`` CLI), ``controller`` (the demo PD controller), ``demo`` (``make run``),
``replay`` (bags), ``render`` (pictures of a bag), ``sweep`` and ``bench``. ROS arguments go
last, after ``--ros-args`` (e.g. ``--params-file``, remappings).
Modules behind a subcommand are imported only when it runs, so ``--help`` is quick.
"""

import argparse
import math
import sys
import tempfile
import warnings
from pathlib import Path

from affine_joint_sim.resources import packaged_scenes, scene_path
from affine_joint_sim.ros.parameters import MODES, STORAGES
from affine_joint_sim.scene import SceneError, looks_like_urdf
from affine_joint_sim.sim_warnings import SimulationDetail

__all__ = ['main']

ROS_ARGS = '--ros-args'


def _assignment(text: str) -> tuple[str, float]:
    name, sep, value = text.partition('=')
    try:
        if not sep or not name:
            raise ValueError
        return name, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected JOINT=NUMBER, got {text!r}') from None


def _non_negative(text: str) -> float:
    try:
        value = float(text)
        if not 0.0 <= value < float('inf'):
            raise ValueError
        return value
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a finite number >= 0, got {text!r}') from None


def _positive(text: str) -> float:
    try:
        value = float(text)
        if not value > 0.0 or value == float('inf'):
            raise ValueError
        return value
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a finite number > 0, got {text!r}') from None


def _pixels(text: str) -> int:
    try:
        value = int(text)
        if not 16 <= value <= 8192:
            raise ValueError
        return value
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a whole number of pixels in 16..8192, got '
                                         f'{text!r}') from None


_POSE = '3 or 6 finite numbers: X Y Z [m], then optionally R P Y [rad]'


def _pose_number(text: str) -> float:
    try:
        value = float(text)
        if not math.isfinite(value):
            raise ValueError
        return value
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected {_POSE}, got {text!r}') from None


class _BasePose(argparse.Action):
    """``--base X Y Z [R P Y]`` as a scene file's ``base: {xyz, rpy}``: the root link's pose
    in the world [m; rad, fixed-axis roll-pitch-yaw]."""

    def __call__(self, parser, namespace, values, option_string=None):
        if len(values) not in (3, 6):
            raise argparse.ArgumentError(self, f'expected {_POSE}, got {len(values)} numbers')
        setattr(namespace, self.dest, {'xyz': values[:3], 'rpy': values[3:] or [0.0, 0.0, 0.0]})


def _on_off(text: str) -> bool:
    words = {'on': True, 'true': True, '1': True, 'off': False, 'false': False, '0': False}
    try:
        return words[text.lower()]
    except KeyError:
        raise argparse.ArgumentTypeError(f'expected on or off, got {text!r}') from None


def _run(args, ros_args) -> int:
    if args.verbose:
        warnings.simplefilter('default', SimulationDetail)
    placement = _robot_placement(args)
    if not placement:
        return _run_node(args, ros_args)
    with tempfile.TemporaryDirectory(prefix='affine-joint-sim-') as folder:
        args.scene = str(_robot_scene_file(scene_path(args.scene), placement, Path(folder)))
        return _run_node(args, ros_args)


def _robot_placement(args) -> dict:
    """The keys of a scene file's ``urdf:`` entry that ``--base`` and ``--fixed-base`` /
    ``--floating`` give (``base: {xyz, rpy}``, ``fixed_base``; empty without them).
    ValueError naming the flag unless ``--scene`` names a URDF."""
    placement = {key: value for key, value in (('base', args.base),
                                               ('fixed_base', args.fixed_base))
                 if value is not None}
    if not placement:
        return placement
    flag, key = (('--base', 'base: {xyz: [x, y, z], rpy: [r, p, y]}') if 'base' in placement
                 else ('--fixed-base' if args.fixed_base else '--floating',
                       'fixed_base: true or false'))
    if args.scene is None:
        raise ValueError(f'{flag} places a URDF robot: give the robot with --scene ROBOT.urdf')
    if not looks_like_urdf(scene_path(args.scene)):
        raise ValueError(f'{flag} places a URDF robot given with --scene ROBOT.urdf; '
                         f'{args.scene!r} is a scene YAML: write {key} beside its urdf: '
                         'entry instead')
    return placement


def _robot_scene_file(urdf: Path, placement: dict, folder: Path) -> Path:
    """A scene YAML in ``folder`` that names ``urdf`` with the ``placement`` keys beside it:
    the flags become exactly what a scene file says."""
    import yaml

    path = folder / f'{urdf.stem}.yaml'
    path.write_text(yaml.safe_dump({'urdf': str(urdf.resolve()), **placement}),
                    encoding='utf-8')
    return path


def _run_node(args, ros_args) -> int:
    from rclpy.parameter import Parameter

    from affine_joint_sim.ros import run_node as node
    from affine_joint_sim.ros.parameters import PARAMETERS

    overrides = [Parameter(name, value=getattr(args, name)) for name in PARAMETERS
                 if getattr(args, name) is not None]
    return node.main(args=['affine-joint-sim', ROS_ARGS, *ros_args] if ros_args else None,
                     parameter_overrides=overrides)


def _torque(args, ros_args) -> int:
    from affine_joint_sim.ros import tools
    return tools.send('joint_torque', args.joint, args.value, args.namespace, args.timeout)


def _enable(args, ros_args) -> int:
    from affine_joint_sim.ros import tools
    return tools.send('joint_enable', args.joint, args.state, args.namespace, args.timeout)


def _echo(args, ros_args) -> int:
    from affine_joint_sim.ros import tools
    return tools.echo(args.namespace, args.rate, args.once, args.timeout)


def _controller(args, ros_args) -> int:
    from affine_joint_sim.ros import controller
    if not args.target and args.script is None:
        raise ValueError('controller: give --target JOINT=RAD (repeatable) or --script')
    return controller.main(dict(args.target or ()), args.kp, args.kd, args.effort_limit,
                           args.namespace, interface=args.interface, script=args.script)


def _demo(args, ros_args) -> int:
    from affine_joint_sim.ros import demo
    return demo.run_demo(args.scene, dict(args.target or ()), args.duration, args.mode, args.record,
                         args.kp, args.kd, interface=args.interface, script=args.script)


def _replay(args, ros_args) -> int:
    from affine_joint_sim.fleet.bags import holds_bags
    many = len(args.bag) > 1 or args.workers or args.ray or args.report or holds_bags(
        args.bag[0])
    if many:
        if args.out or args.publish:
            print('affine-joint-sim replay: error: --out and --publish take one bag',
                  file=sys.stderr)
            return 2
        if _too_few_workers('replay', args):
            return 2
        from affine_joint_sim.fleet import cli as fleet
        return fleet.main(args)
    from affine_joint_sim.ros import replay
    args.bag = args.bag[0]
    return replay.main(args)


def _too_few_workers(command: str, args) -> bool:
    """--workers below 1, said in one line."""
    if args.workers is not None and args.workers < 1:
        print(f'affine-joint-sim {command}: error: --workers {args.workers}: must be >= 1',
              file=sys.stderr)
        return True
    return False


def _sweep(args, ros_args) -> int:
    if _too_few_workers('sweep', args):
        return 2
    from affine_joint_sim.fleet import sweep
    return sweep.main(args)


def _render(args, ros_args) -> int:
    from affine_joint_sim.viz import render
    return render.main(args)


def _bench(args, ros_args) -> int:
    from affine_joint_sim import bench
    return bench.main(args)


def _add_executor(parser, prefix: str = ''):
    parser.add_argument('--workers', type=int, default=None,
                        help=f'{prefix}worker processes (default: one per CPU)')
    parser.add_argument('--ray', metavar='ADDRESS',
                        help=f"{prefix}run on Ray: 'local' (started for this run), 'auto' "
                             "(this machine's `ray start` cluster) or HOST:PORT (extra "
                             "'cluster')")


def _add_interface(parser):
    parser.add_argument('--interface', default='joint_commands',
                        choices=('joint_commands', 'effort_commands'),
                        help='how the controller sends torques: joint_commands (JointState, '
                             'name + effort, stamped with the state it answers) or '
                             'effort_commands (Float64MultiArray, one value per joint in '
                             'joint_states order: ros2_control\'s JointGroupEffortController)')


def _add_run(commands):
    from affine_joint_sim.ros.parameters import PARAMETERS

    run = commands.add_parser(
        'run', help='run the simulator node',
        description='Run the affine_joint_sim ROS 2 node. Each flag sets the node parameter of '
                    'the same name and beats a --ros-args --params-file; unset flags keep the '
                    'file\'s value or the default shown. --base and --fixed-base/--floating '
                    'place a URDF robot given with --scene, as a scene file\'s base: and '
                    'fixed_base: do.')
    for name, spec in PARAMETERS.items():
        flag = '--' + name.replace('_', '-')
        extra = f' (default: {spec.default!r})'
        if name == 'scene':
            extra += f'; packaged: {", ".join(packaged_scenes())}'
        if isinstance(spec.default, bool):
            run.add_argument(flag, dest=name, action=argparse.BooleanOptionalAction,
                             default=None, help=spec.help + extra)
        else:
            run.add_argument(flag, dest=name, type=type(spec.default), choices=spec.choices,
                             default=None, help=spec.help + extra)
    _add_placement(run)
    run.add_argument('-v', '--verbose', action='store_true',
                     help='say each thing a robot\'s load simulates differently from its '
                          'file (a URDF joint without limits, a mesh reduced), not only the '
                          'one-line summary per robot')
    run.set_defaults(func=_run)


def _add_placement(run):
    """The flags that place a URDF robot given with --scene (its urdf: entry's keys)."""
    robot = run.add_argument_group('URDF robot given with --scene ROBOT.urdf')
    robot.add_argument('--base', nargs='*', type=_pose_number, action=_BasePose, default=None,
                       metavar=('X Y Z', 'R P Y'),
                       help='the root link\'s pose in the world: position [m] and fixed-axis '
                            'roll, pitch, yaw [rad] (default: 0 0 0 0 0 0; a scene file\'s '
                            'base: {xyz, rpy})')
    held = robot.add_mutually_exclusive_group()
    held.add_argument('--fixed-base', dest='fixed_base', action='store_const', const=True,
                      default=None, help='weld the root link to the world (the default; a '
                                         'scene file\'s fixed_base: true)')
    held.add_argument('--floating', dest='fixed_base', action='store_const', const=False,
                      help='let the root link move freely (legged robots; a scene file\'s '
                           'fixed_base: false)')


def _add_namespace(parser):
    parser.add_argument('--namespace', default='', help='namespace of the node (default: /)')


def _add_script(parser, default=''):
    from affine_joint_sim.control_script import packaged_scripts
    parser.add_argument('--script', default=None, metavar='FILE|NAME',
                        help='a control script: targets that follow keyframes in simulated '
                             'time, with per-joint gains (replaces --target, --kp, --kd; '
                             f'packaged: {", ".join(packaged_scripts())}){default}')


def _add_gains(parser):
    parser.add_argument('--kp', type=float, default=100.0, help='P gain [N·m/rad]')
    parser.add_argument('--kd', type=float, default=10.0, help='D gain [N·m·s/rad]')


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='affine-joint-sim',
        description='Affine-body simulator of robots with revolute, prismatic and fixed '
                    'joints: ROS 2 Jazzy node and tools. Run with '
                    'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (the Makefile sets it).')
    commands = parser.add_subparsers(dest='command', required=True)
    _add_run(commands)

    for name, topic, value_help in (
            ('torque', 'external_torque', ('value', float, 'torque [N·m]')),
            ('enable', 'external_torque/is_constrained', ('state', _on_off, 'on or off'))):
        sub = commands.add_parser(name, help=f'send one message to joints/JOINT/{topic}',
                                  description=f'Publish once on joints/JOINT/{topic} and wait '
                                              'until the node acknowledges it.')
        sub.add_argument('joint', help='joint name')
        sub.add_argument(value_help[0], type=value_help[1], help=value_help[2])
        _add_namespace(sub)
        sub.add_argument('--timeout', type=float, default=10.0,
                         help='seconds to wait for the node (default: %(default)s)')
        sub.set_defaults(func=_torque if name == 'torque' else _enable)

    echo = commands.add_parser('echo', help='print joint_states as a live table',
                               description='Print joint_states as a table until Ctrl-C.')
    _add_namespace(echo)
    echo.add_argument('--rate', type=_positive, default=10.0, help='refreshes per second')
    echo.add_argument('--once', action='store_true', help='print one message and exit')
    echo.add_argument('--timeout', type=float, default=0.0,
                      help='exit 1 if no message within this many seconds (0: wait forever)')
    echo.set_defaults(func=_echo)

    controller = commands.add_parser(
        'controller', help='demo PD controller',
        description='Drive joints to target angles through joint_commands until Ctrl-C.')
    controller.add_argument('--target', type=_assignment, action='append',
                            metavar='JOINT=RAD', help='target angle (repeatable)')
    _add_script(controller)
    _add_gains(controller)
    controller.add_argument('--effort-limit', type=float, default=float('inf'),
                            help='largest |torque| sent [N·m]')
    _add_interface(controller)
    _add_namespace(controller)
    controller.set_defaults(func=_controller)

    demo = commands.add_parser(
        'demo', help='node + PD controller closed loop (make run, which also records a bag)',
        description='Run the node and the PD controller as two processes over DDS for '
                    '--duration simulated seconds and print a summary; with --record, record a '
                    'bag. Ctrl-C stops both and still prints the summary.')
    demo.add_argument('--scene', default='pendulum', help='scene file or packaged name')
    demo.add_argument('--target', type=_assignment, action='append',
                      default=None, metavar='JOINT=RAD', help='target angle (repeatable; '
                      'default: shoulder=1.0 on the pendulum, else every moving joint\'s '
                      'initial position, holding the start pose)')
    _add_script(demo, ' (default: the packaged script named as the scene, if any, when no '
                '--target is given)')
    demo.add_argument('--duration', type=_positive, default=3.0,
                      help='simulated seconds (> 0)')
    demo.add_argument('--mode', default='lockstep', choices=MODES,
                      help='node mode (default: %(default)s: deterministic)')
    demo.add_argument('--record', type=Path, default=None,
                      help='bag directory to record into (default: no bag)')
    _add_gains(demo)
    _add_interface(demo)
    demo.set_defaults(func=_demo)

    replay = commands.add_parser(
        'replay', help='re-simulate a recorded bag and compare, or re-publish it',
        description='Re-simulate BAG from its own scene and commands and compare with the '
                    'recorded joint states (exit 1 above --tol, 2 on errors); with --scene, '
                    'a what-if against another scene; with --publish, play its commands on ROS.')
    replay.add_argument('bag', type=Path, nargs='+',
                        help='rosbag2 directory (or one .mcap/.db3 file); several, a directory '
                             'of bags or a quoted glob re-simulate them all in parallel')
    replay.add_argument('--tol', type=_non_negative, default=1e-9,
                        help='largest |Δθ| [rad] or |Δω| [rad/s] accepted (default: %(default)g, '
                             'for the same device and precision)')
    replay.add_argument('--scene', help='replay against this scene file or packaged scene '
                        'instead (what-if)')
    replay.add_argument('--device', default='cpu', help='Warp device (default: cpu)')
    replay.add_argument('--out', type=Path, help='write the re-simulated run as a bag here')
    replay.add_argument('--storage', default='mcap', choices=STORAGES,
                        help='storage of --out (default: mcap)')
    replay.add_argument('--publish', action='store_true',
                        help='publish the recorded commands on ROS at recorded timing instead')
    replay.add_argument('--rate', type=_positive, default=1.0,
                        help='--publish speed factor (default: 1 = recorded timing)')
    _add_executor(replay, 'many bags: ')
    replay.add_argument('--report', type=Path,
                        help='many bags: write the per-bag results to this .json or .csv')
    _add_namespace(replay)
    replay.set_defaults(func=_replay)

    render = commands.add_parser(
        'render', help='draw a bag into a GIF, MP4 or PNG',
        description='Draw the bodies of a recorded run (its body_poses, or re-simulated when '
                    'it has none) beside plots of its joint coordinates and efforts.')
    render.add_argument('bag', help='bag directory (or .mcap/.db3 file)')
    render.add_argument('--out', required=True, help='output file: .gif, .mp4 or .png')
    render.add_argument('--fps', type=_positive, default=15.0, help='frames per second of '
                        'bag time (default 15)')
    render.add_argument('--width', type=_pixels, default=960, help='pixels, 16..8192 '
                        '(default 960)')
    render.add_argument('--height', type=_pixels, default=540, help='pixels, 16..8192 '
                        '(default 540)')
    render.add_argument('--view', default='-60,20', help='camera azimuth,elevation in degrees '
                        '(default -60,20)')
    render.add_argument('--from', dest='start', type=_non_negative, default=None,
                        help='first frame [s of bag time] (a .png: its only frame)')
    render.add_argument('--to', dest='stop', type=_positive, default=None,
                        help='last frame [s of bag time] (default: the end)')
    render.set_defaults(func=_render)

    sweep = commands.add_parser(
        'sweep', help='the speed/accuracy sweep over a declared grid, in parallel',
        description='Run the bench sweep over the cases, scenes and solver settings of SPEC '
                    '(YAML: cases, scenes, dt, integrator, newton_tol, precision, device, '
                    'repeats) as parallel jobs; write sweep.csv, sweep.md and plots to --out.')
    sweep.add_argument('spec', type=Path, help='sweep spec YAML')
    sweep.add_argument('--out', type=Path, default=Path('results/sweep'),
                       help='output directory (default: %(default)s)')
    _add_executor(sweep)
    sweep.set_defaults(func=_sweep)

    from affine_joint_sim import bench as bench_sections
    bench = commands.add_parser('bench', help='speed and accuracy measurements',
                                description='Speed/accuracy measurements; with no section, '
                                            'every section writes into --results.')
    bench_sections.add_arguments(bench)
    bench.set_defaults(func=_bench)
    return parser


def _warning_line(message, category, filename, lineno, line=None) -> str:
    """A warning as the command line shows it: its category and message, without the file,
    line and source of the project's code that raised it."""
    return f'{category.__name__}: {message}\n'


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    warnings.formatwarning = _warning_line
    ros_args = []
    if ROS_ARGS in argv:
        at = argv.index(ROS_ARGS)
        argv, ros_args = argv[:at], argv[at + 1:]
    args = build_parser().parse_args(argv)
    try:
        return args.func(args, ros_args)
    except (SceneError, FileNotFoundError, ValueError) as exc:
        print(f'affine-joint-sim: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
