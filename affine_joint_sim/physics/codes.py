"""Integer codes shared by the host model and the kernels (per-joint and per-scene switches)."""

__all__ = ['REVOLUTE', 'PRISMATIC', 'FIXED', 'JOINT_TYPES', 'LEVER_ARM', 'GENERALIZED',
           'WRAPPED', 'CONTINUOUS', 'BDF1', 'BDF2']

REVOLUTE, PRISMATIC, FIXED = 0, 1, 2            # joint_type: UID 18, 20, 25
JOINT_TYPES = {'revolute': REVOLUTE, 'prismatic': PRISMATIC, 'fixed': FIXED}
LEVER_ARM, GENERALIZED = 0, 1                   # torque_model
WRAPPED, CONTINUOUS = 0, 1                      # angle_mode
BDF1, BDF2 = 0, 1                               # solver.integrator
