"""Keep DDS on loopback: the environment every process of this project runs ROS under.

Set before rclpy initialises; child processes inherit it.
"""

import os
import random

from affine_joint_sim.resources import config_dir

__all__ = ['use_loopback_dds']


def use_loopback_dds() -> None:
    """Loopback-only discovery, a random domain unless one is set, and fast discovery."""
    # The default discovery range multicasts on every interface; nothing may leave loopback.
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    # A random domain keeps concurrent runs apart; 1..101 stays clear of domain 0 and within
    # the ports Fast DDS can compute for a localhost domain.
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
    # Faster participant discovery (the figures: README, "DDS stays on loopback").
    os.environ.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE',
                          str(config_dir() / 'fastdds_fast_discovery.xml'))
