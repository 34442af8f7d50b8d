"""meshes.read_mesh: a reader's warnings are not read errors; only what a reader raises for a
bad file is "cannot read"."""

import warnings

import numpy as np
import pytest
import trimesh

from affine_joint_sim.meshes import read_mesh
from affine_joint_sim.scene import SceneError
from affine_joint_sim.sim_warnings import SimulationWarning


def _box_dae(tmp_path):
    """A COLLADA box 0.1 × 0.2 × 0.3 m (8 vertices, 12 triangles), written by trimesh."""
    path = tmp_path / 'box.dae'
    path.write_bytes(trimesh.exchange.dae.export_collada(trimesh.creation.box([0.1, 0.2, 0.3])))
    return path


@pytest.fixture
def warning_reader(monkeypatch):
    """trimesh.load that warns as pycollada does under NumPy 2.5, then reads."""
    load = trimesh.load

    def warns_then_loads(*args, **kwargs):
        warnings.warn('Setting the shape on a NumPy array has been deprecated',
                      DeprecationWarning, stacklevel=2)
        return load(*args, **kwargs)

    monkeypatch.setattr(trimesh, 'load', warns_then_loads)


def test_a_readers_warning_passes_through_as_it_was_and_the_mesh_is_read(tmp_path,
                                                                          warning_reader):
    dae = str(_box_dae(tmp_path))
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter('always')
        vertices, faces = read_mesh(dae, [2.0, 1.0, 1.0], 'here')
    assert vertices.shape == (8, 3) and faces.shape == (12, 3)
    assert np.allclose(np.ptp(vertices, axis=0), [0.2, 0.2, 0.3])        # scaled per axis
    # the reader's, in order (pycollada may add its own NumPy deprecations after this one)
    assert str(said[0].message) == 'Setting the shape on a NumPy array has been deprecated'
    assert all(w.category is DeprecationWarning for w in said)
    assert not any(issubclass(w.category, SimulationWarning) for w in said)


def test_warnings_as_errors_raise_the_readers_warning_not_cannot_read(tmp_path, warning_reader):
    """Before, `python -W error` turned the reader's DeprecationWarning into an exception that
    a broad except reported as 'cannot read collision mesh'."""
    dae = str(_box_dae(tmp_path))
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        with pytest.raises(DeprecationWarning, match='Setting the shape'):
            read_mesh(dae, [1.0, 1.0, 1.0], 'here')
        warnings.filterwarnings('ignore', category=DeprecationWarning)   # the reader's own
        vertices, _ = read_mesh(dae, [1.0, 1.0, 1.0], 'here')
    assert vertices.shape == (8, 3)


@pytest.mark.parametrize('name, content, words', [
    ('junk.dae', b'garbage', 'cannot read collision mesh .*junk.dae .DaeMalformedError: .*XML '
                             'Parsing'),
    ('faces.obj', b'v 1 2 3\nf 1 2 3\n', r'cannot read collision mesh .*faces.obj .IndexError'),
    ('junk.stl', b'not a mesh', 'collision mesh .*junk.stl has no finite vertices'),
    ('missing.stl', None, r"cannot read collision mesh .*missing.stl .ValueError: string is "
                          'not a file'),
])
def test_a_bad_file_is_one_scene_error_naming_where(tmp_path, name, content, words):
    if content is not None:
        (tmp_path / name).write_bytes(content)
    with pytest.raises(SceneError, match=f"^body 'b': {words}"):
        read_mesh(str(tmp_path / name), [1.0, 1.0, 1.0], "body 'b'")


def test_a_bug_is_not_reported_as_an_unreadable_mesh(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError('a bug, not a bad file')

    monkeypatch.setattr(trimesh, 'load', broken)
    with pytest.raises(RuntimeError, match='a bug'):
        read_mesh(str(_box_dae(tmp_path)), [1.0, 1.0, 1.0], 'here')
