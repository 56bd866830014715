"""Thin rclpy adapters: declare parameters, translate messages, own timers and QoS."""
