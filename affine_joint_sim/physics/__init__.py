"""Physics of affine bodies joined by joints: host-side model build and Warp kernels.

Nothing here imports ROS. ``fields`` is the one table of Model / State / Control / Scratch
fields; ``model`` turns a Scene into the model's constant arrays (NumPy, float64); the stage
modules (``affine``, ``ortho``, ``joints``, ``commands``, ``potential``, ``assemble``,
``tree_solve``, ``prediction``, ``newton``, ``commit``) each build their Warp functions per
precision, and ``kernels`` composes them into the one-launch ``step`` kernel. ``contact/``
holds contact, host and kernel, a module per job. ``evaluate`` launches single stages for
tests; ``energy`` is the host-side mechanical energy.
"""
