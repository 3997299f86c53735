"""The ctypes mirror of include/lensray.h against the header itself."""

from __future__ import annotations

import shutil
import subprocess

import lensray
from lensray import _capi

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


def test_defaults_read_through_the_structs():
    """lr_camera_default and lr_render_settings_default, read through the
    ctypes structs, give the values the header documents."""
    cam = _capi.lr_camera()
    _capi.lib().lr_camera_default(_capi.ctypes.byref(cam))
    assert (cam.fov, cam.focus_distance, cam.aperture_blades) == (40, 10, 6)
    assert list(cam.look_at) == [0, 0, -1] and list(cam.focus_on) == [-1, -1]
    assert (cam.image_plane_distance, cam.focal_length) == (1, 9)
    assert (cam.chromatic.amplify, cam.chromatic.wavelengths) == (1, 8)
    assert cam.chromatic.abbe_nd == 1.5168 and cam.chromatic.abbe_vd == 64.17
    rs = _capi.lr_render_settings()
    _capi.lib().lr_render_settings_default(_capi.ctypes.byref(rs))
    assert (rs.width, rs.height, rs.spp, rs.max_depth, rs.tile_size) == (640, 480, 16, 8, 32)
    assert (rs.plan, rs.adaptive, rs.adaptive_min_spp) == (1, 1, 4)
    assert rs.adaptive_threshold == 0.01
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
