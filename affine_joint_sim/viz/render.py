"""``affine-joint-sim render BAG --out FILE``: pictures of a recorded run, no viewer needed.

The bodies are drawn from the bag's ``body_poses`` (a URDF robot's link frames give its
bodies' poses through the scene's frames); a bag recorded without them is re-simulated from
its scene and commands (``ros.replay``). Shapes are shaded solids (a mesh whose file trimesh
can load is drawn with at most ``MESH_FACES`` faces, decimated by vertex clustering when it has
more); a side panel plots the joint coordinates and efforts over the frames' window with a
cursor at the frame's time. The ground's half-spaces are drawn as a checkerboard of tiles
(``GROUND_TILES`` a side) across the view, so sliding shows. A bag with body_poses is read
only over that window. A ``.gif``
(Pillow) or ``.mp4`` (imageio with ffmpeg) holds one frame every 1/fps s of bag time between
``--from`` and ``--to``; a ``.png`` is the frame at ``--from`` (default: the end). Plain
matplotlib, no display.
"""

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from affine_joint_sim.meshes import decimated
from affine_joint_sim.poses import LinkFrames, rigid_transforms
from affine_joint_sim.progress import Progress
from affine_joint_sim.rotations import quaternion_matrix
from affine_joint_sim.viz.drawables import drawables

__all__ = ['RenderError', 'Track', 'load_track', 'render', 'frame_times', 'ground_tiles']

MESH_FACES = 400          # the most faces a mesh is drawn with (a frame's cost grows with them)
GROUND_TILES = 10         # tiles a side of the ground drawn under the view
_POSE_MARGIN = 1.0        # s before --from read too: the pose in force at the first frame
_LIGHT = np.array([0.4, -0.5, 0.77])


class RenderError(Exception):
    """A bag or option that cannot be rendered; the message says why in one line."""


@dataclass
class Track:
    """What a bag shows: body poses and joint states against bag time.

    Attributes:
        scene: the bag's scene.
        pose_times: bag time of each pose sample [s].
        bodies: rigid world transforms of every body per sample, (n, n_bodies, 4, 4).
        state_times: bag time of each joint state [s].
        joint_names: names in joint_states.
        positions, efforts: (m, n_joints) [rad | m], [N·m | N].
        resimulated: whether the poses came from re-simulating the bag.
        span: the bag's first and last message time [s] (the track may hold less).
    """

    scene: object
    pose_times: np.ndarray
    bodies: np.ndarray
    state_times: np.ndarray
    joint_names: list
    positions: np.ndarray
    efforts: np.ndarray
    resimulated: bool
    span: tuple[float, float]


def load_track(path, start: float | None = None, stop: float | None = None) -> Track:
    """A bag's poses and joint states: from ``body_poses`` read between bag times ``start``
    and ``stop`` [s] (default: the whole bag; one second before ``start`` too, for the pose in
    force there), or, for a bag without them, re-simulated from its beginning."""
    from affine_joint_sim.ros.replay import ReplayError, _scene_of, read_bag, replay
    from affine_joint_sim.scene import SceneError

    window = (None if start is None else max(int((start - _POSE_MARGIN) * 1e9), 0),
              None if stop is None else int(stop * 1e9) + 1)
    try:
        bag = read_bag(path, ('joint_states', 'body_poses'), *window)
        if not any(m.kind == 'body_poses' for m in bag.messages):
            bag = read_bag(path)                 # re-simulated: every command is needed
        if bag.scene_yaml is None:
            raise RenderError(f'{path}: the bag holds no scene (~/scene): empty, or not '
                              'recorded by the affine_joint_sim node')
        scene = _scene_of(bag, None)
    except (ReplayError, SceneError) as exc:
        raise RenderError(str(exc).splitlines()[0]) from None
    states = [(m.t_ns, m.decode()) for m in bag.messages if m.kind == 'joint_states']
    if not states:
        raise RenderError(f'{path}: the bag holds no joint_states: nothing to draw')
    poses = [(m.t_ns, m.decode()) for m in bag.messages if m.kind == 'body_poses']
    if poses:
        pose_times = np.array([t for t, _ in poses]) * 1e-9
        bodies = _bodies_from_frames(scene, [msg.poses for _, msg in poses])
    else:
        samples = []
        try:
            replay(bag, on_state=lambda bag_ns, stamp_ns, sim: samples.append(
                (bag_ns, rigid_transforms(sim.body_q))))
        except ReplayError as exc:
            raise RenderError(str(exc).splitlines()[0]) from None
        pose_times = np.array([t for t, _ in samples]) * 1e-9
        bodies = np.array([b for _, b in samples])
    return Track(scene, pose_times, bodies, np.array([t for t, _ in states]) * 1e-9,
                 list(states[-1][1].name), _column(states, 'position'),
                 _column(states, 'effort'), not poses,
                 (bag.span_ns[0] * 1e-9, bag.span_ns[1] * 1e-9))


