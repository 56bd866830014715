"""The rig population's files: per-rig task results, rigs.md and rigs.png.
"""
