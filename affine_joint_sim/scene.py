"""Scene schema: loading, validation and serialisation of scene files (README.md#scenes).

A scene is YAML (or a dict) in SI units with world z up (REP 103). Every bad input fails at
load with a ``SceneError`` that names the source, the key path (``joints[1].parent``) and what
is valid; unknown keys are errors, never silently ignored.
"""

import math
import re
from pathlib import Path
from urllib.parse import unquote
from typing import Annotated, Literal

import yaml
from pydantic import (BaseModel, BeforeValidator, Field, PrivateAttr,
                      ValidationError, model_validator)

from affine_joint_sim.contact_schema import Collision, Contact, Ground
from affine_joint_sim.physics.host.joint_kinds import JOINT_KIND_NAMES, joint_kind
from affine_joint_sim.schema_base import (Number, OneOf, PositiveFloat, StrictModel, Vec3,
                                          not_a_boolean)

__all__ = ['Scene', 'SceneSettings', 'SceneError', 'StrictModel', 'Body', 'Joint', 'Limit',
           'Drive', 'Mimic', 'Shape', 'Solver', 'Orientation', 'Frame', 'Visual', 'Geometry',
           'Mesh', 'Sensor', 'SENSOR_TYPES', 'Robot', 'looks_like_urdf', 'topic_token',
           'validation_report']

# Names are the user's (URDF names as they are): printable, no whitespace. Per-joint topic
# names use topic_token(name).
NAME_PATTERN = r'^[^\s]+$'
Name = Annotated[str, Field(pattern=NAME_PATTERN)]


def topic_token(name: str) -> str:
    """``name`` as a ROS topic token: runs of characters outside [A-Za-z0-9_] become one
    ``_`` (no repeated underscores) and a leading digit gets an ``_`` before it."""
    token = re.sub(r'[^A-Za-z0-9]+', '_', name).strip('_') or '_'
    return '_' + token if token[0].isdigit() else token


class SceneError(ValueError):
    """A scene that cannot be loaded; the message lists every problem with its key path."""


class Cylinder(StrictModel):
    """Solid cylinder whose axis is the body z axis [m]."""

    radius: PositiveFloat
    length: PositiveFloat


class Sphere(StrictModel):
    """Solid sphere [m]."""

    radius: PositiveFloat


class Shape(OneOf):
    """Exactly one primitive: ``box`` (full side lengths [m]), ``cylinder`` or ``sphere``."""

    box: tuple[PositiveFloat, PositiveFloat, PositiveFloat] | None = None
    cylinder: Cylinder | None = None
    sphere: Sphere | None = None

    KINDS = ('box', 'cylinder', 'sphere')


class Orientation(StrictModel):
    """Initial orientation, world frame: ``rpy`` [rad] (fixed-axis x-y-z, REP 103) or
    ``quat_xyzw``."""

    rpy: Vec3 | None = None
    quat_xyzw: tuple[Number, Number, Number, Number] | None = None

    @model_validator(mode='after')
    def _exactly_one(self):
        if (self.rpy is None) == (self.quat_xyzw is None):
            raise ValueError('give exactly one of rpy, quat_xyzw')
        if self.quat_xyzw is not None:
            norm = math.sqrt(sum(c * c for c in self.quat_xyzw))
            if abs(norm - 1.0) > 1e-3:
                raise ValueError(f'quat_xyzw must be a unit quaternion (norm {norm:.6g}, '
                                 'valid within 1e-3 of 1)')
        return self