def _bag_end(path) -> float | None:
    """The bag's last message time [s] (its index only), or None if it cannot be read (then
    ``load_track`` says why)."""
    from affine_joint_sim.ros.replay import ReplayError, read_bag

    try:
        return read_bag(path, kinds=()).span_ns[1] * 1e-9
    except ReplayError:
        return None


def _column(states, field: str) -> np.ndarray:
    width = max(len(getattr(msg, field)) for _, msg in states)
    return np.array([list(getattr(msg, field)) + [np.nan] * (width - len(getattr(msg, field)))
                     for _, msg in states])


def _bodies_from_frames(scene, samples) -> np.ndarray:
    """Body transforms from body_poses samples: a body's pose is any of its frames' pose times
    that frame's pose in the body, inverted."""
    frames = LinkFrames(scene)
    first = {}
    for i, body in enumerate(frames.body):
        first.setdefault(int(body), i)
    to_body = {body: np.linalg.inv(frames.local[i]) for body, i in first.items()}
    out = np.tile(np.eye(4), (len(samples), len(scene.bodies), 1, 1))
    for k, poses in enumerate(samples):
        for body, i in first.items():
            p = poses[i]
            world = np.eye(4)
            world[:3, :3] = quaternion_matrix(p.orientation.x, p.orientation.y,
                                              p.orientation.z, p.orientation.w)
            world[:3, 3] = p.position.x, p.position.y, p.position.z
            out[k, body] = world @ to_body[body]
    return out


def frame_times(track: Track, fps: float, start: float | None, stop: float | None,
                single: bool) -> np.ndarray:
    """Bag times [s] of the frames: every 1/fps from ``start`` to ``stop`` (default: the
    whole bag); one frame (at ``start``, default the end) for a still picture."""
    first, last = track.span
    if single:
        if start is not None and not first <= start <= last + 1e-9:
            raise RenderError(f'--from {start:g} must be within the bag\'s time span '
                              f'[{first:g}, {last:g}] s')
        return np.array([last if start is None else min(start, last)])
    start = first if start is None else start
    stop = last if stop is None else stop
    if not first <= start < stop <= last + 1e-9:
        raise RenderError(f'--from {start:g} and --to {stop:g} must satisfy {first:g} <= from '
                          f'< to <= {last:g} (the bag\'s time span [s])')
    return start + np.arange(math.floor((stop - start) * fps + 1e-9) + 1) / fps


# ---- shapes ---------------------------------------------------------------------------------

def _box(scale):
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5)
                        for z in (-0.5, 0.5)]) * scale
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return [corners[list(f)] for f in faces]


def _cylinder(scale, sides=16):
    a = np.linspace(0.0, 2.0 * math.pi, sides, endpoint=False)
    ring = np.stack([0.5 * scale[0] * np.cos(a), 0.5 * scale[1] * np.sin(a)], axis=1)
    bottom = np.column_stack([ring, np.full(sides, -0.5 * scale[2])])
    top = np.column_stack([ring, np.full(sides, 0.5 * scale[2])])
    walls = [np.array([bottom[i], bottom[(i + 1) % sides], top[(i + 1) % sides], top[i]])
             for i in range(sides)]
    return walls + [bottom[::-1], top]


