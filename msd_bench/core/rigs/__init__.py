"""Rigs: the rig emulator's physics, the rig population, playing the method through a rig, check-rig's
clauses.
"""
