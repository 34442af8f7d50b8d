"""``affine-joint-sim sweep SPEC.yaml --out DIR [--workers N | --ray ADDRESS]``: the bench's
speed/accuracy sweep over a declared grid, its settings run as parallel jobs.

The spec (YAML, every key optional but one case)::

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

It writes what ``bench sweep`` writes (sweep.csv, sweep.md, the Pareto and order plots) into
--out, through the same code (``bench.sweep.run``), without the wheel's damping section. The
command profiles of one scene entry are one job per setting: the environments of one batched
stepper (``num_envs``), each compared with its own reference.
"""

import sys
from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import Field, ValidationError

from affine_joint_sim.scene import Number, StrictModel, validation_report

__all__ = ['SweepSpec', 'main']

PositiveList = Annotated[list[Annotated[Number, Field(gt=0.0)]], Field(min_length=1)]


class SpecScene(StrictModel):
    scene: str
    torques: dict[str, Number] | Annotated[list[dict[str, Number]], Field(min_length=1)] = {}
    duration: Annotated[Number, Field(gt=0.0)] = 0.5

    def profiles(self) -> list[dict]:
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
    """Read and check a spec; ValueError with one line per problem."""
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
    return spec


def main(args) -> int:
    """Run the sweep; 0, or 2 with the problem on stderr."""
    from affine_joint_sim.bench.sweep import Settings, case_and_truth, run
    from affine_joint_sim.fleet.cli import executor_for

    try:
        spec = load_spec(Path(args.spec))
        for batch in spec.batches():         # every case and its truth, before any job runs
            for key in batch:
                case_and_truth(key)
    except Exception as exc:                 # a spec, scene or reference that cannot be used
        print(f'affine-joint-sim sweep: error: {str(exc).strip()}', file=sys.stderr)
        return 2
    try:
        executor, how = executor_for(args.workers, args.ray, len(spec.batches()) * len(
            spec.dt) * len(spec.integrator) * len(spec.newton_tol) * len(spec.precision)
            * len(spec.device))
    except RuntimeError as exc:
        print(f'affine-joint-sim sweep: error: {exc}', file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    settings = Settings(tuple(spec.dt), tuple(spec.integrator), tuple(spec.newton_tol),
                        tuple(spec.precision), None, spec.repeats, damping=False)
    run(args.out, spec.device, settings, executor=executor, batches=spec.batches())
    print(f'ran on {how}')
    return 0
