"""The odsuite error hierarchy.

Every error a user can cause is an ``OdsuiteError``; its message is one line naming the file,
field, channel and value involved. The CLI prints that line and exits 1; any other exception is a
bug and keeps its traceback.
"""


class OdsuiteError(Exception):
    """Base of every error odsuite raises on purpose."""


class ConfigError(OdsuiteError, ValueError):
    """A setting, option or definition has an invalid value."""


class DivergedError(ConfigError):
    """A simulation's response grew without bound (a nonlinear model too strong for its force):
    a user's model is wrong, a fit's trial values are far off."""


class NonPhysicalError(ConfigError):
    """Values no physical body has (an inertia that is not positive definite): a user's model is
    wrong, a fit's trial values are outside what the model can hold."""


class NoSignalError(ConfigError):
    """A record whose every response reads one value throughout: there is nothing to compare a
    model with (a summary of several records leaves it out)."""


class DimensionError(OdsuiteError, ValueError):
    """Arrays or channel lists do not have the shapes that belong together."""


class ProjectFileError(OdsuiteError, OSError):
    """A project file cannot be opened, read or written."""


class NotAProjectError(ProjectFileError):
    """The file exists but is not an odsuite project."""


class ProjectVersionError(ProjectFileError):
    """The project was written by a newer, incompatible odsuite format version."""


class SchemaError(ProjectFileError):
    """The project file lacks a group, dataset or attribute the schema requires."""


class ProjectLockedError(ProjectFileError):
    """Another process has the project open for writing."""


class PluginError(OdsuiteError):
    """A plugin could not be used."""


class PluginLoadError(PluginError):
    """A plugin failed to load, or a required built-in plugin is missing."""


class PluginConflictError(PluginError):
    """Two plugins register a provider under the same name."""


class HardwareError(OdsuiteError, RuntimeError):
    """The acquisition hardware or its driver failed."""


class OdsuiteWarning(UserWarning):
    """Input odsuite accepts but reads with an assumption the user should know about."""


class DiskFullError(ProjectFileError):
    """The disk a file is written to has no room for it."""
