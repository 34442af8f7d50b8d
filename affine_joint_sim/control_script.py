"""A scripted PD command (README.md#grasping): joint targets that move along keyframes in
simulated time, each joint with its own gains. The demo controller runs one over ROS
(``affine-joint-sim demo --scene grasp``); the bench runs the same one in process.

A script file is YAML::

    gains:                    # kp [N·m/rad | N/m], kd [N·m·s/rad | N·s/m]
      elbow: {kp: 1500, kd: 50}
    keyframes:                # targets [rad | m] at simulated times t [s]
      - {t: 0.0, targets: {elbow: 1.1}}
      - {t: 1.0, targets: {elbow: 1.4}}

Each joint of ``gains`` follows the keyframes that name it: between two of them its target
moves along a smooth step (zero velocity at both ends, so a PD command does not jerk), before
the first and after the last it holds. Torques are τ = kp (θ* − θ) − kd ω per joint.
"""

from pathlib import Path
from typing import Annotated

import numpy as np
import yaml
from pydantic import Field, ValidationError, model_validator

from affine_joint_sim.resources import packaged_file, packaged_names
from affine_joint_sim.scene import SceneError, validation_report
from affine_joint_sim.schema_base import Number, StrictModel

__all__ = ['ControlScript', 'Gains', 'Keyframe', 'script_path', 'packaged_scripts',
           'pd_torques', 'command_stepper']

NonNegative = Annotated[Number, Field(ge=0.0)]


class Gains(StrictModel):
    """A joint's PD gains: ``kp`` [N·m/rad | N/m], ``kd`` [N·m·s/rad | N·s/m]."""

    kp: NonNegative
    kd: NonNegative


class Keyframe(StrictModel):
    """Targets [rad | m] of some joints at simulated time ``t`` [s]."""

    t: NonNegative
    targets: Annotated[dict[str, Number], Field(min_length=1)]


class ControlScript(StrictModel):
    """Per-joint gains and the keyframes their targets follow (module docstring)."""

    gains: Annotated[dict[str, Gains], Field(min_length=1)]
    keyframes: Annotated[list[Keyframe], Field(min_length=1)]

    @model_validator(mode='after')
    def _consistent(self):
        for k, (before, after) in enumerate(zip(self.keyframes, self.keyframes[1:])):
            if after.t <= before.t:
                raise ValueError(f'keyframes[{k + 1}].t ({after.t:g}) must be later than '
                                 f'keyframes[{k}].t ({before.t:g})')
        for k, frame in enumerate(self.keyframes):
            unknown = [joint for joint in frame.targets if joint not in self.gains]
            if unknown:
                raise ValueError(f'keyframes[{k}].targets: {", ".join(unknown)} not in gains '
                                 f'({", ".join(self.gains)})')
        silent = [joint for joint in self.gains
                  if not any(joint in frame.targets for frame in self.keyframes)]
        if silent:
            raise ValueError(f'gains: {", ".join(silent)} named in no keyframe (no target)')
        return self

    @classmethod
    def hold(cls, targets: dict[str, float], kp: float, kd: float) -> 'ControlScript':
        """Constant ``targets`` with the same gains for every joint."""
        return cls(gains={joint: Gains(kp=kp, kd=kd) for joint in targets},
                   keyframes=[Keyframe(t=0.0, targets=targets)])

    @classmethod
    def load(cls, name_or_path) -> 'ControlScript':
        """A script file, or a packaged script by name (``grasp``); SceneError naming the file
        and each problem, FileNotFoundError naming the packaged ones."""
        path = script_path(name_or_path)
        try:
            data = yaml.safe_load(path.read_text(encoding='utf-8'))
        except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
            raise SceneError(f'{path}: cannot read control script ({exc})') from None
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            raise SceneError(validation_report(str(path), exc, cls, 'control script')) from None

    @property
    def joints(self) -> list[str]:
        """The joints the script drives, in the order of ``gains``."""
        return list(self.gains)

    @property
    def kp(self) -> np.ndarray:
        """Proportional gains per joint of ``joints``."""
        return np.array([g.kp for g in self.gains.values()])

    @property
    def kd(self) -> np.ndarray:
        """Derivative gains per joint of ``joints``."""
        return np.array([g.kd for g in self.gains.values()])

    def targets_at(self, t: float) -> np.ndarray:
        """Targets [rad | m] per joint of ``joints`` at simulated time ``t`` [s]."""
        out = np.empty(len(self.gains))
        for j, joint in enumerate(self.gains):
            points = [(f.t, f.targets[joint]) for f in self.keyframes if joint in f.targets]
            later = [k for k, (time, _) in enumerate(points) if time > t]
            if not later:
                out[j] = points[-1][1]
            elif later[0] == 0:
                out[j] = points[0][1]
            else:
                (t0, a), (t1, b) = points[later[0] - 1], points[later[0]]
                s = (t - t0) / (t1 - t0)
                out[j] = a + (b - a) * s * s * (3.0 - 2.0 * s)
        return out


def pd_torques(kp, kd, target, angle, velocity, effort_limit=np.inf) -> np.ndarray:
    """τ = kp (θ* − θ) − kd ω [N·m | N], clipped to ±``effort_limit``."""
    return np.clip(kp * (target - angle) - kd * velocity, -effort_limit, effort_limit)


def command_stepper(sim, script: ControlScript) -> np.ndarray:
    """Set the script's PD torques on a Stepper (one environment) for its next step, from its
    state now, as the demo controller answers a joint state; returns them [N·m | N]."""
    rows = [sim.joint_names.index(joint) for joint in script.joints]
    tau = pd_torques(script.kp, script.kd, script.targets_at(sim.time), sim.angles[rows],
                     sim.velocities[rows])
    for joint, value in zip(script.joints, tau):
        sim.set_torque(joint, value)
    return tau


def script_path(name_or_path) -> Path:
    """A control script: an existing path as given, else a packaged one by name."""
    return packaged_file(name_or_path, 'scripts', 'control script')


def packaged_scripts() -> list[str]:
    """Names of the packaged control scripts."""
    return packaged_names('scripts')
