"""The node's parameters (README.md#the-ros-2-node): defaults, valid ranges, which may change live.

``affine-joint-sim run`` builds one flag per parameter from ``PARAMETERS``, so the flags and a
``--ros-args --params-file`` YAML always mirror each other.
"""

import math
from dataclasses import dataclass

__all__ = ['MODES', 'STORAGES', 'PARAMETERS', 'ParameterSpec', 'ConfigError', 'check',
           'command_joints']

MODES = ('realtime', 'fast', 'lockstep')
STORAGES = ('mcap', 'sqlite3')


class ConfigError(ValueError):
    """A parameter value outside its valid range; the message names both."""


@dataclass(frozen=True)
class ParameterSpec:
    """One node parameter.

    Attributes:
        default: the value when neither a params file nor a flag sets it (fixes the type).
        help: what it means, with its unit.
        choices: the valid values of a closed set, else None.
        minimum: the smallest valid number, else None.
        exclusive: whether ``minimum`` itself is invalid.
        live: whether it may change while the node runs (``ros2 param set``); the others
            are declared read-only.
    """

    default: object
    help: str
    choices: tuple | None = None
    minimum: float | None = None
    exclusive: bool = False
    live: bool = False


PARAMETERS = {
    'scene': ParameterSpec('pendulum', 'scene YAML or robot URDF file, or a packaged scene name'),
    'device': ParameterSpec('cpu', 'Warp device: cpu, cuda, cuda:N'),
    'mode': ParameterSpec('realtime', 'realtime: paced by the wall clock x real_time_factor; '
                          'fast: as fast as possible; lockstep: after publishing a step, wait '
                          'for joint_commands before the next', choices=MODES, live=True),
    'real_time_factor': ParameterSpec(1.0, 'simulated seconds per wall second in realtime mode',
                                      minimum=0.0, exclusive=True, live=True),
    'lockstep_publishers': ParameterSpec(1, 'lockstep: answers to each state (one per '
                                         'controller; per robot in a scene of several) '
                                         'before the next step', minimum=1, live=True),
    'command_joints': ParameterSpec('', 'joints of effort_commands/position_commands arrays, '
                                    'comma-separated, in order (empty: every moving joint in '
                                    'scene order)'),
    'max_command_bytes': ParameterSpec(65536, 'largest command message taken [bytes, as '
                                       'serialized]; larger ones are dropped undecoded',
                                       minimum=64, live=True),
    'publish_clock': ParameterSpec(True, 'publish /clock every step', live=True),
    'viz_rate': ParameterSpec(30.0, 'markers and body_poses per simulated second [Hz] (0: '
                              'none)', minimum=0.0),
    'frame_id': ParameterSpec('world', 'frame of markers and body_poses'),
    'record': ParameterSpec('', 'bag directory to record into (empty: no recording)'),
    'storage': ParameterSpec('mcap', 'bag storage', choices=STORAGES),
    'command_timeout': ParameterSpec(0.0, 'simulated seconds [s] after which a silent joint\'s '
                                     'torque falls to 0 (0: hold the last command)',
                                     minimum=0.0, live=True),
    'ground': ParameterSpec(math.nan, 'add the ground z >= this height [m] to the scene, '
                            'replacing its own (nan: none added); a URDF robot\'s <collision> '
                            'elements then touch it'),
    'duration': ParameterSpec(0.0, 'stop after this many simulated seconds [s] (0: run until '
                              'interrupted)', minimum=0.0, live=True),
}


def check(name: str, value):
    """``value`` for parameter ``name`` (an integer given for a float parameter becomes a
    float); raise ConfigError unless it is valid."""
    spec = PARAMETERS[name]
    if type(spec.default) is float and type(value) is int:
        value = float(value)
    if type(value) is not type(spec.default):
        raise ConfigError(f'parameter {name!r}: expected a {type(spec.default).__name__}, '
                          f'got {value!r}')
    if spec.choices is not None and value not in spec.choices:
        raise ConfigError(f'parameter {name!r}: {value!r} is not one of '
                          f'{", ".join(spec.choices)}')
    if name == 'frame_id' and (not value or any(c.isspace() for c in value)):
        raise ConfigError(f'parameter {name!r}: {value!r} is not a frame name (non-empty, no '
                          'whitespace)')
    if name == 'ground' and math.isinf(value):
        raise ConfigError(f'parameter {name!r}: {value!r} is not a height (a finite number of '
                          'metres, or nan for none)')
    if spec.minimum is not None:
        low = spec.minimum
        if not math.isfinite(value) or value < low or (spec.exclusive and value == low):
            bound = f'> {low:g}' if spec.exclusive else f'>= {low:g}'
            raise ConfigError(f'parameter {name!r}: {value!r} is out of range (must be finite '
                              f'and {bound})')
    return value


def command_joints(value: str, sim) -> list[str]:
    """The joints of the command arrays from parameter ``command_joints`` (comma-separated;
    empty: every moving joint in scene order). Raises ConfigError naming the valid ones."""
    valid = sim.command_joint_names
    names = [n.strip() for n in value.split(',') if n.strip()] or valid
    wrong = [n for n in names if n not in valid]
    if wrong or len(set(names)) != len(names):
        raise ConfigError(f"parameter 'command_joints': {', '.join(wrong) or 'a repeated joint'}"
                          f" is not a moving joint of the scene (valid, once each: "
                          f"{', '.join(valid)})")
    return names
