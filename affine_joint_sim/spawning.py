"""Entities added to and removed from a scene while it runs (README.md#spawning-and-deleting):
the scene edits behind ``Stepper.spawn`` / ``Stepper.delete`` and the standard's
SpawnEntity / DeleteEntity. An entity is a body of the scene schema or a URDF robot (its
bodies, joints and links named ``<name>/...``, its topics under its namespace, as a
``robots:`` entry); it joins at the end of the scene's lists, so every other body and joint
keeps its place. The physics of the change (what carries over) is the Stepper's.
"""

import tempfile
from pathlib import Path

import yaml

from affine_joint_sim.rotations import quaternion_from_matrix, rpy_from_matrix
from affine_joint_sim.scene import Scene, SceneError

__all__ = ['with_body', 'with_robot', 'without', 'entity_names', 'spawn_event', 'apply_edit',
           'SPAWN_EVENT', 'DELETE_EVENT']


def entity_names(scene: Scene) -> list[str]:
    """What ``without`` removes: the robots of ``scene.robots`` and the bodies outside them
    that are in no joint."""
    jointed = {name for j in scene.joints for name in (j.parent, j.child)}
    return [r.name for r in scene.robots] + [
        b.name for b in scene.bodies if scene.robot_of(b.name) is None and b.name not in jointed]


def _placed(data: dict, pose) -> dict:
    """A body dict at world ``pose`` (4×4) of its frame."""
    return {**data, 'position': [float(x) for x in pose[:3, 3]],
            'orientation': {'quat_xyzw': quaternion_from_matrix(pose[:3, :3])}}


def _taken(scene: Scene, name: str) -> None:
    """SceneError if ``name`` is taken by an entity, a body, a robot or a prefix of them."""
    names = {b.name for b in scene.bodies} | {r.name for r in scene.robots}
    if name in names or any(n.startswith(name + '/') for n in names):
        raise SceneError(f'name {name!r} is taken (entities: {", ".join(entity_names(scene))})')


def with_body(scene: Scene, body: dict, pose) -> Scene:
    """``scene`` and a body (a scene ``bodies`` entry, its ``name`` its own) at world ``pose``
    (4×4); in a scene that lists frames and visuals (a URDF robot's) it gets a frame of its
    name and its shape drawn, as an ``objects`` entry. SceneError naming what is wrong."""
    if not isinstance(body, dict) or not isinstance(body.get('name'), str):
        raise SceneError(f'a spawned body is a mapping with a name (got {body!r})')
    _taken(scene, body['name'])
    data = scene.model_dump(mode='json', exclude_none=True)
    placed = _placed(body, pose)
    data['bodies'].append(placed)
    if scene.frames:
        data['frames'].append({'name': placed['name'], 'body': placed['name']})
    if scene.visuals and 'shape' in placed:
        data['visuals'].append({'body': placed['name'], 'geometry': placed['shape']})
    return _scene(data, scene, f'spawned body {body["name"]!r}')


def with_robot(scene: Scene, name: str, urdf: str, pose, namespace: str | None = None,
               **options) -> Scene:
    """``scene`` and the URDF robot ``urdf`` (a file's path, or the URDF text itself: it
    starts with ``<``) named ``name``, its root link at world ``pose`` (4×4), its topics under
    ``namespace`` (default ``name``); ``options``: a ``robots:`` entry's keys
    (``fixed_base``, ``initial_positions``, ...). SceneError naming what is wrong."""
    from affine_joint_sim.urdf.robots import robots_scene_data

    _taken(scene, name)
    entry = {'name': name, 'namespace': namespace or name, **options,
             'base': {'xyz': [float(x) for x in pose[:3, 3]],
                      'rpy': [float(a) for a in rpy_from_matrix(pose[:3, :3])]}}
    data = scene.model_dump(mode='json', exclude_none=True)
    with tempfile.TemporaryDirectory() as folder:
        if urdf.lstrip().startswith('<'):
            path = Path(folder) / f'{name}.urdf'
            path.write_text(urdf, encoding='utf-8')
        else:
            path = Path(urdf)
        keys = {k: data[k] for k in ('contact', 'ground') if k in data}
        if 'contact' in keys:       # the scene's pairs name its bodies: kept below
            keys['contact'] = {**keys['contact'], 'exclude': []}
        added, texts = robots_scene_data({'robots': [{**entry, 'urdf': str(path)}], **keys},
                                         Path('.'), f'spawned robot {name!r}')
    for section in ('bodies', 'joints', 'frames', 'visuals', 'robots'):
        data[section] = data.get(section, []) + added[section]
    if 'contact' in added:
        data['contact'] = {**added['contact'], 'exclude': data.get('contact', {}).get(
            'exclude', []) + added['contact']['exclude']}
    spawned = _scene(data, scene, f'spawned robot {name!r}')
    spawned._robot_descriptions = {**scene.robot_descriptions, **texts}
    return spawned


