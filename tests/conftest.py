"""Suite-wide isolation: every test run gets its own ROS 2 domain on loopback only.

Set before any test imports rclpy, so DDS never multicasts off the machine and
two concurrent runs (or a developer's bench.py) never see each other.
"""

from __future__ import annotations

import os
import random

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
if "MSD_TEST_DOMAIN_ID" not in os.environ:
    # One domain for the whole run, shared with the node processes tests start.
    os.environ["MSD_TEST_DOMAIN_ID"] = str(random.Random(os.getpid()).randint(1, 200))
os.environ["ROS_DOMAIN_ID"] = os.environ["MSD_TEST_DOMAIN_ID"]
