"""A URDF robot as a scene (README.md#robots-from-urdf): bodies, joints and link frames.

What becomes what:
- Links welded by ``fixed`` joints are one body (mass, COM and inertia combined by the
  parallel-axis rule); a link without mass is always welded to its parent this way (it carries
  frames only). With ``merge_fixed: false`` massive links stay bodies joined by fixed joints
  (UID 25).
- Every body's rest frame is its principal frame at its COM (``urdf.inertia``). The root body
  is fixed to the world at the root link's frame (``fixed_base: true``) or free.
- ``revolute`` → UID 18 with its ``<limit lower upper>`` as a limit (UID 670) and
  ``<limit effort>`` as effort_limit; ``continuous`` → UID 18 without limit; ``prismatic`` →
  UID 20 with its limit (UID 669); ``<dynamics damping>`` → damping, ``<dynamics friction>``
  → friction (Coulomb). Angles are multi-turn (``angle_mode: continuous``), torques pure
  couples (``torque_model: generalized``). ``floating`` → the child is a free body;
  ``planar`` → error; ``<mimic joint multiplier offset>`` → a mimic coupling to that joint
  (the follower starts where its leader puts it unless ``initial_positions`` names it).
- Visuals (``urdf.visuals``) keep their pose on the body, geometry, colour and mesh URIs.
- With ``contact`` or ``ground`` given, each link's ``<collision>`` elements become its body's
  collision geometry at their pose in the body frame (meshes found as visuals are; one that
  is not found is an error). ``base`` places the root link in the world.
- ``initial_positions`` place the bodies by forward kinematics; every joint reports its URDF
  coordinate (``initial_position``). The joint's axis points x0, x1 lie ``ANCHOR_HALF_LENGTH``
  either side of the joint origin along its axis.
"""

import math
import warnings
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import Field, ValidationError

from affine_joint_sim import portable_math as pm
from affine_joint_sim.contact_schema import Contact, Ground, Origin
from affine_joint_sim.physics.host.mass import inertia_mass_properties
from affine_joint_sim.rotations import (axis_rotation, pose_matrix, quaternion_from_matrix,
                                        rpy_from_matrix)
from affine_joint_sim.scene import (Body, Number, SceneError, SceneName, SceneSettings,
                                    Sensor, validation_report)
from affine_joint_sim.sim_warnings import SimulationWarning, summarised
from affine_joint_sim.urdf.inertia import (LinkInertia, combine, physical_moments,
                                           principal_frame)
from affine_joint_sim.urdf.packages import resolve_uri
from affine_joint_sim.urdf.read import read_urdf
from affine_joint_sim.urdf.srdf import disabled_pairs
from affine_joint_sim.urdf.visuals import link_visuals

__all__ = ['urdf_scene_data', 'UrdfOptions', 'ANCHOR_HALF_LENGTH', 'object_entries']

# Half the distance between a joint's two axis points x0, x1 [m]: the hinge's stiffness against
# bending grows with its square (0.1 m halves the gap of the arm6 falling onto its limits).
ANCHOR_HALF_LENGTH = 0.1
# URDF joint types with a coordinate
_MOVING = ('revolute', 'continuous', 'prismatic')


class UrdfOptions(SceneSettings):
    """The overrides of a URDF scene (a scene YAML's keys beside ``urdf:``): the scene
    settings, ``name`` defaulting to the robot's, and how the robot becomes bodies."""

    name: SceneName | None = None       # None: the robot's name, else the file's stem
    fixed_base: bool = True
    merge_fixed: bool = True
    initial_positions: dict[str, Number] = {}
    # kg: a moving body lighter than this (a massless intermediate link) gets this mass, as
    # MuJoCo's boundmass does; 0 leaves masses as the URDF gives them
    min_mass: Annotated[float, Field(ge=0.0, allow_inf_nan=False)] = 0.0
    package_paths: dict[str, str] = {}
    joints: dict[str, dict] = {}
    base: Origin = Origin()             # the root link's pose in the world
    contact: Contact | None = None      # as a scene's; with ground: <collision> is used
    ground: Ground | None = None
    sensors: list[Sensor] = []          # as a scene's; body: a link name (README.md#sensors)
    srdf: str | None = None             # its <disable_collisions> join contact.exclude
    # bodies beside the robot, each on its own (a fixed table, a free box to grasp), as a
    # scene's ``bodies`` entries in the world frame; drawn as their shapes, each with a frame
    # of its name at its origin (body_poses)
    objects: list[Body] = []


