"""User-facing errors.

Everything a user can get wrong (a scene file, a ``--set`` key, an experiment name) raises a
subclass of :class:`SwarmnavError`. The CLI turns these into one line on stderr and exit
code 2; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations


class SwarmnavError(Exception):
    """Base class of errors caused by user input."""


class ScenarioError(SwarmnavError):
    """A scene file or scene dictionary is malformed or physically impossible."""


class ConfigError(SwarmnavError):
    """A method parameter, experiment spec or command-line value is invalid."""


class StoreError(SwarmnavError):
    """A results store (``results.sqlite``) cannot be used: damaged, not a database, locked or
    unreadable. The message names the file."""


class DivergedError(SwarmnavError):
    """The simulated state stopped being finite: the parameters (gains, step) make the method
    numerically unstable. Valid values can still combine into an unstable run."""
