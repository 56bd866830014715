"""rosbag2 (MCAP) bags: reading, writing, checking, recovering, and the records identification takes
from them.
"""
