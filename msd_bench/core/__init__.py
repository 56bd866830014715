"""Pure science of the paper: plant, excitation, identification, Q-learning, metrics.

Nothing in this package imports rclpy: it runs in a notebook with no ROS at all.
"""