def _sphere(scale, rings=8, sectors=12):
    polar = np.linspace(0.0, math.pi, rings + 1)
    azimuth = np.linspace(0.0, 2.0 * math.pi, sectors + 1)
    points = 0.5 * np.array(scale) * np.stack(
        [np.outer(np.sin(polar), np.cos(azimuth)), np.outer(np.sin(polar), np.sin(azimuth)),
         np.outer(np.cos(polar), np.ones_like(azimuth))], axis=-1)
    return [np.array([points[i, j], points[i + 1, j], points[i + 1, j + 1], points[i, j + 1]])
            for i in range(rings) for j in range(sectors)]


def _mesh(item):
    try:
        import trimesh
        mesh = trimesh.load(item.mesh_path, force='mesh')
        if len(mesh.faces) == 0:
            raise ValueError('no faces')
        return list(decimated(np.asarray(mesh.vertices, dtype=float),
                              np.asarray(mesh.faces), MESH_FACES) * item.scale)
    except Exception:               # any file trimesh cannot read is drawn as a small box
        return _box(np.array([0.05, 0.05, 0.05]))


def _polygons(scene) -> list:
    """(body, local 4×4, polygons in the shape's frame, RGB) of every drawable."""
    makers = {'box': _box, 'cylinder': _cylinder, 'sphere': _sphere}
    out = []
    for item in drawables(scene):
        polygons = (_mesh(item) if item.kind == 'mesh' else
                    makers[item.kind](np.asarray(item.scale, dtype=float)))
        out.append((item.body, item.local, polygons, np.asarray(item.color[:3])))
    return out


def _ground_planes(scene):
    """(unit normal, a point on it, t₁, t₂) of each ground half-space."""
    from affine_joint_sim.physics.contact.model import tangent

    for plane in scene.ground or []:
        if plane.height is not None:
            normal, point = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, plane.height])
        else:
            normal = np.asarray(plane.normal, float) / np.linalg.norm(plane.normal)
            point = np.asarray(plane.point, float)
        t1 = tangent(normal)
        yield normal, point, t1, np.cross(normal, t1)


def _under(centre, normal, point) -> np.ndarray:
    """``centre`` projected onto the plane through ``point`` with unit ``normal``."""
    return centre - ((centre - point) @ normal) * normal


def ground_tiles(scene, centre, half: float) -> list:
    """(corners (4, 3) [m, world], RGB) of a checkerboard on each of the scene's ground
    half-spaces, 2·half [m] a side, centred under ``centre``."""
    out = []
    side = 2.0 * half / GROUND_TILES
    for normal, point, t1, t2 in _ground_planes(scene):
        origin = _under(centre, normal, point)
        for i in range(GROUND_TILES):
            for j in range(GROUND_TILES):
                a = origin + (i * side - half) * t1 + (j * side - half) * t2
                corners = np.array([a, a + side * t1, a + side * (t1 + t2), a + side * t2])
                shade = 0.82 if (i + j) % 2 else 0.7
                out.append((corners, np.array([shade, shade, shade])))
    return out


# ---- drawing ----------------------------------------------------------------------------------

