"""Physics of affine bodies joined by joints: host-side model build and Warp kernels.

Nothing here imports ROS. The folders follow the pipeline: ``host/`` builds the model on the
host (``fields``, the one table of Model / State / Control / Scratch fields; ``model``, a
Scene turned into the model's constant arrays, NumPy float64; mass, rigidity, the joint types'
table, and ``energy``, the host-side mechanical energy); ``stages/`` holds the kernel stages
(``affine``, ``ortho``, ``joint_terms``, ``commands``, ``potential``, ``assemble``,
``prediction``, ``commit``, ``step``), each building its Warp functions per precision;
``solve/`` holds Newton's method and its linear solves; ``joints/`` the joint types and
``contact/`` contact, host and kernel, a module per job. ``kernels`` composes the stages into
the one-launch ``step`` kernel; ``evaluate`` launches single stages for tests.
"""
