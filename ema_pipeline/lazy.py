"""Package names imported on first use (a module ``__getattr__``, PEP 562).

A package's ``__init__`` that imported every module it re-exports would load
them all, and what they import (numpy and its BLAS, scipy, the channel sheet
...), for any part of the package: the command line's entry point must set
the BLAS thread variables before numpy loads, and identifying FRF files needs
neither the simulation nor the experiment file's readers. The packages that
re-export names (:mod:`ema_pipeline`, :mod:`ema_pipeline.cli`,
:mod:`ema_pipeline.io`, :mod:`ema_pipeline.acquisition`,
:mod:`ema_pipeline.identification`, :mod:`ema_pipeline.report`) take their ``__getattr__`` and
``__dir__`` from :func:`lazy_exports`. This module imports nothing of the
package's own.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: Mapping[str, str | tuple[str, str]]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` for the names of
    ``exports`` (each name's module, relative to ``package``, or the module
    and the name there, for a name exported under another): a name is
    imported from its module when first asked for and then kept in the
    package's namespace (later look-ups skip ``__getattr__``); any other name
    is an ``AttributeError``.

    Examples
    --------
    >>> getattr_, dir_ = lazy_exports("ema_pipeline", {"MAX_AXIS_HZ": "data"})
    >>> from ema_pipeline.data import MAX_AXIS_HZ
    >>> getattr_("MAX_AXIS_HZ") == MAX_AXIS_HZ, "MAX_AXIS_HZ" in dir_()
    (True, True)
    >>> getattr_("no_such_name")
    Traceback (most recent call last):
    AttributeError: module 'ema_pipeline' has no attribute 'no_such_name'
    """

    def __getattr__(name: str) -> Any:
        home = exports.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, attribute = home if isinstance(home, tuple) else (home, name)
        value = getattr(importlib.import_module(f"{package}.{module}"), attribute)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__
