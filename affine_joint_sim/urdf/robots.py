"""A scene of several URDF robots (README.md#several-robots): a scene YAML's ``robots:`` list.

Each entry (``name``, ``urdf`` relative to the YAML, ``namespace``, and a URDF scene's robot
keys: ``base``, ``fixed_base``, ``initial_positions``, ``joints``, ...) is converted as a
one-robot scene is (``urdf.convert``); its bodies, joints and frames are then named
``<name>/<URDF name>`` (the frame prefix of its links on /tf), and the robots, with the
``objects`` beside them, become one scene. The scene settings, ``contact``, ``ground`` and
``sensors`` are the YAML's top-level keys; ``contact.exclude`` and ``sensors`` name links as
``<robot>/<link>`` (or an object). Bodies of two robots touch each other as any two bodies do.
"""

from pathlib import Path

from pydantic import ValidationError

from affine_joint_sim.scene import SceneError, SceneSettings, validation_report
from affine_joint_sim.urdf.convert import UrdfOptions, object_entries, urdf_scene_data

__all__ = ['robots_scene_data', 'ROBOT_KEYS']

# The keys of a robots: entry beyond name, urdf and namespace: a URDF scene's, for one robot.
ROBOT_KEYS = ('fixed_base', 'merge_fixed', 'initial_positions', 'min_mass', 'package_paths',
              'joints', 'base', 'srdf')
_ENTRY_KEYS = ('name', 'urdf', 'namespace', *ROBOT_KEYS)
_SCENE_KEYS = (*SceneSettings.model_fields, 'robots', 'contact', 'ground', 'sensors', 'objects')
_RENAMED = {'bodies': ('name',), 'joints': ('name', 'parent', 'child'),
            'frames': ('name', 'body', 'parent'), 'visuals': ('body',)}


def robots_scene_data(data: dict, base_dir: Path, source: str) -> tuple[dict, dict[str, str]]:
    """The scene dict (for ``Scene.from_dict``) of a scene YAML's ``data`` listing URDF
    robots, and each robot's URDF text by name. SceneError naming ``source`` and the key."""
    unknown = [k for k in data if k not in _SCENE_KEYS]
    if unknown:
        raise SceneError(f'{source}: {unknown[0]}: unknown key beside robots:; valid keys: '
                         f'{", ".join(_SCENE_KEYS)} (other bodies go under objects:)')
    robots, descriptions = data['robots'], {}
    contact, ground = data.get('contact'), data.get('ground')
    touching = contact is not None or ground is not None
    scene = {k: v for k, v in data.items() if k in SceneSettings.model_fields}
    merged = {'bodies': [], 'joints': [], 'frames': [], 'visuals': [], 'exclude': []}
    entries = []
    for i, entry in enumerate(robots):
        name, path, overrides = _entry(entry, i, base_dir, source)
        if touching:      # each link's <collision> is loaded; the YAML's exclude comes below
            overrides['contact'] = {**(contact if isinstance(contact, dict) else {}),
                                    'exclude': []}
        robot, text = urdf_scene_data(path, overrides, f'{source} (robots[{i}]: {path})')
        descriptions[name] = text
        entries.append({'name': name, 'namespace': entry.get('namespace', name)})
        for section, keys in _RENAMED.items():
            merged[section] += [_renamed(item, keys, name + '/') for item in robot[section]]
        merged['exclude'] += [[f'{name}/{a}', f'{name}/{b}']
                              for a, b in robot.get('contact', {}).get('exclude', [])]
    try:
        objects = UrdfOptions.model_validate({'objects': data.get('objects', [])}).objects
    except ValidationError as exc:
        raise SceneError(validation_report(source, exc, UrdfOptions)) from None
    bodies, frames, visuals = object_entries(objects)
    scene.update(robots=entries, bodies=merged['bodies'] + bodies, joints=merged['joints'],
                 frames=merged['frames'] + frames, visuals=merged['visuals'] + visuals)
    for key in ('ground', 'sensors'):
        if key in data:
            scene[key] = data[key]
    if touching:
        exclude = contact.get('exclude', []) if isinstance(contact, dict) else []
        scene['contact'] = {**(contact if isinstance(contact, dict) else {}),
                            'exclude': merged['exclude'] + _bodies_of(exclude, scene, source)}
    return scene, descriptions


def _entry(entry, i: int, base_dir: Path, source: str) -> tuple[str, Path, dict]:
    """(name, URDF path, the URDF scene's overrides) of ``robots[i]``; SceneError naming the
    key."""
    where = f'{source}: robots[{i}]'
    if not isinstance(entry, dict) or not isinstance(entry.get('urdf'), str) \
            or not entry['urdf']:
        raise SceneError(f'{where}: each robot is a mapping with urdf: the path of its URDF '
                         f'file (got {entry!r})')
    unknown = [k for k in entry if k not in _ENTRY_KEYS]
    if unknown:
        raise SceneError(f'{where}.{unknown[0]}: unknown key; valid keys here: '
                         f'{", ".join(_ENTRY_KEYS)}')
    name = entry.get('name')
    if not isinstance(name, str) or not name:
        raise SceneError(f'{where}.name: give each robot a name (its frame prefix and, unless '
                         'namespace says otherwise, its topics\' namespace)')
    overrides = {k: entry[k] for k in ROBOT_KEYS if k in entry}
    return name, base_dir / entry['urdf'], overrides


def _renamed(item: dict, keys: tuple, prefix: str) -> dict:
    """``item`` with the names under ``keys`` (and a mimic's leader) given ``prefix``."""
    out = dict(item)
    for key in keys:
        if out.get(key) is not None:
            out[key] = prefix + out[key]
    if isinstance(out.get('mimic'), dict):
        out['mimic'] = {**out['mimic'], 'joint': prefix + out['mimic']['joint']}
    return out


def _bodies_of(pairs, scene: dict, source: str) -> list[list[str]]:
    """``contact.exclude`` pairs of link (``<robot>/<link>``) or object names as pairs of body
    names; SceneError naming an unknown one."""
    body_of = {f['name']: f['body'] for f in scene['frames']}
    body_of.update({b['name']: b['name'] for b in scene['bodies']})
    out = []
    for k, pair in enumerate(pairs if isinstance(pairs, list) else []):
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            out.append(pair)            # the scene's validation says what is wrong
            continue
        for name in pair:
            if name not in body_of:
                raise SceneError(f'{source}: contact.exclude[{k}]: unknown link or object '
                                 f'{name!r} (a robot\'s link is <robot>/<link>)')
        bodies = [body_of[name] for name in pair]
        if bodies[0] != bodies[1]:
            out.append(bodies)
    return out
