"""User-facing errors: one clear line, never a traceback."""


class DsmvError(Exception):
    """Base class of errors caused by user input rather than by a bug."""


class PluginError(DsmvError):
    """A plugin broke its contract at run time (a soil law's strength factor negative or not
    finite): the run ends ``failed`` with one line naming the plugin and what it was given."""


class ConfigError(DsmvError):
    """A config value is wrong.

    The message always names the config path, the value given and what is allowed,
    e.g. ``landing.mass_kg = -1.0: must be greater than 0 (kg)``.
    """

    def __init__(self, path: str, value, allowed: str):
        self.path, self.value, self.allowed = path, value, allowed
        super().__init__(f"{path} = {value!r}: {allowed}")