class Body(StrictModel):
    """An affine body; its rest frame is centred at its centre of mass (docs/physics.md#mass).

    Its mass properties come from ``shape`` with ``density`` or ``mass``, or from ``mass`` and
    ``inertia``: the principal moments of inertia [kg·m²] about the centre of mass, the body
    axes being the principal axes (a URDF link); a ``shape`` given beside them is drawn only.
    A fixed body needs neither shape nor inertia (only its mass, which sets joint stiffness).
    """

    name: Name
    shape: Shape | None = None
    inertia: tuple[PositiveFloat, PositiveFloat, PositiveFloat] | None = None
    density: PositiveFloat | None = None
    mass: PositiveFloat | None = None
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Orientation | None = None
    linear_velocity: Vec3 = (0.0, 0.0, 0.0)
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)
    fixed: bool = False
    kappa: PositiveFloat | None = None    # Pa; None: from its joints' loads (physics.host.rigidity)
    # what it touches with (README.md#contact): 'shape' (its own), or a list of geometries
    collision: Literal['shape'] | list[Collision] | None = None
    friction: Annotated[Number, Field(ge=0.0)] | None = None   # its own Coulomb μ

    @model_validator(mode='after')
    def _density_or_mass(self):
        if self.collision == 'shape' and self.shape is None:
            raise ValueError("collision: 'shape' needs a shape (or give a list of geometries)")
        if self.inertia is not None:
            if self.mass is None or self.density is not None:
                raise ValueError('inertia needs mass [kg] (and no density)')
            ixx, iyy, izz = self.inertia
            if min(iyy + izz - ixx, ixx + izz - iyy, ixx + iyy - izz) <= 0.0:
                raise ValueError(f'principal moments {list(self.inertia)} must satisfy the '
                                 'triangle inequality strictly (each less than the sum of the '
                                 'other two)')
            return self
        if self.shape is None and not (self.fixed and self.mass is not None):
            raise ValueError('give a shape (or mass and inertia; a fixed body may give mass '
                             'alone)')
        if (self.density is None) == (self.mass is None):
            raise ValueError('give exactly one of density [kg/m^3] or mass [kg]')
        return self


class Frame(StrictModel):
    """A named frame rigidly attached to a body (a URDF link frame), its pose in the body's
    frame: ``position`` [m] and ``orientation``; ``parent``: the frame it hangs from on /tf (a
    URDF link's parent link; None: the node's world frame, ``frame_id``)."""

    name: Name
    body: str
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Orientation | None = None
    parent: str | None = None


SENSOR_TYPES = ('imu', 'contact')


class Sensor(StrictModel):
    """A sensor (README.md#sensors; values: ``affine_joint_sim.sensors``): ``name`` (its
    topic ``sensors/<name>``: a ROS topic token), ``type`` (``imu`` | ``contact``) and
    ``body``: a frame of the scene's ``frames`` (a URDF link, welded ones included: the sensor
    sits at the link frame) or else a body (the sensor sits at the body frame)."""

    name: Name
    type: Literal[SENSOR_TYPES]
    body: str


class Mesh(StrictModel):
    """A mesh file drawn by viewers (never used by the physics): ``uri`` as the URDF gives it
    (``package://``, ``file://`` or a path), ``path`` the file found for it on this machine
    (None: not found, drawn as ``fallback``, a box [m]), ``scale`` per axis."""

    uri: str
    path: str | None = None
    scale: Vec3 = (1.0, 1.0, 1.0)
    fallback: tuple[PositiveFloat, PositiveFloat, PositiveFloat] = (0.05, 0.05, 0.05)


class Geometry(OneOf):
    """What a visual draws: exactly one of ``box``, ``cylinder``, ``sphere`` (as a Shape) or
    ``mesh``."""

    box: tuple[PositiveFloat, PositiveFloat, PositiveFloat] | None = None
    cylinder: Cylinder | None = None
    sphere: Sphere | None = None
    mesh: Mesh | None = None

    KINDS = ('box', 'cylinder', 'sphere', 'mesh')


class Visual(StrictModel):
    """A shape viewers draw on a body (a URDF ``<visual>``): its pose in the body's frame
    (``position`` [m], ``orientation``), its geometry and its RGBA colour (0–1; None: the
    palette's colour of the body)."""

    body: str
    geometry: Geometry
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Orientation | None = None
    color: tuple[Number, Number, Number, Number] | None = None


class Limit(StrictModel):
    """Joint limit (UID 670 revolute [rad], UID 669 prismatic [m]) on the reported coordinate:
    a cubic penalty inside the implicit step, s((x−u)/(u−l))³ above u, s((l−x)/(u−l))³ below l
    (s|x−l|³ when u = l); its physical stiffness scales with 1/dt² like the joint's."""

    lower: Number
    upper: Number
    strength: PositiveFloat = 1.0e3

    @model_validator(mode='after')
    def _ordered(self):
        if self.lower > self.upper:
            raise ValueError(f'lower ({self.lower:g}) must be <= upper ({self.upper:g})')
        return self


class Drive(StrictModel):
    """Position drive (UID 19 revolute; its prismatic analogue): a spring K/2 (x − target)²
    inside the implicit step, K = strength_ratio (m_P + m_C) (physical stiffness K/dt²)."""

    target: Number = 0.0
    strength_ratio: PositiveFloat = 100.0
    enabled: bool = True


