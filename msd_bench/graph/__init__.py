"""Stages of the main job that drive node *processes* (no rclpy in this package's own process)."""
