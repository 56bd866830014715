"""Closed-loop evaluation (paper §5): greedy loops under scenarios, metrics, risk, Table-1 rows and
their statistics.
"""
