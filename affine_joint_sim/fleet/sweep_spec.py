"""The spec of ``affine-joint-sim sweep`` (YAML, every key optional but one case)::

    cases: [pendulum, arm6]          # cases of `bench sweep` (bench.cases) by name
    scenes:                          # any scene or URDF under constant torques [N·m]
      - {scene: my_robot.urdf, torques: {elbow: 0.5}, duration: 0.5}
      - {scene: arm, torques: [{yaw: 0.1}, {yaw: 0.3}, {yaw: 1.0}]}   # command profiles
    dt: [0.01, 0.005]                # s
    integrator: [bdf1, bdf2]
    newton_tol: [1.0e-4]
    precision: [float64]
    device: [cpu]
    repeats: 1                       # timed runs per setting (median)

``load_spec`` checks everything a job would otherwise trip over, before any job runs: the keys
and ranges, the case names, every scene (loadable, revolute joints only) and every joint its
torques name; ``check_devices`` that the devices exist on this machine. Each problem is one
line naming the key.
"""

from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import Field, ValidationError

from affine_joint_sim.scene import Number, StrictModel, validation_report

__all__ = ['SweepSpec', 'load_spec', 'check_devices']

PositiveList = Annotated[list[Annotated[Number, Field(gt=0.0)]], Field(min_length=1)]


class SpecScene(StrictModel):
    scene: str
    torques: dict[str, Number] | Annotated[list[dict[str, Number]], Field(min_length=1)] = {}
    duration: Annotated[Number, Field(gt=0.0)] = 0.5    # s

    def profiles(self) -> list[dict]:
        """The command profiles: joint name -> constant torque [N·m] (or force [N])."""
        return self.torques if isinstance(self.torques, list) else [self.torques]


class SweepSpec(StrictModel):
    """A sweep: cases × dt × integrator × newton_tol × precision × device."""

    cases: list[str] = []
    scenes: list[SpecScene] = []
    dt: PositiveList = [0.01, 0.005]
    integrator: Annotated[list[Literal['bdf1', 'bdf2']], Field(min_length=1)] = ['bdf1', 'bdf2']
    newton_tol: PositiveList = [1e-4]
    precision: Annotated[list[Literal['float64', 'float32']], Field(min_length=1)] = [
        'float64']
    device: Annotated[list[str], Field(min_length=1)] = ['cpu']
    repeats: Annotated[int, Field(ge=1, le=100)] = 1

    def batches(self) -> list[list]:
        """Case keys of ``bench.sweep.case_and_truth``, grouped into batches: a named case
        alone, a scene entry's command profiles together."""
        return [[name] for name in self.cases] + [
            [(s.scene, tuple(sorted(p.items())), s.duration) for p in s.profiles()]
            for s in self.scenes]


def load_spec(path: Path) -> SweepSpec:
    """Read and check a spec; ValueError (or the scene loader's FileNotFoundError) naming the
    first problem, one line per problem."""
    from affine_joint_sim.bench.cases import cases

    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f'{path}: cannot read a sweep spec ({exc})') from None
    try:
        spec = SweepSpec.model_validate(data if data is not None else {})
    except ValidationError as exc:
        raise ValueError(validation_report(str(path), exc, SweepSpec, 'sweep spec')) from None
    known = [c.name for c in cases()]
    unknown = [name for name in spec.cases if name not in known]
    if unknown:
        raise ValueError(f'{path}: cases {unknown} are not sweep cases ({", ".join(known)}); '
                         'put other scenes under scenes:')
    if not spec.batches():
        raise ValueError(f'{path}: give at least one entry in cases: or scenes:')
    for k, entry in enumerate(spec.scenes):
        _check_torques(path, k, entry)
    return spec


def _check_torques(path: Path, k: int, entry: SpecScene) -> None:
    """Scene entry ``k`` loads as a case (revolute joints only) and its torques name only its
    joints."""
    from affine_joint_sim.bench.cases import custom_case

    joints = [j.name for j in custom_case(entry.scene, (), entry.duration).scene.joints]
    for p, profile in enumerate(entry.profiles()):
        unknown = [name for name in profile if name not in joints]
        if unknown:
            where = f'scenes[{k}].torques' + (f'[{p}]' if isinstance(entry.torques, list)
                                              else '')
            names = ', '.join(repr(name) for name in unknown)
            raise ValueError(f'{path}: {where}: joint{"s" * (len(unknown) > 1)} {names} '
                             f'{"are" if len(unknown) > 1 else "is"} not in {entry.scene} '
                             f'(joints: {", ".join(joints)})')


def check_devices(path: Path, spec: SweepSpec) -> None:
    """ValueError naming the first device of ``spec`` that this machine does not have
    (Warp's names: cpu, cuda, cuda:N). Warp starts (quietly) only for a device other than
    cpu."""
    if all(device == 'cpu' for device in spec.device):
        return
    import warp as wp

    from affine_joint_sim.quiet_warp import quiet_warp

    quiet_warp()
    here = [d.alias for d in wp.get_devices()]
    valid = here + ['cuda'] * any(alias.startswith('cuda:') for alias in here)
    for k, device in enumerate(spec.device):
        if device not in valid:
            raise ValueError(f'{path}: device[{k}]: {device!r} is not a device of this '
                             f'machine (it has: {", ".join(valid)})')
