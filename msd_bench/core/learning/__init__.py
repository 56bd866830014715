"""Tabular Q-learning (paper §4): configuration, compiled kernels, training, table selection, Dyna-Q.
"""