class _Figure:
    """The 3-D view and the side panel over ``window`` (first, last frame time [s]);
    ``draw(t)`` renders the frame at bag time t."""

    def __init__(self, track: Track, size, view, window):
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        self.track, self.poly = track, Poly3DCollection
        self.shapes = _polygons(track.scene)
        dpi = 100
        self.fig = plt.figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
        self.cursors = []
        if not track.joint_names:           # nothing to plot beside: the view takes it all
            self.ax = self.fig.add_subplot(projection='3d')
            self.ax.view_init(elev=view[1], azim=view[0])
            self._limits()
            self.title = self.fig.suptitle('', fontsize=11)
            self.collections = []
            return
        grid = self.fig.add_gridspec(2, 2, width_ratios=(1.6, 1.0), left=0.0, right=0.97,
                                     top=0.93, bottom=0.1, wspace=0.25, hspace=0.35)
        self.ax = self.fig.add_subplot(grid[:, 0], projection='3d')
        self.ax.view_init(elev=view[1], azim=view[0])
        self._limits()
        self.title = self.fig.suptitle('', x=0.3, fontsize=11)
        shown = (track.state_times >= window[0] - 1e-9) & (track.state_times <= window[1] + 1e-9)
        for row, (values, label) in enumerate(((track.positions, 'position [rad | m]'),
                                               (track.efforts, 'effort [N·m | N]'))):
            ax = self.fig.add_subplot(grid[row, 1])
            for k, name in enumerate(track.joint_names):
                ax.plot(track.state_times[shown], values[shown, k], lw=1.0, label=name)
            if window[1] > window[0]:
                ax.set_xlim(*window)
            ax.set_ylabel(label, fontsize=8)
            ax.tick_params(labelsize=7)
            self.cursors.append(ax.axvline(track.state_times[0], color='k', lw=0.8))
            if row == 0 and len(track.joint_names) <= 8:
                ax.legend(fontsize=6, loc='upper left', ncol=2)
        self.fig.axes[-1].set_xlabel('bag time [s]', fontsize=8)
        self.collections = []

    def _limits(self):
        """A cube that holds the whole run; or, for a robot that travels more than twice its
        own size (a floating robot falling), a cube of its size that follows its bodies'
        centre (``_follow``)."""
        centres = self.track.bodies[:, :, :3, 3]                  # (samples, bodies, 3) [m]
        reach = max((np.abs(p).max() for _, _, polys, _ in self.shapes for p in polys),
                    default=0.1)
        size = (centres.max(axis=1) - centres.min(axis=1)).max() + 2 * reach
        mean = centres.reshape(-1, 3).mean(axis=0)
        points = np.array([*centres.reshape(-1, 3),           # and the ground under them
                           *(_under(mean, normal, point)
                             for normal, point, _, _ in _ground_planes(self.track.scene))])
        low = points.min(axis=0) - reach
        high = points.max(axis=0) + reach
        self.half = max(size / 2, 0.1)
        self.follow = (high - low).max() > 2 * size
        if not self.follow:
            self.half = max((high - low).max() / 2, 0.1)
            self._centre_on((low + high) / 2)
        self.ax.set_box_aspect((1, 1, 1))
        self.ax.set_xlabel('x [m]', fontsize=7)
        self.ax.set_ylabel('y [m]', fontsize=7)
        self.ax.set_zlabel('z [m]', fontsize=7)
        self.ax.tick_params(labelsize=6)

    def _centre_on(self, centre) -> None:
        for axis, c in zip('xyz', centre):
            getattr(self.ax, f'set_{axis}lim')(c - self.half, c + self.half)

    def draw(self, t: float) -> np.ndarray:
        """The RGB image of the frame at bag time ``t`` [s]."""
        k = max(int(np.searchsorted(self.track.pose_times, t + 1e-9, side='right')) - 1, 0)
        if self.follow:
            self._centre_on(self.track.bodies[k, :, :3, 3].mean(axis=0))
        for collection in self.collections:
            collection.remove()
        self.collections = []
        faces, colors = [], []
        low = [getattr(self.ax, f'get_{axis}lim')()[0] for axis in 'xyz']
        for corners, rgb in ground_tiles(self.track.scene, np.array(low) + self.half,
                                         self.half):
            faces.append(corners)
            colors.append(rgb)
        for body, local, polygons, rgb in self.shapes:
            world = self.track.bodies[k, body] @ local
            for polygon in polygons:
                points = polygon @ world[:3, :3].T + world[:3, 3]
                normal = np.cross(points[1] - points[0], points[2] - points[0])
                norm = np.linalg.norm(normal)
                shade = 0.45 + 0.55 * (abs(normal @ _LIGHT) / norm if norm > 0 else 0.5)
                faces.append(points)
                colors.append(np.clip(rgb * shade, 0.0, 1.0))
        collection = self.poly(faces, facecolors=colors, edgecolors='none')
        self.ax.add_collection3d(collection)
        self.collections.append(collection)
        for cursor in self.cursors:
            cursor.set_xdata([t, t])
        self.title.set_text(f'{self.track.scene.name}   t = {t:6.3f} s')
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[:, :, :3].copy()


