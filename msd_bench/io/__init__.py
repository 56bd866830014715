"""File input/output: rosbag2 (MCAP) bags, model and Q-table artifacts, reports.

The only package that touches files (docs/design.md §Layers).
"""
