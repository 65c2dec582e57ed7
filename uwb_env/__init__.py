"""uwb_env: closed-loop sensor scheduling in UWB multistatic radar networks.

``import uwb_env`` makes the env ids (``uwb_env.envs.ENV_IDS``) available to ``gymnasium.make`` without importing
gymnasium itself, so that the low modules (``uwb_env.units``, ``uwb_env.config``, ``uwb_env.scene``, ...) stay free of
it: importing any of them runs this file first. If gymnasium is already imported, the ids are registered now;
otherwise right after gymnasium's own import finishes (a one-shot import hook, removed once it has registered). The
registration itself is ``uwb_env.envs.register_envs`` (string entry points, idempotent);
``gymnasium.make("uwb_env:uwb_env/<Id>")`` works without any import, as for any Gymnasium package.
"""

from __future__ import annotations

import importlib
import importlib.abc
import sys
from collections.abc import Sequence
from importlib.machinery import ModuleSpec
from types import ModuleType

__version__ = "0.1.0"

_WATCHED = ("gymnasium", "uwb_env.envs")
"""Registration needs both gymnasium and ``uwb_env.envs``; whichever finishes importing last triggers it."""


def _register_envs_if_ready() -> None:
    """Register the env ids once gymnasium is imported, importing ``uwb_env.envs`` for its table if need be.

    ``uwb_env.envs`` itself imports gymnasium, so gymnasium can finish importing while ``uwb_env.envs`` is half
    imported (no ``register_envs`` yet): then nothing happens here, and the end of ``uwb_env.envs``'s import calls this
    again.
    """
    if "gymnasium" not in sys.modules:
        return
    try:
        envs = importlib.import_module("uwb_env.envs")
    except Exception as exc:  # reached from another package's import: say why that import fails
        raise ImportError(
            f"uwb_env registers its env ids with gymnasium once both are imported, and importing uwb_env.envs failed: "
            f"{type(exc).__name__}: {exc}"
        ) from exc
    register = getattr(envs, "register_envs", None)
    if register is None:
        return
    register()
    if _HOOK in sys.meta_path:
        sys.meta_path.remove(_HOOK)


class _RunAfterExec(importlib.abc.Loader):
    """Loader proxy: runs the real loader, hands the module back to it, then registers the env ids."""

    def __init__(self, loader: importlib.abc.Loader) -> None:
        self._loader = loader

    def create_module(self, spec: ModuleSpec) -> ModuleType | None:
        return self._loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        if module.__spec__ is not None:
            module.__spec__.loader = self._loader
        module.__loader__ = self._loader
        self._loader.exec_module(module)
        _register_envs_if_ready()


class _RegisterOnImport(importlib.abc.MetaPathFinder):
    """Finds gymnasium and ``uwb_env.envs`` through the other finders; wraps their loaders in :class:`_RunAfterExec`."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if fullname not in _WATCHED:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                if spec.loader is not None and hasattr(spec.loader, "exec_module"):
                    spec.loader = _RunAfterExec(spec.loader)
                return spec
        return None


_HOOK = _RegisterOnImport()

if "gymnasium" in sys.modules:
    _register_envs_if_ready()
else:
    sys.meta_path.insert(0, _HOOK)
