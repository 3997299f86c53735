"""ctypes mirror of include/lensray.h and the search for liblensray.

Only this module knows the C structs' layouts.  They must match
include/lensray.h field for field; tests/test_capi.py compiles a probe
against the header and compares every field's offset and the structs'
sizes, so a change to the header that is not made here too fails the
tests instead of corrupting memory.

A camera is not mirrored: it is the library's own (lr_camera_new), set
through lr_scene_camera and lr_camera_apply_json with the scene format's
keys and read back through lr_camera_json, so a camera model's fields
are its own business and adding one changes nothing here.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from ctypes import (
    CFUNCTYPE,
    POINTER,
    Structure,
    c_char,
    c_char_p,
    c_double,
    c_int,
    c_size_t,
    c_uint64,
    c_void_p,
)
from pathlib import Path
from typing import Any, Optional

# lr_status
LR_OK = 0
LR_ERR_INVALID = -1
LR_ERR_IO = -2
LR_ERR_NOMEM = -3
LR_ERR_EMBREE = -4
LR_ERR_CANCELLED = -5
LR_ERR_LIMIT = -6

# lr_format
LR_FORMAT_EXR = 0
LR_FORMAT_PNG = 1

# LR_DEPTH_NONE: the Z of a pixel whose ray hits nothing.
DEPTH_NONE = 1e10


class lr_error(Structure):
    _fields_ = [
        ("status", c_int),
        ("path", c_char * 256),
        ("message", c_char * 768),
    ]


# void (*)(void *user, uint64_t done, uint64_t total)
lr_progress_fn = CFUNCTYPE(None, c_void_p, c_uint64, c_uint64)


class lr_render_settings(Structure):
    _fields_ = [
        ("width", c_int),
        ("height", c_int),
        ("spp", c_int),
        ("sampler", c_int),
        ("seed", c_uint64),
        ("max_depth", c_int),
        ("threads", c_int),
        ("tile_size", c_int),
        ("want_depth", c_int),
        ("region", c_int * 4),
        ("plan", c_int),
        ("adaptive", c_int),
        ("adaptive_threshold", c_double),
        ("adaptive_min_spp", c_int),
        ("progress", lr_progress_fn),
        ("progress_user", c_void_p),
        ("cancel", POINTER(c_int)),
        ("integrator", c_int),
        ("light", c_int),
    ]


class lr_render_stats(Structure):
    _fields_ = [
        ("seconds", c_double),
        ("cpu_seconds", c_double),
        ("pixels", c_uint64),
        ("samples", c_uint64),
        ("rays", c_uint64),
        ("nan_samples", c_uint64),
        ("threads", c_int),
        ("lens_pixels", c_uint64),
        ("chroma_pixels", c_uint64),
        ("camera_rays", c_uint64),
        ("full_camera_rays", c_uint64),
        ("full_samples", c_uint64),
        ("lens_blocked", c_uint64),
        ("light_lights", c_uint64),
        ("light_paths", c_uint64),
        ("light_landed", c_uint64),
        ("ghost_lights", c_uint64),
        ("ghost_paths", c_uint64),
        ("ghost_landed", c_uint64),
        ("ghost_flux", c_double),
    ]


class lr_output_options(Structure):
    _fields_ = [
        ("exr_half", c_int),
        ("exr_depth", c_int),
        ("png_16bit", c_int),
        ("exr_compression", c_int),
    ]


STRUCTS = {
    "lr_error": lr_error,
    "lr_render_settings": lr_render_settings,
    "lr_render_stats": lr_render_stats,
    "lr_output_options": lr_output_options,
}

# The C functions: name -> (restype, argtypes).  Pointers to opaque
# handles (lr_scene *, lr_image *) travel as c_void_p.
_P = c_void_p
_PP = POINTER(c_void_p)
_ERR = POINTER(lr_error)
# lr_camera *: a camera from lr_camera_new, whose layout only C knows.
_CAM = c_void_p
_SIGNATURES = {
    "lr_version": (c_char_p, []),
    "lr_status_name": (c_char_p, [c_int]),
    "lr_camera_new": (_CAM, []),
    "lr_camera_free": (None, [_CAM]),
    "lr_camera_json": (c_void_p, [_CAM]),
    "lr_render_settings_default": (None, [POINTER(lr_render_settings)]),
    "lr_render_settings_validate": (c_int, [POINTER(lr_render_settings), _ERR]),
    "lr_camera_apply_json": (c_int, [_CAM, c_char_p, c_size_t, _ERR]),
    "lr_render_settings_apply_json": (
        c_int, [POINTER(lr_render_settings), c_char_p, c_size_t, _ERR]),
    "lr_scene_load_file": (
        c_int, [c_char_p, POINTER(c_char_p), c_size_t, _PP, _ERR]),
    "lr_scene_load_json": (
        c_int, [c_char_p, c_size_t, c_char_p, POINTER(c_char_p), c_size_t,
                _PP, _ERR]),
    "lr_scene_free": (None, [_P]),
    "lr_scene_camera": (None, [_P, _CAM]),
    "lr_scene_settings": (None, [_P, POINTER(lr_render_settings)]),
    "lr_scene_primitive_count": (c_size_t, [_P]),
    "lr_scene_warnings": (c_char_p, [_P]),
    "lr_render": (
        c_int, [_P, _CAM, POINTER(lr_render_settings), _PP,
                POINTER(lr_render_stats), _ERR]),
    "lr_image_width": (c_int, [_P]),
    "lr_image_height": (c_int, [_P]),
    "lr_image_rgb": (POINTER(ctypes.c_float), [_P]),
    "lr_image_depth": (POINTER(ctypes.c_float), [_P]),
    "lr_image_create": (c_int, [c_int, c_int, c_int, _PP, _ERR]),
    "lr_image_rgb_mut": (POINTER(ctypes.c_float), [_P]),
    "lr_image_depth_mut": (POINTER(ctypes.c_float), [_P]),
    "lr_image_free": (None, [_P]),
    "lr_output_options_default": (None, [POINTER(lr_output_options)]),
    "lr_format_from_path": (c_int, [c_char_p, POINTER(c_int), _ERR]),
    "lr_image_encode": (
        c_int, [_P, c_int, POINTER(lr_output_options), _PP, POINTER(c_size_t),
                _ERR]),
    "lr_image_write": (c_int, [_P, c_char_p, POINTER(lr_output_options), _ERR]),
    "lr_free": (None, [c_void_p]),
    "lr_render_plan_map": (
        c_int, [_P, _CAM, POINTER(lr_render_settings), _PP,
                POINTER(c_int), POINTER(c_int), _ERR]),
}

# lr_render_plan_map's cells (include/lensray.h): one per block of
# PLAN_BLOCK x PLAN_BLOCK pixels, bits PLAN_LENS and PLAN_CHROMA.
PLAN_BLOCK = 16
PLAN_LENS = 1
PLAN_CHROMA = 2

# Functions newer than the first release: used when the library has them.
_OPTIONAL = {
    "lr_progress_store": (None, [c_void_p, c_uint64, c_uint64]),
}

# Library file names, most specific first.
_NAMES = ("liblensray.so.0", "liblensray.so")


def candidate_paths() -> list[Path]:
    """Where liblensray is looked for, in order (see library_path)."""
    here = Path(__file__).resolve().parent
    found: list[Path] = []
    env = os.environ.get("LENSRAY_LIB")
    if env:
        found.append(Path(env))
    found += [here / n for n in _NAMES]
    # A source checkout: python/lensray/ sits two levels below the
    # repository, whose build/ holds the library.
    for up in here.parents:
        found += [up / "build" / n for n in _NAMES]
    return found


def _find() -> str:
    env = os.environ.get("LENSRAY_LIB")
    if env:
        # An explicit choice is never second-guessed: a wrong one fails.
        if not Path(env).exists():
            raise OSError(f"LENSRAY_LIB={env}: no such file")
        # Absolute: dlopen looks a name without a slash up on the
        # system's library path, not in the current directory.
        return os.path.abspath(env)
    for p in candidate_paths():
        if p.exists():
            return str(p)
    # Installed with `make install`: the linker's search path.
    name = ctypes.util.find_library("lensray")
    if name:
        return name
    raise OSError(
        "liblensray not found: build it with `make` in the lensray "
        "repository and reinstall the package (`pip install ./python`), or "
        "set LENSRAY_LIB to the path of liblensray.so")


_lib: Optional[ctypes.CDLL] = None
_lib_path: Optional[str] = None
_progress_store: Optional[Any] = None


def lib() -> ctypes.CDLL:
    """The loaded library, with every function's signature declared."""
    global _lib, _lib_path
    if _lib is None:
        path = _find()
        handle = ctypes.CDLL(path)
        for name, (res, args) in _SIGNATURES.items():
            fn = getattr(handle, name)
            fn.restype = res
            fn.argtypes = args
        for name, (res, args) in _OPTIONAL.items():
            fn = getattr(handle, name, None)
            if fn is not None:
                fn.restype = res
                fn.argtypes = args
        _lib, _lib_path = handle, path
    return _lib


def library_path() -> str:
    """The file liblensray was loaded from (loading it if need be)."""
    lib()
    assert _lib_path is not None
    return _lib_path


def progress_store() -> Optional[Any]:
    """lr_progress_store as an lr_progress_fn for lr_render_settings, or
    None when the library predates it."""
    global _progress_store
    if _progress_store is None:
        fn = getattr(lib(), "lr_progress_store", None)
        if fn is None:
            return None
        # Cast once: each ctypes.cast keeps its source alive in the
        # function pointer's _objects, one entry (some 250 bytes) a render.
        _progress_store = ctypes.cast(ctypes.cast(fn, c_void_p), lr_progress_fn)
    return _progress_store