class Mimic(StrictModel):
    """A mimic joint's coupling (URDF ``<mimic>``): its coordinate follows x = multiplier ·
    x_leader + offset [rad | m] through a spring K/2 (x − multiplier x_leader − offset)² inside
    the implicit step, K = strength_ratio (m_P + m_C) of the follower's bodies (physical
    stiffness K/dt², like a joint's). The follower takes no commands."""

    joint: Name
    multiplier: Number = 1.0
    offset: Number = 0.0
    strength_ratio: PositiveFloat = 1000.0


class Joint(StrictModel):
    """A joint: ``revolute`` (UID 18, torque UID 668), ``prismatic`` (UID 20, force UID 667)
    or ``fixed`` (UID 25). ``torque`` is N·m for revolute and N for prismatic joints.
    ``initial_position`` is the coordinate it reports at t = 0 [rad | m] (the bodies stand
    there: a URDF's joint coordinates); limits, drive targets and reports share its origin."""

    name: Name
    type: Literal[JOINT_KIND_NAMES] = 'revolute'
    parent: str
    child: str
    x0: Vec3 | None = None
    x1: Vec3 | None = None
    strength_ratio: PositiveFloat = 1000.0    # K = strength_ratio (m_P + m_C) [kg]
    torque: Number = 0.0
    enabled: bool = True
    torque_model: Literal['lever_arm', 'generalized'] = 'lever_arm'
    angle_mode: Literal['wrapped', 'continuous'] = 'wrapped'
    effort_limit: Annotated[float, Field(gt=0.0, allow_inf_nan=True),
                            BeforeValidator(not_a_boolean)] = math.inf
    limit: Limit | None = None
    damping: Annotated[Number, Field(ge=0.0)] = 0.0
    friction: Annotated[Number, Field(ge=0.0)] = 0.0     # Coulomb friction [N·m | N]
    drive: Drive | None = None
    initial_position: Number = 0.0
    mimic: Mimic | None = None

    @model_validator(mode='after')
    def _keys_of_type(self):
        if math.isnan(self.effort_limit):
            raise ValueError('effort_limit must be a positive number or .inf, not NaN')
        # keys set away from their defaults (a dumped scene repeats the defaults)
        given = {key for key in self.model_fields_set
                 if getattr(self, key) != type(self).model_fields[key].default}
        kind = joint_kind(self.type)
        if not kind.takes_axis:
            extra = sorted(given & _MOVABLE_KEYS)
            if extra:
                raise ValueError(f'a fixed joint welds its bodies: it takes no {", ".join(extra)}'
                                 ' (its weld frame is the midpoint of the two body centres)')
            return self
        missing = [key for key in ('x0', 'x1') if getattr(self, key) is None]
        if missing:
            raise ValueError(f'a {self.type} joint needs {" and ".join(missing)} '
                             '(two world points on its axis at t = 0)')
        if not kind.periodic:
            extra = sorted(given & {'torque_model', 'angle_mode'})
            if extra:
                raise ValueError(f'{", ".join(extra)} applies to revolute joints only')
        if self.mimic is not None:
            commanded = sorted(given & {'torque', 'drive'})
            if commanded:
                raise ValueError(f'a mimic joint follows joint {self.mimic.joint!r}: it takes no '
                                 f'{" or ".join(commanded)}')
        limit = self.limit
        if limit is not None and not limit.lower <= self.initial_position <= limit.upper:
            # a limit entered that deep rejects every step: the joint would never move
            raise ValueError(f'initial_position {self.initial_position:g} is outside the limit '
                             f'[{limit.lower:g}, {limit.upper:g}]')
        return self


_MOVABLE_KEYS = {'x0', 'x1', 'torque', 'enabled', 'torque_model', 'angle_mode', 'effort_limit',
                 'limit', 'damping', 'friction', 'drive', 'initial_position', 'mimic'}


NEWTON_MAX_ITER = 32             # Newton iterations per step at most, by default
NEWTON_MAX_ITER_CONTACT = 256    # the same in a scene with contact


class Solver(StrictModel):
    """Speed/accuracy knobs (docs/physics.md#solver-settings)."""

    integrator: Literal['bdf1', 'bdf2'] = 'bdf2'
    newton_tol: PositiveFloat = 1.0e-4
    # None: Scene.newton_max_iter's default (more where the scene has contact)
    newton_max_iter: Annotated[int, Field(ge=1, le=1000)] | None = None
    line_search: bool = True
    warm_start: bool = True
    precision: Literal['float64', 'float32'] = 'float64'


