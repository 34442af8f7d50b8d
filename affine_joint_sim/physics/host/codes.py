"""Integer codes shared by the host model and the kernels (per-joint and per-scene switches)."""

__all__ = ['LEVER_ARM', 'GENERALIZED', 'WRAPPED', 'CONTINUOUS', 'BDF1', 'BDF2']

# joint_type: the codes of physics.host.joint_kinds
LEVER_ARM, GENERALIZED = 0, 1                   # torque_model
WRAPPED, CONTINUOUS = 0, 1                      # angle_mode
BDF1, BDF2 = 0, 1                               # solver.integrator
