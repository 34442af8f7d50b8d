"""The step kernel's stages in pipeline order, each a ``build(t)`` of Warp functions: the types of a
precision and the kernels' math, affine kinematics, orthogonality, joint terms, commands,
prediction, the incremental potential and its assembly, commit, the step kernel itself, and the
frame and sensor kernels built on them (contact's stages: physics.contact; the solves:
physics.solve)."""