SceneName = Annotated[str, Field(min_length=1)]


class Robot(StrictModel):
    """One robot of a scene of several (README.md#several-robots): its bodies, joints and
    frames are the scene's entries named ``<name>/...`` (a URDF's link and joint names under
    that prefix, which is also its links' frame prefix on /tf); its topics (``joint_states``,
    ``joint_commands``, the command arrays, per-joint topics, ``robot_description``) go under
    ``namespace`` (relative to the node's namespace), its joints named there as in its URDF."""

    name: Annotated[str, Field(pattern=r'^[A-Za-z][A-Za-z0-9_]*$')]
    namespace: Annotated[str, Field(pattern=r'^[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*$')]

    @property
    def prefix(self) -> str:
        """The prefix of its entries' names in the scene: ``<name>/``."""
        return self.name + '/'


class SceneSettings(StrictModel):
    """A scene's settings beside its bodies and joints: ``name``, time step ``dt`` [s],
    ``gravity`` [m/s², world frame] and ``solver``. A scene YAML gives them at its top level,
    beside ``bodies`` (``Scene``) or beside ``urdf:`` (``urdf.UrdfOptions``)."""

    name: SceneName = 'scene'
    # below 1 µs the stamps (integer ns per step) would stop resolving a step
    dt: Annotated[Number, Field(ge=1.0e-6)] = 0.01
    gravity: Vec3 = (0.0, 0.0, -9.81)
    solver: Solver = Solver()


def looks_like_urdf(path: Path) -> bool:
    """Whether ``Scene.load`` reads the file as a URDF: it starts, after a byte-order mark and
    blank space, with ``<`` (an XML declaration, a comment or <robot>), which YAML never does.
    False when it cannot be read (the YAML reader then says why)."""
    try:
        with path.open('rb') as file:
            head = file.read(4096)
    except OSError:
        return False
    for bom in (b'\xef\xbb\xbf', b'\xff\xfe', b'\xfe\xff'):
        head = head.removeprefix(bom)
    return head.replace(b'\x00', b'').lstrip().startswith(b'<')


