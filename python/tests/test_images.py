"""lensray.write and the Jupyter picture, with the library's encoders."""

from __future__ import annotations

import struct
import subprocess

import numpy as np
import pytest

import lensray

from conftest import BUILD, LENS, SCENES, SMALL, cli_render, read_exr, same_bits


def prefixed(prefix, d):
    return {f"{prefix}.{k}": v for k, v in d.items()}


def test_write_exr_round_trips_through_openexr(tmp_path):
    rng = np.random.default_rng(1)
    rgb = rng.random((7, 11, 3), dtype=np.float32) * 100
    z = rng.random((7, 11), dtype=np.float32)
    lensray.write(tmp_path / "a.exr", rgb, z)
    back, zback = read_exr(tmp_path / "a.exr")
    assert same_bits(back, rgb) and same_bits(zback, z)
    lensray.write(tmp_path / "b.exr", rgb, half=True)
    back, zback = read_exr(tmp_path / "b.exr")
    assert zback is None
    assert np.allclose(back, rgb, rtol=1e-3) and not same_bits(back, rgb)


def test_write_png_matches_the_cli(tmp_path, spheres):
    """The same render written by the CLI and by lensray.write gives the
    same PNG file, 8 and 16 bit."""
    sets = {**prefixed("camera", LENS), **prefixed("render", SMALL)}
    rgb = spheres.render(camera=LENS, render=SMALL)
    cli_render(SCENES / "spheres.json", tmp_path / "cli.png", sets)
    lensray.write(tmp_path / "py.png", rgb)
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    cli_render(SCENES / "spheres.json", tmp_path / "cli16.png", sets, "--png16")
    lensray.write(tmp_path / "py16.png", rgb, png16=True)
    assert (tmp_path / "py16.png").read_bytes() == (tmp_path / "cli16.png").read_bytes()
    assert rgb._repr_png_() == (tmp_path / "py.png").read_bytes()


def test_repr_png_is_a_png_of_the_right_size(spheres):
    rgb = spheres.render(render=SMALL)
    png = rgb._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    w, h = struct.unpack(">II", png[16:24])
    assert (w, h) == (SMALL["width"], SMALL["height"])
    # Arithmetic on an Image gives an Image; non-pictures show as text.
    assert (rgb * 2)._repr_png_() is not None
    assert rgb[:, :, 0]._repr_png_() is None
    assert isinstance(rgb.mean(), (float, np.floating))


def test_write_refuses_bad_input(tmp_path):
    with pytest.raises(ValueError):
        lensray.write(tmp_path / "a.exr", np.zeros((4, 4, 5)))
    with pytest.raises(ValueError):
        lensray.write(tmp_path / "a.exr", np.zeros((4, 4, 3)), np.zeros((3, 4)))
    with pytest.raises(lensray.SceneError):
        lensray.write(tmp_path / "a.tiff", np.zeros((4, 4, 3)))
    with pytest.raises(lensray.LensrayIOError):
        lensray.write(tmp_path / "no" / "dir" / "a.png", np.zeros((4, 4, 3)))
    assert not (tmp_path / "a.exr").exists()
    # A Z channel a PNG cannot hold is refused, not dropped (the CLI's
    # --depth and the daemon's output.depth refuse PNG too).
    with pytest.raises(ValueError, match="Z channel"):
        lensray.write(tmp_path / "a.PNG", np.zeros((4, 4, 3)), np.zeros((4, 4)))
    assert not (tmp_path / "a.PNG").exists()
    # So are options for the other format: half=True made an 8-bit PNG and
    # png16=True a float EXR, silently (the CLI refuses --half with .png).
    with pytest.raises(ValueError, match="half"):
        lensray.write(tmp_path / "a.png", np.zeros((4, 4, 3)), half=True)
    with pytest.raises(ValueError, match="png16"):
        lensray.write(tmp_path / "a.EXR", np.zeros((4, 4, 3)), png16=True)
    assert not (tmp_path / "a.png").exists()
    assert not (tmp_path / "a.EXR").exists()
    # No array, or a scalar, is named as such: None became a NaN scalar and
    # then "got shape (1,)", a shape the caller never passed.
    with pytest.raises(TypeError, match="None"):
        lensray.write(tmp_path / "a.exr", None)
    with pytest.raises(ValueError, match=r"got shape \(\)"):
        lensray.encode_png(0.5)
    with pytest.raises(ValueError, match=r"got shape \(3,\)"):
        lensray.encode_png([0.5, 0.5, 0.5])
    # NaN and infinity are refused and located: the file held them as 0,
    # silently (an independent check).
    bad = np.zeros((4, 4, 3), np.float32)
    bad[2, 1, 0] = np.inf
    bad[3, 3, 2] = np.nan
    with pytest.raises(ValueError, match=r"2 NaN or infinite values \(the first at row 2, column 1\)"):
        lensray.write(tmp_path / "a.exr", bad)
    with pytest.raises(ValueError, match="NaN or infinite"):
        lensray.encode_png(bad)
    # A depth of NaN was written as 1e10 (+inf is that by the docs).
    z = np.zeros((4, 4), np.float32)
    z[1, 3] = np.nan
    with pytest.raises(ValueError, match=r"depth holds NaN or -inf \(the first at row 1, column 3\)"):
        lensray.write(tmp_path / "a.exr", np.zeros((4, 4, 3)), z)
    assert not (tmp_path / "a.exr").exists()


@pytest.mark.parametrize("compression", ["zip", "zips", "none"])
@pytest.mark.parametrize("half", [False, True])
def test_own_exr_reader_equals_openexr(tmp_path, spheres, compression, half):
    # lensray's reader for Pythons without OpenEXR (Blender's), on what
    # lensray writes, against the OpenEXR package: the same bits.
    from lensray import _exr
    rgb, z = spheres.render(render={"width": 61, "height": 37, "spp": 2}, depth=True)
    path = tmp_path / "a.exr"
    cli = [str(BUILD / "lensray"), "render", str(SCENES / "spheres.json"), "-o", str(path),
           "-q", "--depth", "--set", "render.width=61", "--set", "render.height=37",
           "--set", "render.spp=2", "--compression", compression] + (["--half"] if half else [])
    subprocess.run(cli, check=True, timeout=60)
    ch = _exr.read(path.read_bytes())
    ref_rgb, ref_z = read_exr(path)
    assert same_bits(np.stack([ch[c] for c in "RGB"], axis=2), ref_rgb)
    assert same_bits(ch["Z"], ref_z) and same_bits(ch["Z"], z)
    if not half:
        assert same_bits(np.stack([ch[c] for c in "RGB"], axis=2), rgb)
    with pytest.raises(ValueError, match="OpenEXR"):
        _exr.read(b"not an exr")
