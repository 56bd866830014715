"""The one error type of the bag layer.

Users (the CLI, the identifier node, notebooks) catch :class:`BagError` and
print it as is: its message is one line that names the bag path and, where it
matters, the topic. Library exceptions from rosbags and mcap never leak out of
:mod:`msd_bench.io.bags.reader`.
"""

from msd_bench.core.errors import MsdBenchError


class BagError(MsdBenchError):
    """A bag is missing, incomplete, corrupt, or lacks a topic we need."""
