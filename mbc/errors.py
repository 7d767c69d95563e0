"""The package's exceptions, rooted in `MbcError`."""


class MbcError(Exception):
    """Base class of every error this package raises."""


class ConfigError(MbcError, ValueError):
    """A bad argument or configuration value; the message names the valid choices."""


class ModelLoadError(MbcError):
    """A robot model file is missing or does not parse."""