def urdf_scene_data(path, overrides: dict, source: str) -> tuple[dict, str]:
    """The scene dict (for ``Scene.from_dict``) of the URDF at ``path`` with ``overrides``
    (``UrdfOptions``), and the URDF text. SceneError naming ``source`` on bad input, a
    SimulationWarning summing up the URDF features simulated differently from what it says
    (``sim_warnings.summarised``: one SimulationDetail each)."""
    try:
        options = UrdfOptions.model_validate(overrides)
    except ValidationError as exc:
        raise SceneError(validation_report(source, exc, UrdfOptions)) from None
    with summarised(Path(path).name):
        text, robot, collisions, notes = read_urdf(path)
        for note in notes:
            _warn(note, 'visuals not drawn (geometry not readable)')
        return _Converter(robot, options, path, collisions).scene_dict(), text


def _warn(message: str, kind: str = '', size: float = 0.0, worst: str = '') -> None:
    """A SimulationWarning; with a ``kind``, an item of the load's summary."""
    warnings.warn(SimulationWarning(message, kind, size, worst), stacklevel=4)


class _Converter:
    """One URDF robot turned into a scene dict (one use)."""

    def __init__(self, robot, options: UrdfOptions, path, collisions: list):
        self.robot, self.options, self.path = robot, options, path
        self.collisions = collisions
        self._starts: dict[str, float] = {}       # joint name -> coordinate at t = 0
        self._implicit_world()
        self.links = {link.name: link for link in robot.links}
        self._check_names()
        self._check_masses()
        self.joint_of = {joint.child: joint for joint in robot.joints}   # child link → joint
        self.joint_named = {joint.name: joint for joint in robot.joints}
        self.root = self._root()
        self.order = self._tree_order()
        self.poses = self._forward_kinematics()
        self.local = {}         # link -> its pose in its body's frame, filled with the bodies

    def _fail(self, message: str):
        raise SceneError(f'{self.path}: {message}')

    def _implicit_world(self) -> None:
        """A joint whose parent is an undefined ``world`` link means the world (Drake's and
        Gazebo's convention): the link is added, and said."""
        names = {link.name for link in self.robot.links}
        if 'world' not in names and any(j.parent == 'world' for j in self.robot.joints):
            import yourdfpy
            self.robot.links.append(yourdfpy.Link(name='world'))
            _warn(f"{self.path}: link 'world' is not defined but a joint's parent: taken as "
                  'the world (a massless root link)', "undefined links 'world' taken as the "
                  'world')

    def _check_masses(self) -> None:
        """Masses are not negative (read.py checked that every number is finite)."""
        for link in self.robot.links:
            inertial = link.inertial
            if inertial is not None and inertial.mass is not None and inertial.mass < 0.0:
                self._fail(f'link {link.name!r}: negative mass ({inertial.mass:g} kg)')

    def _check_names(self) -> None:
        for kind, items in (('link', self.robot.links), ('joint', self.robot.joints)):
            seen = set()
            for item in items:
                if item.name in seen:
                    self._fail(f'duplicate {kind} name {item.name!r}')
                if not item.name.strip() or any(c.isspace() for c in item.name):
                    self._fail(f'{kind} name {item.name!r} contains whitespace')
                seen.add(item.name)
        for joint in self.robot.joints:
            for side in ('parent', 'child'):
                if getattr(joint, side) not in self.links:
                    self._fail(f'joint {joint.name!r}: its {side} link '
                               f'{getattr(joint, side)!r} is not defined')
        for joint in self.robot.joints:
            norm = pm.norm(_raw_axis(joint))
            if joint.type in _MOVING and not (np.isfinite(norm) and norm > 1e-9):
                self._fail(f'joint {joint.name!r}: <axis xyz> must be a non-zero vector (got '
                           f'{list(_raw_axis(joint))})')
        children = {}
        for joint in self.robot.joints:
            if joint.child in children:
                self._fail(f'link {joint.child!r} is the child of joints '
                           f'{children[joint.child]!r} and {joint.name!r}: a closed kinematic '
                           'loop (only trees of joints are supported)')
            children[joint.child] = joint.name

    def _root(self) -> str:
        roots = [name for name in self.links if name not in self.joint_of]
        if len(roots) != 1:
            if not roots:
                self._fail('no root link (every link is a child): the joints form a closed '
                           'loop')
            self._fail(f'{len(roots)} root links ({", ".join(roots)}): a URDF robot is one '
                       'tree of links')
        return roots[0]

    def _tree_order(self) -> list[str]:
        """Links parents first (breadth first from the root); a link left out is on a loop."""
        below = {}
        for joint in self.robot.joints:
            below.setdefault(joint.parent, []).append(joint.child)
        order, frontier = [], [self.root]
        while frontier:
            order += frontier
            frontier = [c for link in frontier for c in below.get(link, [])]
        if len(order) != len(self.links):
            loop = sorted(set(self.links) - set(order))
            self._fail(f'links {", ".join(loop)} are not connected to the root '
                       f'{self.root!r}: their joints form a closed loop')
        return order

    def _joint_position(self, joint) -> float:
        """The joint's coordinate at t = 0 [rad | m]: its ``initial_positions`` entry (refused
        outside the joint's limits: a limit entered that deep rejects every step), else for a
        mimic joint where its leader puts it, else 0, else (a robot whose zero position is
        outside its limits, as some exports are) its nearest limit, said once."""
        if joint.name in self._starts:
            return self._starts[joint.name]
        bounds = self._start_bounds(joint)
        unit = 'm' if joint.type == 'prismatic' else 'rad'
        if joint.name in self.options.initial_positions:
            start = float(self.options.initial_positions[joint.name])
            if bounds is not None and not bounds[0] <= start <= bounds[1]:
                self._fail(f'initial_positions: {joint.name!r} = {start:g} {unit} is outside the '
                           f'joint\'s limits [{bounds[0]:g}, {bounds[1]:g}] {unit}')
        elif joint.mimic is not None and joint.mimic.joint in self.joint_named:
            self._starts[joint.name] = 0.0      # (a loop of mimics ends here; refused later)
            mimic = self._mimic(joint)
            start = (mimic['multiplier'] * self._joint_position(self.joint_named[mimic['joint']])
                     + mimic['offset'])
        elif bounds is not None and not bounds[0] <= 0.0 <= bounds[1]:
            start = bounds[0] if bounds[0] > 0.0 else bounds[1]
            _warn(f'{self.path}: joint {joint.name!r} starts at its '
                  f'{"lower" if start == bounds[0] else "upper"} limit {start:g} {unit}: its '
                  f'zero position is outside its limits [{bounds[0]:g}, {bounds[1]:g}] (choose '
                  'another start with initial_positions)',
                  'joints starting at a limit (zero outside their limits)', abs(start),
                  f'{joint.name!r} {start:g} {unit}')
        else:
            start = 0.0
        self._starts[joint.name] = start
        return start

    def _start_bounds(self, joint) -> tuple[float, float] | None:
        """The limits [lower, upper] the joint will have (an override's, else the URDF's), or
        None when it has none."""
        override = self.options.joints.get(joint.name, {})
        if 'limit' in override:
            limit = override['limit']
            return None if not isinstance(limit, dict) else (float(limit.get('lower', 0.0)),
                                                              float(limit.get('upper', 0.0)))
        limit = joint.limit
        if joint.type == 'continuous' or limit is None:
            return None
        bounds = float(limit.lower or 0.0), float(limit.upper or 0.0)   # URDF: missing is 0
        return bounds if all(math.isfinite(b) for b in bounds) else None

    def _forward_kinematics(self) -> dict:
        """World pose (4×4) of every link at the initial joint positions; root at ``base``."""
        movable = [j.name for j in self.robot.joints if j.type in _MOVING]
        unknown = sorted(set(self.options.initial_positions) - set(movable))
        if unknown:
            self._fail(f'initial_positions: {", ".join(map(repr, unknown))} is not a revolute, '
                       f'continuous or prismatic joint (valid: {", ".join(movable)})')
        poses = {self.root: pose_matrix(self.options.base.xyz, self.options.base.rpy)}
        for link in self.order[1:]:
            joint = self.joint_of[link]
            poses[link] = pm.matmul(pm.matmul(poses[joint.parent], _origin(joint)),
                                    _motion(joint, self._joint_position(joint)))
        return poses

    # ---- bodies --------------------------------------------------------------------------

    def _welded(self, joint) -> bool:
        """A fixed joint whose child becomes part of its parent's body."""
        if joint.type != 'fixed':
            return False
        if self.options.merge_fixed:
            return True
        return self._own_inertia(joint.child).mass <= 0.0

    def _own_inertia(self, link: str) -> LinkInertia:
        return LinkInertia.of_link(self.links[link].inertial, self.poses[link])

    def _groups(self) -> dict:
        """Body name (its top link) → the links welded into it, parents first."""
        body_of, groups = {}, {}
        for link in self.order:
            joint = self.joint_of.get(link)
            top = body_of[joint.parent] if joint is not None and self._welded(joint) else link
            body_of[link] = top
            groups.setdefault(top, []).append(link)
        self.body_of = body_of
        return groups

    def _body(self, name: str, links: list[str], fixed: bool, total_moving_mass: float) -> dict:
        inertia = combine([self._own_inertia(link) for link in links])
        pose = np.eye(4)
        if fixed:
            pose = self.poses[name]             # the root link's, at ``base``
            mass = inertia.mass if inertia.mass > 0.0 else total_moving_mass
            body = {'name': name, 'mass': max(mass, 1e-9), 'fixed': True,
                    'position': _list(pose[:3, 3]),
                    'orientation': {'quat_xyzw': quaternion_from_matrix(pose[:3, :3])}}
        else:
            if inertia.mass < self.options.min_mass:
                _warn(f'{self.path}: link {name!r} weighs {inertia.mass:g} kg: given min_mass '
                      f'{self.options.min_mass:g} kg', 'links given min_mass')
                inertia = LinkInertia(self.options.min_mass, inertia.com, inertia.inertia)
            if inertia.mass <= 0.0:
                if name == self.root:
                    self._fail(f'link {name!r} is the root of a free-base robot (fixed_base: '
                               'false) but has no mass: give it an <inertial> with mass > 0, '
                               'or keep fixed_base: true (a floating joint below it frees its '
                               'child already)')
                self._fail(f'link {name!r} moves (joint {self.joint_of[name].name!r}) but has '
                           'no mass: give it an <inertial> with mass > 0 (links welded to it '
                           'by fixed joints count), or set min_mass [kg] to give massless '
                           'links that mass')
            moments, axes = principal_frame(inertia.inertia)
            try:
                moments, change = physical_moments(inertia.mass, moments)
            except ValueError as exc:
                self._fail(f'link {name!r}: {exc}')
            if change:
                _warn(f'{self.path}: link {name!r}: {change}', 'inertias raised to be physical')
            pose[:3, :3], pose[:3, 3] = axes, inertia.com
            body = {'name': name, 'mass': inertia.mass, 'inertia': [float(m) for m in moments],
                    'position': _list(inertia.com),
                    'orientation': {'quat_xyzw': quaternion_from_matrix(axes)}}
        frames = []
        for link in links:
            local = pm.matmul(_rigid_inverse(pose), self.poses[link])
            self.local[link] = local
            joint = self.joint_of.get(link)
            frames.append({'name': link, 'body': name, 'position': _list(local[:3, 3]),
                           'orientation': {'quat_xyzw': quaternion_from_matrix(local[:3, :3])},
                           **({'parent': joint.parent} if joint is not None else {})})
        return body, frames

    # ---- joints --------------------------------------------------------------------------

    def _joint(self, joint) -> dict | None:
        """The scene joint of a URDF joint between two bodies (None: the child is free)."""
        kind = joint.type
        if kind == 'planar':
            self._fail(f'joint {joint.name!r}: planar joints are not supported (no affine '
                       'joint constitution models them); make it a fixed joint or a chain of '
                       'prismatic and revolute joints')
        if kind == 'floating':
            _warn(f'{self.path}: joint {joint.name!r} is floating: link {joint.child!r} moves '
                  'freely (no joint)', 'floating joints (their child moves freely)')
            return None
        out = {'name': joint.name, 'type': 'revolute' if kind == 'continuous' else kind,
               'parent': self.body_of[joint.parent], 'child': self.body_of[joint.child]}
        if kind == 'fixed':
            return out
        frame = pm.matmul(self.poses[joint.parent], _origin(joint))
        axis = pm.matmul(frame[:3, :3], _axis(joint))
        out['x0'] = _list(frame[:3, 3] - ANCHOR_HALF_LENGTH * axis)
        out['x1'] = _list(frame[:3, 3] + ANCHOR_HALF_LENGTH * axis)
        out['initial_position'] = self._joint_position(joint)
        if kind != 'prismatic':
            out['torque_model'] = 'generalized'
            out['angle_mode'] = 'continuous'
        limit = joint.limit
        if kind != 'continuous':
            out['limit'] = self._limit(joint)
        if limit is not None and limit.effort is not None and math.isfinite(limit.effort):
            if limit.effort > 0.0:
                out['effort_limit'] = float(limit.effort)
            else:
                _warn(f'{self.path}: joint {joint.name!r}: <limit effort="{limit.effort:g}"> '
                      'read as no effort limit (an effort limit of 0 would leave the joint '
                      'unactuated)', 'joints with <limit effort="0"> (no effort limit)')
        for key in ('damping', 'friction'):
            value = self._dynamics(joint, key)
            if value:
                out[key] = value
        if joint.mimic is not None:
            out['mimic'] = self._mimic(joint)
        return out

    def _dynamics(self, joint, key: str) -> float:
        """A ``<dynamics>`` attribute [N·m·s/rad | N·s/m or N·m | N], 0 when absent."""
        value = getattr(joint.dynamics, key, None) if joint.dynamics is not None else None
        if value is None:
            return 0.0
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not (math.isfinite(number) and number >= 0.0):
            self._fail(f'joint {joint.name!r}: <dynamics {key}="{value}"> must be a number '
                       '>= 0')
        return number

    def _limit(self, joint) -> dict | None:
        limit = joint.limit
        lower = None if limit is None else limit.lower
        upper = None if limit is None else limit.upper
        if lower is not None and upper is not None and math.isinf(lower) and lower < 0.0 \
                and math.isinf(upper) and upper > 0.0:
            return None                                  # explicitly unlimited
        if any(v is not None and not math.isfinite(v) for v in (lower, upper)):
            self._fail(f'joint {joint.name!r}: <limit lower="{lower}" upper="{upper}"> must be '
                       'finite, or -inf and inf together for no limit')
        if lower is None or upper is None:
            _warn(f'{self.path}: joint {joint.name!r} ({joint.type}) has no <limit lower upper>: '
                  'the URDF spec makes a missing bound 0, so it '
                  + ('cannot move' if not (lower or upper) else 'moves on one side of 0 only')
                  + '; give lower and upper, make it continuous, or override the limit '
                  f'away (joints: {{{joint.name}: {{limit: null}}}})',
                  'joints without <limit lower upper> (held at 0)')
        lower, upper = float(lower or 0.0), float(upper or 0.0)
        if lower > upper:
            self._fail(f'joint {joint.name!r}: <limit lower="{lower:g}"> is above '
                       f'upper="{upper:g}"')
        if lower == upper and None not in (getattr(limit, 'lower', None),
                                           getattr(limit, 'upper', None)):
            _warn(f'{self.path}: joint {joint.name!r} ({joint.type}) has lower = upper = '
                  f'{lower:g}: its limit locks it there; free it with joints: {{{joint.name}: '
                  '{limit: null}}, or make it continuous', 'joints locked by lower = upper')
        return {'lower': lower, 'upper': upper}

    def _mimic(self, joint) -> dict:
        """The scene's ``mimic`` entry of a URDF ``<mimic>`` (multiplier 1, offset 0 where
        not given)."""
        mimic = joint.mimic
        if mimic.joint not in self.joint_named:
            self._fail(f'joint {joint.name!r}: <mimic joint="{mimic.joint}"> names no joint of '
                       'the robot')
        return {'joint': mimic.joint,
                'multiplier': 1.0 if mimic.multiplier is None else float(mimic.multiplier),
                'offset': 0.0 if mimic.offset is None else float(mimic.offset)}

    # ---- the scene -----------------------------------------------------------------------

    def scene_dict(self) -> dict:
        groups = self._groups()
        moving_mass = sum(self._own_inertia(link).mass for link in self.order
                          if self.body_of[link] != self.root or not self.options.fixed_base)
        bodies, frames = [], []
        for name, links in groups.items():
            fixed = name == self.root and self.options.fixed_base
            body, body_frames = self._body(name, links, fixed, moving_mass)
            bodies.append(body)
            frames += body_frames
        if not self.options.fixed_base and any(self.options.gravity) \
                and self.options.ground is None:
            _warn(f'{self.path}: the robot floats (fixed_base: false) and there is no ground: '
                  'under gravity it falls without end (give ground, or fixed_base: true to '
                  'weld its root link to the world)')
        touching = self.options.contact is not None or self.options.ground is not None
        if touching:
            self._add_collisions(bodies)
        for k, item in enumerate(self.options.objects):
            if item.name in self.body_of or item.name in self.body_of.values():
                self._fail(f'objects[{k}].name: {item.name!r} is a link of the robot (an object '
                           'needs a name of its own)')
        objects, object_frames, object_visuals = object_entries(self.options.objects)
        joints = [self._joint(j) for j in self.robot.joints if not self._welded(j)]
        joints = self._overridden([j for j in joints if j is not None])
        options = self.options
        visuals = link_visuals(self.robot, self.local, self.body_of, options.package_paths,
                               self.path.parent, {b['name']: _size(b) for b in bodies},
                               lambda message: _warn(f'{self.path}: {message}',
                                                     'visual meshes not found (drawn as boxes)'))
        visuals += object_visuals
        settings = options.model_dump(include={*SceneSettings.model_fields, 'contact',
                                               'ground', 'sensors'}, exclude_none=True)
        settings['name'] = options.name or self.robot.name or self.path.stem
        if touching:
            settings['contact'] = {**settings.get('contact', {}), 'exclude': self._excluded()}
        frames += object_frames
        return {**settings, 'bodies': bodies + objects, 'joints': joints, 'frames': frames,
                'visuals': visuals}

    def _excluded(self) -> list[list[str]]:
        """contact.exclude (link and object names) and the SRDF's <disable_collisions> as
        pairs of body names (two links merged into one body need none); SceneError naming an
        unknown link."""
        named = [(pair, f'contact.exclude[{k}]') for k, pair in
                 enumerate(self.options.contact.exclude if self.options.contact else [])]
        if self.options.srdf is not None:
            found = resolve_uri(self.options.srdf, self.options.package_paths, self.path.parent)
            if found is None:
                raise SceneError(f'srdf: {self.options.srdf!r} not found (package_paths, '
                                 'ROS_PACKAGE_PATH, AMENT_PREFIX_PATH, the URDF\'s folder '
                                 'searched)')
            named += [((pair.link1, pair.link2), f'{found}:{pair.line}: <disable_collisions>')
                      for pair in disabled_pairs(found)]
        body_of = {**self.body_of, **{o.name: o.name for o in self.options.objects}}
        out = []
        for pair, where in named:
            for link in pair:
                if link not in body_of:
                    what = 'link or object' if where.startswith('contact') else 'link'
                    raise SceneError(f'{where}: unknown {what} {link!r} of {self.path}')
            bodies = [body_of[link] for link in pair]
            if bodies[0] != bodies[1] and bodies not in out:
                out.append(bodies)
        return out

    def _add_collisions(self, bodies: list[dict]) -> None:
        """Each link's <collision> elements as its body's ``collision`` list, posed in the
        body frame; SceneError for one that cannot be used (file, line and link named)."""
        by_name = {body['name']: body for body in bodies}
        for item in self.collisions:
            where = f'{self.path}:{item.line}: <collision> of link {item.link!r}'
            if item.problem is not None:
                raise SceneError(f'{where}: {item.problem}')
            geometry = dict(item.geometry)
            if 'mesh' in geometry:
                mesh = dict(geometry['mesh'])
                found = resolve_uri(mesh['uri'], self.options.package_paths, self.path.parent)
                if found is None:
                    raise SceneError(f'{where}: mesh {mesh["uri"]!r} not found (package_paths, '
                                     'ROS_PACKAGE_PATH, AMENT_PREFIX_PATH searched): contact '
                                     'needs it')
                geometry['mesh'] = {**mesh, 'path': str(found.resolve())}
            pose = pm.matmul(self.local[item.link], item.origin)
            geometry['origin'] = {'xyz': _list(pose[:3, 3]), 'rpy': rpy_from_matrix(pose[:3, :3])}
            by_name[self.body_of[item.link]].setdefault('collision', []).append(geometry)

    def _overridden(self, joints: list[dict]) -> list[dict]:
        """Apply the ``joints: {name: {key: value}}`` overrides."""
        by_name = {j['name']: j for j in joints}
        for name, keys in self.options.joints.items():
            if name not in by_name:
                self._fail(f'joints: {name!r} is not a joint of the robot (valid: '
                           f'{", ".join(by_name)})')
            by_name[name].update(keys)
        return joints


