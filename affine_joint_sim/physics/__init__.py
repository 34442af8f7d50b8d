"""Physics of affine bodies with revolute joints: host-side model build and Warp kernels.

Nothing here imports ROS. ``model`` turns a Scene into constant arrays (NumPy, float64);
``kernels`` holds the Warp step kernel that advances every environment by one dt.
"""