class Scene(SceneSettings):
    """A validated scene. Build with ``Scene.from_yaml(path)`` or ``Scene.from_dict(d)``."""

    bodies: Annotated[list[Body], Field(min_length=1)]
    joints: list[Joint] = []
    contact: Contact | None = None      # None: no contact (unless ground is given)
    ground: Ground | None = None        # static half-spaces (README.md#contact)
    frames: list[Frame] = []
    # what viewers draw; empty: every body's shape (a URDF scene lists its links' visuals)
    visuals: list[Visual] = []
    sensors: list[Sensor] = []          # README.md#sensors
    robots: list[Robot] = []            # README.md#several-robots; empty: one robot or none
    _robot_description: str | None = PrivateAttr(default=None)
    _robot_descriptions: dict[str, str] = PrivateAttr(default_factory=dict)

    @property
    def robot_description(self) -> str | None:
        """The URDF text the scene was built from (None for a scene written as YAML or
        listing several robots)."""
        return self._robot_description

    @property
    def robot_descriptions(self) -> dict[str, str]:
        """Each robot's URDF text by robot name (a scene loaded from ``robots:`` entries with
        ``urdf:``; empty otherwise)."""
        return self._robot_descriptions

    @classmethod
    def load(cls, path, **overrides) -> 'Scene':
        """A scene file, told by its content whatever its name (``.urdf``, ``.xml``,
        ``.xacro``, none): XML is a URDF, read with default settings; anything else a scene
        YAML. ``overrides`` replace top-level keys of the file (``ground=[{'height': 0.0}]``;
        for a URDF, or a YAML naming one, the ``urdf:`` entry's keys)."""
        if looks_like_urdf(Path(path)):
            return cls.from_urdf(path, **overrides)
        return cls.from_yaml(path, overrides)

    @classmethod
    def from_urdf(cls, path, **overrides) -> 'Scene':
        """A URDF robot (README.md#robots-from-urdf), with the overrides of a scene YAML's
        ``urdf:`` entry (``name``, ``dt``, ``gravity``, ``solver``, ``fixed_base``,
        ``merge_fixed``, ``initial_positions``, ``package_paths``, ``joints``, ``base``,
        ``contact``, ``ground``, ``sensors``: their ``body`` a link name)."""
        return cls._from_urdf(Path(path), overrides, source=str(path))

    @classmethod
    def from_dict(cls, data, source: str = '<dict>') -> 'Scene':
        """Validate a plain dict (as read from YAML); raise SceneError naming ``source``."""
        if not isinstance(data, dict):
            raise SceneError(f'{source}: a scene must be a mapping, got {type(data).__name__}')
        try:
            scene = cls.model_validate(data)
        except ValidationError as exc:
            raise SceneError(validation_report(source, exc, cls)) from None
        problems = scene._cross_check()
        if problems:
            raise SceneError(_format_errors(source, problems))
        return scene

    @classmethod
    def from_yaml(cls, path, overrides: dict | None = None) -> 'Scene':
        """Load and validate a scene file, ``overrides`` replacing its top-level keys."""
        path = Path(path)
        try:
            text = path.read_text(encoding='utf-8')
        except OSError as exc:
            raise SceneError(f'{path}: cannot read scene file ({exc.strerror})') from None
        except UnicodeDecodeError as exc:
            raise SceneError(f'{path}: not a UTF-8 text file (byte {exc.start}: {exc.reason}); '
                             'a scene is YAML text') from None
        return cls.from_yaml_text(text, source=str(path), base_dir=path.parent,
                                  overrides=overrides)

    @classmethod
    def from_yaml_text(cls, text: str, source: str = '<yaml>',
                       solver_defaults: dict | None = None, base_dir=None,
                       overrides: dict | None = None) -> 'Scene':
        """Validate a scene given as YAML text (e.g. the copy stored in a bag);
        ``solver_defaults`` fill solver keys the text does not give, ``overrides`` replace
        top-level keys; a ``urdf:`` path is relative to ``base_dir`` (default: the working
        directory)."""
        try:
            data = yaml.load(text, Loader=_SceneLoader)
        except yaml.YAMLError as exc:
            raise SceneError(f'{source}: not valid YAML: {exc}') from None
        except RecursionError:
            raise SceneError(f'{source}: YAML nested too deeply to be a scene') from None
        if solver_defaults and isinstance(data, dict) and isinstance(data.get('solver', {}), dict):
            data['solver'] = dict(solver_defaults, **data.get('solver', {}))
        if overrides and isinstance(data, dict):
            data.update(overrides)
        if isinstance(data, dict) and 'urdf' in data:
            return cls._from_urdf_entry(data, base_dir, source)
        if isinstance(data, dict) and _lists_urdf_robots(data.get('robots')):
            from affine_joint_sim.urdf.robots import robots_scene_data
            data, descriptions = robots_scene_data(data, Path(base_dir or '.'), source)
            scene = cls.from_dict(data, source=source)
            scene._robot_descriptions = descriptions
            return scene
        _find_collision_meshes(data, Path(base_dir or '.'))
        return cls.from_dict(data, source=source)

    @classmethod
    def _from_urdf_entry(cls, data: dict, base_dir, source: str) -> 'Scene':
        """A scene YAML naming ``urdf: path`` (relative to the YAML) with overrides."""
        overrides = dict(data)
        path = overrides.pop('urdf')
        if not isinstance(path, str) or not path:
            raise SceneError(f'{source}: urdf: must be the path of a URDF file (got {path!r})')
        path = Path(base_dir or '.') / path
        return cls._from_urdf(path, overrides, source=f'{source} (urdf: {path})')

    @classmethod
    def _from_urdf(cls, path: Path, overrides: dict, source: str) -> 'Scene':
        """The scene of the URDF at ``path`` with ``overrides``; its robot description is the
        URDF text. SceneError naming ``source`` on bad input."""
        from affine_joint_sim.urdf import urdf_scene_data
        data, text = urdf_scene_data(path, overrides, source)
        scene = cls.from_dict(data, source=source)
        scene._robot_description = text
        return scene

    def to_yaml(self) -> str:
        """The scene as YAML text that ``from_yaml_text`` reads back to an equal scene."""
        return yaml.safe_dump(self.model_dump(mode='json', exclude_none=True), sort_keys=False)

    def body_index(self, name: str) -> int:
        """Index of a body by name (KeyError naming the valid ones)."""
        return _index(name, [b.name for b in self.bodies], 'body')

    def joint_index(self, name: str) -> int:
        """Index of a joint by name (KeyError naming the valid ones)."""
        return _index(name, [j.name for j in self.joints], 'joint')

    def _cross_check(self) -> list[tuple[str, str]]:
        """Checks across entries: unique names, known parents, distinct axis points, a forest."""
        problems = []
        body_names = [b.name for b in self.bodies]
        problems += _duplicates('bodies', body_names)
        problems += _duplicates('joints', [j.name for j in self.joints])
        valid = ', '.join(body_names)
        for i, joint in enumerate(self.joints):
            for key in ('parent', 'child'):
                if getattr(joint, key) not in body_names:
                    problems.append((f'joints[{i}].{key}',
                                     f'unknown body {getattr(joint, key)!r}; valid: {valid}'))
            if joint.parent == joint.child:
                problems.append((f'joints[{i}].child', 'parent and child must differ'))
            if joint.x0 is not None and math.dist(joint.x0, joint.x1) < 1e-9:
                problems.append((f'joints[{i}].x1', 'x1 must differ from x0 (the axis is x1 - x0)'))
        problems += self._robot_problems()
        problems += _token_clashes([(self.robot_of(j.name), self.local_name(j.name))
                                    for j in self.joints])
        problems += self._mimic_problems()
        problems += _duplicates('frames', [f.name for f in self.frames])
        frame_names = [f.name for f in self.frames]
        for i, frame in enumerate(self.frames):
            if frame.parent is not None and frame.parent not in frame_names:
                problems.append((f'frames[{i}].parent', f'unknown frame {frame.parent!r}; '
                                 f'valid: {", ".join(frame_names)}'))
        for section, items in (('frames', self.frames), ('visuals', self.visuals)):
            for i, item in enumerate(items):
                if item.body not in body_names:
                    problems.append((f'{section}[{i}].body', f'unknown body {item.body!r}; '
                                     f'valid: {valid}'))
        problems += self._sensor_problems()
        for k, pair in enumerate(self.contact.exclude if self.contact else []):
            for name in pair:
                if name not in body_names:
                    problems.append((f'contact.exclude[{k}]', f'unknown body {name!r}; valid: '
                                     f'{valid}'))
        if not problems:
            problems += self._closed_loops()
        return problems

    def robot_of(self, name: str) -> Robot | None:
        """The robot whose entry (body, joint or frame) ``name`` is, or None."""
        return next((r for r in self.robots if name.startswith(r.prefix)), None)

    def local_name(self, name: str) -> str:
        """An entry's name within its robot (its URDF name), or ``name`` outside robots."""
        robot = self.robot_of(name)
        return name if robot is None else name[len(robot.prefix):]

    def _robot_problems(self) -> list[tuple[str, str]]:
        """Robots: unique names and namespaces, each owning at least one body."""
        problems = _duplicates('robots', [r.name for r in self.robots])
        seen = {}
        for i, robot in enumerate(self.robots):
            if robot.namespace in seen:
                problems.append((f'robots[{i}].namespace', f'{robot.namespace!r} is also '
                                 f'robots[{seen[robot.namespace]}]\'s: each robot needs its own'))
            seen.setdefault(robot.namespace, i)
            if not any(b.name.startswith(robot.prefix) for b in self.bodies):
                problems.append((f'robots[{i}].name', f'no body is named {robot.prefix}...: a '
                                 "robot's bodies are named <robot>/<link>"))
        return problems

    def _mimic_problems(self) -> list[tuple[str, str]]:
        """Mimics: each follows another movable joint, and no chain of them closes a loop."""
        problems = []
        kinds = {j.name: joint_kind(j.type) for j in self.joints}
        leader = {j.name: j.mimic.joint for j in self.joints if j.mimic is not None}
        for i, joint in enumerate(self.joints):
            if joint.mimic is None:
                continue
            name = joint.mimic.joint
            movable = [j for j, kind in kinds.items() if kind.takes_axis and j != joint.name]
            if name not in kinds or name == joint.name or not kinds[name].takes_axis:
                problems.append((f'joints[{i}].mimic.joint', f'{name!r} is not another revolute '
                                 f'or prismatic joint; valid: {", ".join(movable)}'))
                continue
            seen, at = {joint.name}, name
            while at in leader and at not in seen:
                seen.add(at)
                at = leader[at]
            if at in seen:
                problems.append((f'joints[{i}].mimic.joint', f'the mimics from '
                                 f'{joint.name!r} through {name!r} form a loop: one joint of a '
                                 'chain must move on its own'))
        return problems

    def _sensor_problems(self) -> list[tuple[str, str]]:
        """Sensors: unique names that are ROS topic tokens, on a known frame or body."""
        problems = _duplicates('sensors', [s.name for s in self.sensors])
        places = list(dict.fromkeys([f.name for f in self.frames] + [b.name for b in self.bodies]))
        for i, sensor in enumerate(self.sensors):
            token = topic_token(sensor.name)
            if token != sensor.name:
                problems.append((f'sensors[{i}].name', f'{sensor.name!r} is not a ROS topic token '
                                 '(letters, digits and single underscores, not starting with a '
                                 f'digit or ending with an underscore; e.g. {token!r})'))
            if sensor.body not in places:
                what = 'link or body' if self.frames else 'body'
                problems.append((f'sensors[{i}].body', f'unknown {what} {sensor.body!r}; valid: '
                                 f'{", ".join(places)}'))
        return problems

    @property
    def newton_max_iter(self) -> int:
        """Newton iterations per step at most: ``solver.newton_max_iter`` if given, else
        NEWTON_MAX_ITER, or NEWTON_MAX_ITER_CONTACT in a scene with contact (a ground or a
        ``contact`` entry), where an impact's barrier can take many more (docs/physics.md)."""
        if self.solver.newton_max_iter is not None:
            return self.solver.newton_max_iter
        contact = self.contact is not None or self.ground is not None
        return NEWTON_MAX_ITER_CONTACT if contact else NEWTON_MAX_ITER

    def articulations(self) -> tuple[list[int], set]:
        """(an articulation index per body: bodies joined by joints, directly or through
        others, share one; the set of directly jointed body index pairs, both orders)."""
        sets, jointed = _DisjointSets(len(self.bodies)), set()
        for joint in self.joints:
            a, b = self.body_index(joint.parent), self.body_index(joint.child)
            sets.join(a, b)
            jointed |= {(a, b), (b, a)}
        return [sets.find(i) for i in range(len(self.bodies))], jointed

    def _closed_loops(self) -> list[tuple[str, str]]:
        """Joints must form a forest: report the joints of the first closed loop found."""
        sets = _DisjointSets(len(self.bodies))
        for i, joint in enumerate(self.joints):
            if not sets.join(self.body_index(joint.parent), self.body_index(joint.child)):
                loop = self._path_joints(joint.parent, joint.child, upto=i) + [joint.name]
                return [(f'joints[{i}]', 'joints form a closed loop (' + ', '.join(loop) +
                         '); only trees of joints are supported')]
        return []

    def _path_joints(self, start: str, goal: str, upto: int) -> list[str]:
        """Names of the joints on the path start -> goal among joints[:upto] (a forest)."""
        edges = {}
        for joint in self.joints[:upto]:
            edges.setdefault(joint.parent, []).append((joint.child, joint.name))
            edges.setdefault(joint.child, []).append((joint.parent, joint.name))
        stack, seen = [(start, [])], {start}
        while stack:
            body, path = stack.pop()
            if body == goal:
                return path
            for other, name in edges.get(body, []):
                if other not in seen:
                    seen.add(other)
                    stack.append((other, path + [name]))
        return []


