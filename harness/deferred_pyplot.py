"""``matplotlib.pyplot`` imported when it is first used, not when TOP-RA is imported.

``toppra.algorithm.algorithm`` imports ``matplotlib.pyplot`` at its top for its plotting
helpers, which the harness never calls; that import is about a quarter of what a sweep worker
imports before its first episode (``python -X importtime``: ~0.6 s of ~2.6 s on an idle box,
many times that on a loaded one). ``defer_pyplot`` puts a module in its place whose first
attribute read imports the real ``matplotlib.pyplot`` and forwards to it, so plotting works
unchanged (the report's plots use the real module) and a worker that never plots never pays.
Importing this module defers pyplot (``harness.planning.timing`` imports it before toppra);
it does nothing when pyplot is already imported.
"""

from __future__ import annotations

import importlib
import sys
import types
from importlib.machinery import ModuleSpec
from typing import Any

NAME = "matplotlib.pyplot"


class DeferredModule(types.ModuleType):
    """A module whose first attribute read imports the real one (replacing it in
    ``sys.modules``) and forwards every read to it."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.__spec__ = ModuleSpec(name, None)  # not "initializing": an import returns it as is
        self._real: types.ModuleType | None = None

    def __getattr__(self, attr: str) -> Any:  # only for names the placeholder does not have
        if self._real is None:
            if sys.modules.get(self.__name__) is self:
                del sys.modules[self.__name__]
            self._real = importlib.import_module(self.__name__)
        return getattr(self._real, attr)


def defer_pyplot() -> None:
    """Put a ``DeferredModule`` for ``matplotlib.pyplot`` in ``sys.modules`` unless the real
    module is there already."""
    if NAME not in sys.modules:
        sys.modules[NAME] = DeferredModule(NAME)


defer_pyplot()
