"""Stages of the main job that drive node *processes* (no rclpy in this package's own process, but for
the live view's watch of the plant, ``graph/live.py``, started only by ``bench.py --live``)."""