class _DisjointSets:
    """Union–find over 0..n−1."""

    def __init__(self, n: int):
        self._root = list(range(n))

    def find(self, i: int) -> int:
        root = self._root
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    def join(self, a: int, b: int) -> bool:
        """Join the sets of a and b; False if they were one already."""
        a, b = self.find(a), self.find(b)
        self._root[a] = b
        return a != b


def _find_collision_meshes(data, base_dir: Path) -> None:
    """Give each collision mesh of a scene dict without a ``path`` the file its ``uri`` names
    relative to ``base_dir`` (the scene file's directory), when that file exists (else the
    contact model says it is not found)."""
    bodies = data.get('bodies') if isinstance(data, dict) else None
    for body in bodies if isinstance(bodies, list) else []:
        collision = body.get('collision') if isinstance(body, dict) else None
        for geometry in collision if isinstance(collision, list) else []:
            mesh = geometry.get('mesh') if isinstance(geometry, dict) else None
            if isinstance(mesh, dict) and isinstance(mesh.get('uri'), str) \
                    and mesh.get('path') is None:
                uri = mesh['uri']
                found = (Path(unquote(uri[len('file://'):])) if uri.startswith('file://')
                         else base_dir / uri)
                if found.is_file():
                    mesh['path'] = str(found.resolve())