def object_entries(objects: list[Body]) -> tuple[list[dict], list[dict], list[dict]]:
    """The scene entries of ``objects`` (bodies beside a robot): their bodies, a frame of each
    one's name at its origin, and a visual of each one's shape."""
    bodies = [o.model_dump(mode='json', exclude_none=True) for o in objects]
    frames = [{'name': o['name'], 'body': o['name']} for o in bodies]
    visuals = [{'body': o['name'], 'geometry': o['shape']} for o in bodies if 'shape' in o]
    return bodies, frames, visuals


def _origin(joint) -> np.ndarray:
    return np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=np.float64)


def _raw_axis(joint) -> np.ndarray:
    """The joint's ``<axis xyz>`` as given (URDF's default: x)."""
    return np.array([1.0, 0.0, 0.0]) if joint.axis is None else np.asarray(joint.axis, float)


def _axis(joint) -> np.ndarray:
    """The joint's unit axis in its joint frame (checked non-zero by the converter)."""
    axis = _raw_axis(joint)
    return axis / pm.norm(axis)


def _rigid_inverse(pose: np.ndarray) -> np.ndarray:
    """The inverse [[Rᵀ, −Rᵀ p], [0, 1]] of a rigid 4×4 pose."""
    out = np.eye(4)
    out[:3, :3] = pose[:3, :3].T
    out[:3, 3] = -pm.matmul(pose[:3, :3].T, pose[:3, 3])
    return out


def _motion(joint, position: float) -> np.ndarray:
    """The child's pose in the joint frame at coordinate ``position`` [rad | m]."""
    out = np.eye(4)
    if joint.type in ('revolute', 'continuous'):
        out[:3, :3] = axis_rotation(_axis(joint), position)
    elif joint.type == 'prismatic':
        out[:3, 3] = position * _axis(joint)
    return out


def _size(body: dict) -> list[float]:
    """Sides [m] of the box drawn for a body's mesh that is not found: its equivalent box (a
    fixed body without inertia: 5 cm)."""
    if 'inertia' not in body:
        return [0.05, 0.05, 0.05]
    props = inertia_mass_properties(body['mass'], body['inertia'])
    return [float(2.0 * h) for h in props.half_extent]


def _list(v) -> list[float]:
    return [float(x) for x in v]