def render(path, out, fps: float = 15.0, size=(960, 540), view=(-60.0, 20.0),
           start: float | None = None, stop: float | None = None, progress: bool = True
           ) -> tuple[int, Track]:
    """Render the bag at ``path`` into ``out`` (.gif, .mp4 or .png); returns (frames, track)."""
    out = Path(out)
    kind = out.suffix.lower()
    if kind not in ('.gif', '.mp4', '.png'):
        raise RenderError(f'--out {out}: the file must end in .gif, .mp4 or .png')
    if not out.parent.is_dir():
        raise RenderError(f'--out {out}: no such directory {out.parent}')
    writer = _mp4_writer(out, fps) if kind == '.mp4' else None
    single = kind == '.png'
    if single:                          # read about the one frame: at --from, else the end
        at = start if start is not None else _bag_end(path)
        track = load_track(path, at, at)
    else:
        track = load_track(path, start, stop)
    times = frame_times(track, fps, start, stop, single=single)
    first = max(float(times[0]) - _POSE_MARGIN, track.span[0]) if single else float(times[0])
    figure = _Figure(track, size, view, (first, float(times[-1])))
    bar = Progress(len(times)) if progress else None
    images = []
    for t in times:
        if bar:
            bar.show(f'frame at {t:.3f} s')
        image = figure.draw(float(t))
        if writer is not None:
            writer.append_data(image)
        else:
            images.append(image)
        if bar:
            bar.advance()
    _save(out, kind, images, writer, fps)
    return len(times), track


def _mp4_writer(out: Path, fps: float):
    try:
        import imageio.v2 as imageio
        return imageio.get_writer(out, fps=fps, codec='libx264', quality=7)
    except Exception as exc:          # imageio or its ffmpeg backend missing
        raise RenderError(f'--out {out}: writing .mp4 needs imageio and imageio-ffmpeg (pip '
                          f'install imageio imageio-ffmpeg), or write a .gif ({exc})') from None


def _save(out: Path, kind: str, images, writer, fps: float) -> None:
    from PIL import Image

    if writer is not None:
        writer.close()
    elif kind == '.png':
        Image.fromarray(images[0]).save(out)
    else:
        frames = [Image.fromarray(image).quantize(colors=128, method=Image.Quantize.MEDIANCUT)
                  for image in images]
        frames[0].save(out, save_all=True, append_images=frames[1:], loop=0, optimize=True,
                       duration=round(1000.0 / fps))


def main(args) -> int:
    """The ``render`` subcommand: 0, or 2 with one line on stderr."""
    import sys

    try:
        view = tuple(float(v) for v in args.view.split(','))
        if len(view) != 2 or not all(math.isfinite(v) for v in view):
            raise ValueError
    except ValueError:
        print(f'affine-joint-sim: error: --view {args.view!r}: expected AZIMUTH,ELEVATION in '
              'degrees, e.g. -60,20', file=sys.stderr)
        return 2
    try:
        count, track = render(args.bag, args.out, args.fps, (args.width, args.height), view,
                              args.start, args.stop)
    except RenderError as exc:
        print(f'affine-joint-sim: error: {exc}', file=sys.stderr)
        return 2
    source = 're-simulated from its commands' if track.resimulated else 'from body_poses'
    print(f'{args.out}: {count} frame{"s" * (count != 1)} of {track.scene.name!r} ({source})')
    return 0