class _SceneLoader(yaml.SafeLoader):
    """SafeLoader that also reads ``1.0e8`` (no exponent sign) as a float, unlike YAML 1.1."""


_SceneLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'''^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                   |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                   |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                   |[-+]?\.(?:inf|Inf|INF)
                   |\.(?:nan|NaN|NAN))$''', re.X),
    list('-+0123456789.'))


def _index(name: str, names: list[str], what: str) -> int:
    try:
        return names.index(name)
    except ValueError:
        raise KeyError(f'unknown {what} {name!r}; valid: {", ".join(names) or "none"}') from None


def _duplicates(section: str, names: list[str]) -> list[tuple[str, str]]:
    seen, problems = {}, []
    for i, name in enumerate(names):
        if name in seen:
            problems.append((f'{section}[{i}].name',
                             f'duplicate name {name!r} (also {section}[{seen[name]}])'))
        seen.setdefault(name, i)
    return problems


def _lists_urdf_robots(robots) -> bool:
    """Whether a scene dict's ``robots`` lists URDF files to load (entries with ``urdf:``),
    not the robots of a loaded scene (``Robot``)."""
    return isinstance(robots, list) and any(isinstance(r, dict) and 'urdf' in r for r in robots)


def _token_clashes(names: list[tuple]) -> list[tuple[str, str]]:
    """Joint names (robot, name within it) that would share a per-joint topic (``a-b`` and
    ``a_b`` of one robot); the same name in two robots is two topics in two namespaces."""
    seen, problems = {}, []
    for i, (robot, name) in enumerate(names):
        key = (None if robot is None else robot.name, topic_token(name))
        if key in seen and names[seen[key]][1] != name:
            problems.append((f'joints[{i}].name', f'{name!r} and {names[seen[key]][1]!r} '
                             f'(joints[{seen[key]}]) share the topic token {key[1]!r}'))
        seen.setdefault(key, i)
    return problems


