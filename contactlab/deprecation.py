"""Former public names, kept working (with a DeprecationWarning) after a rename.

``fit`` means scikit-learn's "estimate parameters from data and return self"
everywhere in contactlab; methods and functions that returned a result under
that name are now called ``estimate`` (or ``from_segments`` for a
constructor), and their former names forward here.
"""

from __future__ import annotations

import functools
import warnings


def _warn(old: str, new: str) -> None:
    warnings.warn(f"{old} is now {new}", DeprecationWarning, stacklevel=3)


def renamed_method(old: str, new: str, *, on_class: bool = False):
    """A method ``old`` that warns and calls the method ``new`` (a classmethod when
    ``on_class``)."""

    def method(obj, *args, **kwargs):
        owner = obj if isinstance(obj, type) else type(obj)
        _warn(f"{owner.__name__}.{old}", new)
        return getattr(obj, new)(*args, **kwargs)

    method.__name__ = old
    method.__doc__ = f"Former name of :meth:`{new}` (deprecated)."
    return classmethod(method) if on_class else method


def renamed_function(old: str, fn):
    """A function ``old`` that warns and calls ``fn``."""

    @functools.wraps(fn)
    def function(*args, **kwargs):
        _warn(old, fn.__name__)
        return fn(*args, **kwargs)

    function.__name__ = old
    function.__doc__ = f"Former name of :func:`{fn.__name__}` (deprecated)."
    return function
