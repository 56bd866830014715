"""Files a run owns: atomic writes, bounded readers, model and policy artifacts, run directories.
"""
