"""Headless MuJoCo rendering: which OpenGL marknav asks MuJoCo for, and a clear error without it.

MuJoCo's Python bindings choose their OpenGL platform from ``MUJOCO_GL`` when ``mujoco`` is
first imported (``glfw`` when unset, which needs a display). A simulator has no window, so
:func:`import_mujoco` sets ``MUJOCO_GL=osmesa`` when the user has not chosen one: Mesa's
off-screen software renderer (llvmpipe), which needs no GPU and no display and comes in one
system package (:data:`OSMESA_PACKAGE`). ``MUJOCO_GL=egl`` (Mesa's EGL on llvmpipe, or a GPU's
EGL) works too when set by the user.

Everything that can fail here — the ``mujoco`` package missing, the system library missing, a
GL context that cannot be made — becomes an :class:`~marknav.core.errors.InputError` (exit 2)
naming what to install, never a traceback.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import importlib
import logging
import os
import sys
from types import ModuleType
from typing import Any

from marknav.core.errors import InputError

__all__ = ["EGL_PACKAGES", "OSMESA_PACKAGE", "backend", "import_mujoco", "make_renderer",
           "missing_library"]

log = logging.getLogger(__name__)

#: The Debian/Ubuntu package with Mesa's off-screen renderer (libOSMesa.so.8).
OSMESA_PACKAGE = "libosmesa6"
#: The Debian/Ubuntu packages for EGL on Mesa's software renderer.
EGL_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri"
#: The renderer marknav asks for when ``MUJOCO_GL`` is unset.
DEFAULT_BACKEND = "osmesa"

_LIBRARIES = {
    "osmesa": (("libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"), "OSMesa", OSMESA_PACKAGE),
    "egl": (("libEGL.so.1", "libEGL.so"), "EGL", EGL_PACKAGES),
}
_INSTALL_EXTRA = "pip install 'marknav[mujoco]'"


def backend() -> str:
    """The OpenGL platform MuJoCo will use: ``MUJOCO_GL``, or :data:`DEFAULT_BACKEND` (set in
    the environment by this call, before ``mujoco`` is imported) on Linux when unset. Also
    sets ``LP_NUM_THREADS=1`` (Mesa's rasteriser threads) unless the user set it."""
    # Mesa's software rasteriser on one thread: a simulated run is lock-step, and an evaluation
    # runs one simulation per core (--jobs); more threads only contend for the same cores.
    os.environ.setdefault("LP_NUM_THREADS", "1")
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if not chosen and sys.platform.startswith("linux"):
        os.environ["MUJOCO_GL"] = DEFAULT_BACKEND
        if "PYOPENGL_PLATFORM" not in os.environ:
            os.environ["PYOPENGL_PLATFORM"] = DEFAULT_BACKEND
        chosen = DEFAULT_BACKEND
    return chosen


def _install_hint(name: str) -> str:
    if name in _LIBRARIES:
        package = _LIBRARIES[name][2]
        return (f"install the system package {package} (Debian/Ubuntu: apt-get install -y "
                f"{package})")
    return "set MUJOCO_GL=osmesa (apt-get install -y libosmesa6) or MUJOCO_GL=egl"


def _library_present(name: str) -> bool:
    if name not in _LIBRARIES:
        return True  # a platform marknav does not know: let MuJoCo try it
    sonames, short, _ = _LIBRARIES[name]
    for soname in sonames:
        try:
            ctypes.CDLL(soname)
            return True
        except OSError:
            continue
    return ctypes.util.find_library(short) is not None


def missing_library() -> str | None:
    """``None`` when the OpenGL library of :func:`backend` is there, else how to install it
    (looked up without importing ``mujoco``)."""
    name = backend()
    if _library_present(name):
        return None
    return f"its renderer (MUJOCO_GL={name}) needs a system library: {_install_hint(name)}"


def import_mujoco(*, rendering: bool = True) -> ModuleType:
    """``mujoco``, imported with a headless OpenGL platform chosen (:func:`backend`). With
    ``rendering``, also check the platform's system library is there. Raises InputError."""
    name = backend()
    if rendering and not _library_present(name):
        raise InputError(f"the MuJoCo engine renders with MUJOCO_GL={name}, but its library is "
                         f"missing: {_install_hint(name)}", field="--engine")
    try:
        module = importlib.import_module("mujoco")
    except ImportError as exc:
        raise InputError(f"the MuJoCo engine needs the mujoco package ({exc}): "
                         f"{_INSTALL_EXTRA}", field="--engine") from None
    except RuntimeError as exc:  # an invalid MUJOCO_GL
        raise InputError(f"MuJoCo cannot start: {exc}; {_install_hint('')}",
                         field="MUJOCO_GL") from None
    return module


def make_renderer(model: Any, height: int, width: int) -> Any:
    """A ``mujoco.Renderer`` for ``model`` at ``width`` × ``height``; InputError (naming the
    system package) when no OpenGL context can be made."""
    mujoco = import_mujoco()
    name = backend()
    chosen = getattr(sys.modules.get("mujoco.rendering.classic.gl_context"), "_MUJOCO_GL", name)
    if chosen != name:
        raise InputError(f"mujoco was imported (with MUJOCO_GL={chosen or 'unset'}) before "
                         f"marknav chose a headless renderer: set MUJOCO_GL={name} in the "
                         "environment", field="MUJOCO_GL")
    try:
        return mujoco.Renderer(model, height, width)
    except Exception as exc:  # any GL failure: a missing driver, no display for glfw, ...
        raise InputError(f"MuJoCo cannot render with MUJOCO_GL={name} ({type(exc).__name__}: "
                         f"{exc}): {_install_hint(name)}", field="--engine") from None