def _key_path(loc) -> str:
    path = ''
    for part in loc:
        if isinstance(part, int):
            path += f'[{part}]'
        elif part in ('function-after', 'tagged-union') or '[' in str(part):
            continue
        else:
            path += ('.' if path else '') + str(part)
    return path or '<top>'


def validation_report(source: str, exc: ValidationError, model, what: str = 'scene') -> str:
    """The problems of a pydantic ValidationError of ``model`` (the validated root: a Scene,
    the overrides of a URDF scene, a sweep spec), one line per key path, under ``source``:
    an invalid ``what``."""
    return _format_errors(source, [(_key_path(err['loc']), _message(err, model))
                                   for err in exc.errors()], what)


def _message(err, model) -> str:
    if err['type'] == 'extra_forbidden':
        return f'unknown key; valid keys here: {_valid_keys(err["loc"][:-1], model)}'
    if err['type'] == 'finite_number':
        return 'must be a finite number (NaN and Inf are not allowed)'
    msg = err['msg'].removeprefix('Value error, ')
    if err['type'] == 'string_pattern_mismatch':
        msg = 'must be a non-empty name without whitespace'
    return f'{msg} (got {err["input"]!r})' if 'input' in err and err['type'] != 'missing' \
        and not isinstance(err['input'], (dict, list)) else msg


def _valid_keys(loc, model) -> str:
    """The field names allowed at ``loc`` (a pydantic location below ``model``), for unknown-key
    errors."""
    for part in loc:
        if isinstance(part, int):
            continue
        annotation = model.model_fields[part].annotation
        model = next((t for t in _flatten(annotation)
                      if isinstance(t, type) and issubclass(t, BaseModel)), None)
        if model is None:
            return '?'
    return ', '.join(model.model_fields)


def _flatten(annotation):
    args = getattr(annotation, '__args__', None)
    if not args:
        return [annotation]
    return [t for a in args for t in _flatten(a)]


def _format_errors(source: str, problems: list[tuple[str, str]], what: str = 'scene') -> str:
    lines = [f'{source}: invalid {what} ({len(problems)} problem{"s" * (len(problems) > 1)})']
    lines += [f'  {path}: {message}' for path, message in problems]
    return '\n'.join(lines)
