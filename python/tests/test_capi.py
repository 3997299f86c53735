"""The ctypes mirror of include/lensray.h against the header itself, and
the camera the package sets by JSON instead of mirroring it."""

from __future__ import annotations

import json
import shutil
import subprocess
from ctypes import byref

import lensray
from lensray import _capi, _core

from conftest import BUILD, REPO


def test_struct_layouts_match_the_header(tmp_path):
    """Every field's offset and every struct's size, as the C compiler
    lays them out, equal the ctypes structs'."""
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    assert cc, "a C compiler is needed (the library's build uses one)"
    lines = ["#include <stdio.h>", "#include <stddef.h>", '#include "lensray.h"',
             "int main(void) {"]
    for name, cls in _capi.STRUCTS.items():
        lines.append(f'printf("{name} %zu\\n", sizeof({name}));')
        for field, _ in cls._fields_:
            lines.append(f'printf("{name}.{field} %zu\\n", offsetof({name}, {field}));')
    lines.append("return 0; }")
    src = tmp_path / "probe.c"
    src.write_text("\n".join(lines))
    exe = tmp_path / "probe"
    subprocess.run([cc, "-I", str(REPO / "include"), "-o", str(exe), str(src)],
                   check=True)
    c = dict(line.rsplit(" ", 1) for line in
             subprocess.run([str(exe)], capture_output=True, text=True,
                            check=True).stdout.splitlines())
    py = {}
    for name, cls in _capi.STRUCTS.items():
        py[name] = str(_capi.ctypes.sizeof(cls))
        for field, _ in cls._fields_:
            py[f"{name}.{field}"] = str(getattr(cls, field).offset)
    assert py == c


def _camera_keys(keys: dict) -> dict:
    """lr_camera_json of a camera from lr_camera_new with `keys` applied
    by lr_camera_apply_json: the calls the package sets cameras with."""
    cam = _core._Camera()
    text = json.dumps(keys).encode()
    err = _capi.lr_error()
    st = _capi.lib().lr_camera_apply_json(cam.ptr, text, len(text), byref(err))
    assert st == _capi.LR_OK, err.message
    out = _capi.lib().lr_camera_json(cam.ptr)
    try:
        return json.loads(_capi.ctypes.string_at(out))
    finally:
        _capi.lib().lr_free(out)


def test_defaults_are_the_headers():
    """A camera from lr_camera_new, read as JSON, and
    lr_render_settings_default, read through the ctypes struct, give the
    values the header documents."""
    assert _camera_keys({}) == {"model": "pinhole", "position": [0, 0, 0],
                                "look_at": [0, 0, -1], "up": [0, 1, 0], "fov": 40}
    thin = _camera_keys({"model": "thinlens"})
    assert (thin["focus_distance"], thin["aperture_blades"]) == (10, 6)
    bracket = _camera_keys({"model": "bracket", "chromatic": {"mode": "rgb"},
                            "focus_on": [3, 4]})
    assert (bracket["image_plane_distance"], bracket["focal_length"]) == (1, 9)
    assert bracket["focus_on"] == [3, 4]
    ch = bracket["chromatic"]
    assert (ch["amplify"], ch["wavelengths"]) == (1, 8)
    # No autofocus by default (focus_on -1, -1: written as nothing).
    assert "focus_on" not in _camera_keys({"model": "bracket"})
    rs = _capi.lr_render_settings()
    _capi.lib().lr_render_settings_default(_capi.ctypes.byref(rs))
    assert (rs.width, rs.height, rs.spp, rs.max_depth, rs.tile_size) == (640, 480, 16, 8, 32)
    # 0: the threshold and the minimum are derived from spp.
    assert (rs.plan, rs.adaptive, rs.adaptive_min_spp) == (1, 1, 0)
    assert rs.adaptive_threshold == 0
    assert not rs.progress and not rs.cancel


def test_library_is_found_and_versioned():
    assert lensray.version() == "%d.%d.%d" % (0, 1, 0)
    # The library the package loaded is this build's (a bundled copy made
    # by `pip install ./python`, or the file itself), not a stale one.
    loaded = open(lensray.library_path(), "rb").read()
    assert loaded == (BUILD / "liblensray.so.0").resolve().read_bytes()


def test_lensray_lib_names_a_missing_file(tmp_path):
    import sys
    env = {"LENSRAY_LIB": str(tmp_path / "nope.so"), "PATH": "/usr/bin:/bin"}
    r = subprocess.run([sys.executable, "-c", "import lensray; lensray.version()"],
                       capture_output=True, text=True, env=env)
    assert r.returncode != 0
    assert "LENSRAY_LIB=" in r.stderr and "no such file" in r.stderr


def test_lensray_lib_chooses_the_library(tmp_path):
    import sys
    lib = BUILD / "liblensray.so"
    env = {"LENSRAY_LIB": str(lib), "PATH": "/usr/bin:/bin"}
    r = subprocess.run([sys.executable, "-c",
                        "import lensray; print(lensray.library_path())"],
                       capture_output=True, text=True, env=env, check=True)
    assert r.stdout.strip() == str(lib)


def test_lensray_lib_bare_name_is_the_file_here(tmp_path):
    """A bare file name is the file in the current directory: dlopen took
    it for a name to look up on the system's library path and failed."""
    import shutil
    import sys
    shutil.copy(BUILD / "liblensray.so.0", tmp_path / "mylensray.so")
    env = {"LENSRAY_LIB": "mylensray.so", "PATH": "/usr/bin:/bin"}
    r = subprocess.run([sys.executable, "-c",
                        "import lensray; print(lensray.library_path())"],
                       capture_output=True, text=True, env=env, cwd=tmp_path,
                       check=True)
    assert r.stdout.strip() == str(tmp_path / "mylensray.so")


def test_progress_store_is_cast_once():
    """Each ctypes.cast kept its source in the function pointer's
    _objects: one entry, some 250 bytes, leaked a render with progress."""
    a = _capi.progress_store()
    assert a is not None and _capi.progress_store() is a


def test_cameras_are_not_mirrored():
    """The package passes cameras as the library's own (lr_camera_new)
    and knows no field of lr_camera, so a camera model's fields can change
    without the package: no ctypes struct of the camera is left."""
    assert not hasattr(_capi, "lr_camera") and not hasattr(_capi, "lr_chromatic")
    assert not {"lr_camera", "lr_chromatic"} & set(_capi.STRUCTS)
