"""The one exception family of the science core.

Every user mistake (bad force, empty record, unknown agent kind ...) raises a
subclass of :class:`MsdBenchError`, whose message is one line meant to be
printed as is by the CLI and the nodes, without a traceback.
"""


class MsdBenchError(ValueError):
    """A user-facing error: one clear line, no traceback needed."""


class InvalidInputError(MsdBenchError):
    """A value given to the core is non-finite, empty, mis-shaped or out of range."""


class ConfigError(MsdBenchError):
    """A configuration field has a value outside its documented range."""


class IdentificationError(MsdBenchError):
    """A model could not be fitted from the records given."""


class InterfaceError(MsdBenchError):
    """A plant interface description is inconsistent, or a message does not fit it.

    Raised by the wire layer (``msd_msgs_py/interface.py``): this module imports
    nothing, so the lowest layer can still raise the project's one error family.
    """
