"""A registry of named, configurable algorithm classes: one pattern for the stance detectors
(``postproc.detectors``), the PDR step detectors (``postproc.pdr.detectors``) and step-length models
(``postproc.pdr.length``).

``@REGISTRY.register("name")`` enters a class under the name a user types (``--detector name``); the class
gets ``name`` set, and its first docstring line is its one-line description (``--list-detectors``). The
registry is a dict (name -> class), filled in the order the modules are imported.
"""

from __future__ import annotations

from typing import Callable


class Registry(dict):
    """Name -> class, filled by the ``register`` decorator.

    Parameters
    ----------
    what : str
        What the classes are, for messages ("stance detector", "step detector", ...).
    """

    def __init__(self, what: str):
        super().__init__()
        self.what = what

    def register(self, name: str) -> Callable[[type], type]:
        """Class decorator: enter the class under ``name`` (which must be new) and set ``cls.name``."""

        def enter(cls: type) -> type:
            if name in self:
                raise ValueError(f"{self.what} {name!r} registered twice ({self[name].__name__}, {cls.__name__})")
            cls.name = name
            self[name] = cls
            return cls

        return enter

    def get_class(self, name: str) -> type:
        """The class registered as ``name``; ValueError listing the registered names for an unknown one."""
        try:
            return self[name]
        except KeyError:
            raise ValueError(f"unknown {self.what} {name!r}; choose one of {', '.join(sorted(self))}") from None


def description(cls: type) -> str:
    """One line for listings: the first line of the class docstring (the class name without one)."""
    return (cls.__doc__ or cls.__name__).strip().splitlines()[0]