def without(scene: Scene, name: str) -> Scene:
    """``scene`` less entity ``name`` (``entity_names``): a robot with its bodies, joints,
    frames, visuals and contact exclusions, or a body in no joint with its frame and visuals.
    SceneError if it is none, or if a sensor sits on it."""
    if name not in entity_names(scene):
        raise SceneError(f'no entity {name!r} to delete (entities: '
                         f'{", ".join(entity_names(scene)) or "none"})')
    robot = next((r for r in scene.robots if r.name == name), None)

    def gone(entry: str) -> bool:
        return entry == name if robot is None else entry.startswith(robot.prefix)

    held = [s.name for s in scene.sensors if gone(s.body)]
    if held:
        raise SceneError(f'entity {name!r} carries sensors {", ".join(held)}: a sensor of the '
                         'scene stays with it')
    data = scene.model_dump(mode='json', exclude_none=True)
    data['bodies'] = [b for b in data['bodies'] if not gone(b['name'])]
    data['joints'] = [j for j in data.get('joints', []) if not gone(j['child'])]
    data['frames'] = [f for f in data.get('frames', []) if not gone(f['body'])]
    data['visuals'] = [v for v in data.get('visuals', []) if not gone(v['body'])]
    data['robots'] = [r for r in data.get('robots', []) if r['name'] != name]
    if 'contact' in data:
        data['contact']['exclude'] = [p for p in data['contact'].get('exclude', [])
                                      if not any(gone(b) for b in p)]
    smaller = _scene(data, scene, f'deleting {name!r}')
    smaller._robot_descriptions = {k: v for k, v in scene.robot_descriptions.items()
                                   if k != name}
    return smaller


def _scene(data: dict, scene: Scene, source: str) -> Scene:
    """The edited scene ``data`` validated (SceneError naming ``source``), with ``scene``'s
    robot descriptions."""
    edited = Scene.from_yaml_text(yaml.safe_dump(data, sort_keys=False), source=source)
    edited._robot_description = scene.robot_description
    edited._robot_descriptions = dict(scene.robot_descriptions)
    return edited


SPAWN_EVENT, DELETE_EVENT = 'spawn', 'delete'


def spawn_event(name: str, pose, body: dict | None = None, urdf: str | None = None,
                namespace: str | None = None) -> dict:
    """The event that records a spawn (``~/events``): the entity's name, its pose (4×4 as
    nested lists) and its ``body`` entry or ``urdf`` (a file's path, or the URDF text) with
    its ``namespace``."""
    event = {'event': SPAWN_EVENT, 'entity': name,
             'pose': [[float(x) for x in row] for row in pose]}
    if body is not None:
        return {**event, 'body': body}
    return {**event, 'urdf': urdf, **({'namespace': namespace} if namespace else {})}


def apply_edit(sim, event: dict) -> None:
    """Apply a spawn (``spawn_event``) or delete event (``{'event': 'delete', 'entity':
    name}``) to Stepper ``sim``; its errors as ``Stepper.spawn`` and ``delete`` raise them."""
    if event['event'] == DELETE_EVENT:
        sim.delete(event['entity'])
    else:
        sim.spawn(event['entity'], event['pose'], body=event.get('body'),
                  urdf=event.get('urdf'), namespace=event.get('namespace'))
