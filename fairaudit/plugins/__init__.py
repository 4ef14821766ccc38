"""Deprecated: the experiment code moved to :mod:`fairaudit.experiments`.

``import fairaudit.plugins.X`` still works and gives the module
``fairaudit.experiments.X`` itself (``plugins.experiments`` is now
``experiments.analysis``), with a :class:`DeprecationWarning`. This alias
will be removed in a later release.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType

warnings.warn(
    "fairaudit.plugins is deprecated: import from fairaudit.experiments instead", DeprecationWarning, stacklevel=2
)

_OLD = "fairaudit.plugins"
_RENAMED = {"experiments": "analysis"}


def _new_name(fullname: str) -> str:
    parts = fullname[len(_OLD) + 1 :].split(".")
    parts[0] = _RENAMED.get(parts[0], parts[0])
    return "fairaudit.experiments." + ".".join(parts)


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Makes ``fairaudit.plugins.<name>`` the very module ``fairaudit.experiments.<name>``."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        if not fullname.startswith(_OLD + "."):
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = importlib.import_module(_new_name(spec.name))
        spec.loader_state = module.__spec__  # the import system will overwrite it with this alias's spec
        return module

    def exec_module(self, module: ModuleType) -> None:
        # Already executed under its new name: give it back its own spec.
        module.__spec__ = module.__spec__.loader_state if module.__spec__ else None


if not any(isinstance(f, _Alias) for f in sys.meta_path):
    sys.meta_path.insert(0, _Alias())
