"""The warning category of the simulator (no dependencies: the URDF import, the model build
and the stepper all raise it). Filter it with ``warnings.simplefilter(action,
SimulationWarning)``."""

__all__ = ['SimulationWarning']


class SimulationWarning(UserWarning):
    """A scene or a step the simulator can run but whose result the user should know about."""
