"""The safety supervisor between any controller and the plant, and the adversaries that prove it.
"""
