"""msd-bench: a ROS 2 bench for system identification then off-plant Q-learning."""

__version__ = "0.1.0"
