"""In-process rendering: pixels against the CLI, overrides, depth, stats."""

from __future__ import annotations

import json
import threading
from collections.abc import Mapping

import numpy as np
import pytest

import lensray

from conftest import LENS, SCENES, SMALL, cli_render, read_exr, same_bits


def prefixed(prefix: str, d: dict) -> dict:
    return {f"{prefix}.{k}": v for k, v in d.items()}


def test_pixels_equal_the_cli_exr_bit_for_bit(tmp_path, spheres):
    out = tmp_path / "cli.exr"
    cli_render(SCENES / "spheres.json", out,
               {**prefixed("camera", LENS), **prefixed("render", SMALL)}, "--depth")
    ref_rgb, ref_z = read_exr(out)
    rgb, z = spheres.render(camera=LENS, render=SMALL, depth=True)
    assert rgb.shape == (SMALL["height"], SMALL["width"], 3)
    assert rgb.dtype == np.float32 and z.dtype == np.float32
    assert isinstance(rgb, np.ndarray)
    assert same_bits(rgb, ref_rgb)
    assert same_bits(z, ref_z)
    # The thin lens blurred something: this is not a trivially equal image.
    pinhole = spheres.render(render=SMALL)
    assert not same_bits(pinhole, rgb)


def test_chromatic_spectral_equals_the_cli(tmp_path):
    """Nested overrides (camera.chromatic as an object) reach the library
    as the CLI's --set does."""
    chroma = {"mode": "spectral", "focal_model": "lensmaker", "amplify": 3,
              "glass": "BK7", "wavelengths": 4}
    cam = {"model": "thinlens", "focal_length_mm": 50, "f_number": 1.4,
           "focus_distance": 30, "chromatic": chroma}
    out = tmp_path / "cli.exr"
    cli_render(SCENES / "chromatic.json", out,
               {**prefixed("camera", cam), **prefixed("render", SMALL)})
    with lensray.load(SCENES / "chromatic.json") as s:
        rgb = s.render(camera=cam, render=SMALL)
    assert same_bits(rgb, read_exr(out)[0])


def test_load_overrides_equal_render_overrides(spheres):
    sets = {**prefixed("camera", LENS), **prefixed("render", SMALL)}
    with lensray.load(SCENES / "spheres.json", sets) as s:
        a = s.render()
    with lensray.load(SCENES / "spheres.json",
                      [f"{k}={json.dumps(v)}" for k, v in sets.items()]) as s:
        b = s.render()
    c = spheres.render(camera=LENS, render=SMALL)
    assert same_bits(a, c) and same_bits(b, c)


def test_load_from_dict_equals_load_from_file(spheres):
    doc = json.loads((SCENES / "spheres.json").read_text())
    with lensray.load(doc, base_dir=SCENES) as s:
        a = s.render(camera=LENS, render=SMALL)
    assert same_bits(a, spheres.render(camera=LENS, render=SMALL))


def test_numpy_scalars_are_accepted_as_values(spheres):
    a = spheres.render(camera={"focus_distance": np.float32(12.5), "aperture_radius": 0.1,
                               "model": "thinlens"},
                       render={"width": np.int64(32), "height": 24, "spp": 2})
    b = spheres.render(camera={"focus_distance": 12.5, "aperture_radius": 0.1,
                               "model": "thinlens"},
                       render={"width": 32, "height": 24, "spp": 2})
    assert same_bits(a, b)


def test_stats_and_region(spheres):
    rgb, stats = spheres.render(camera=LENS, render=SMALL, stats=True)
    w, h = SMALL["width"], SMALL["height"]
    assert stats["pixels"] == w * h
    assert stats["full_samples"] == w * h * SMALL["spp"]
    assert 0 < stats["samples"] <= stats["full_samples"]
    assert stats["rays"] >= stats["camera_rays"] > 0
    assert stats["seconds"] > 0 and stats["threads"] >= 1
    crop = spheres.render(camera=LENS, render={**SMALL, "region": [10, 5, 50, 30]})
    assert crop.shape == (25, 40, 3)
    assert same_bits(crop, rgb[5:30, 10:50])


def test_depth_marks_the_sky(spheres):
    rgb, z, stats = spheres.render(render=SMALL, depth=True, stats=True)
    assert z.shape == rgb.shape[:2]
    # The top row looks at the sky; the bottom row at the ground plane.
    assert np.all(z[0] == np.float32(lensray.DEPTH_NONE))
    assert np.all((z[-1] > 0) & (z[-1] < 100))


def test_gil_is_released_while_rendering(spheres):
    """Another Python thread runs while the library renders."""
    started = threading.Event()
    done = threading.Event()
    ticks = [0]

    def spin() -> None:
        started.set()
        while not done.is_set():
            ticks[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    started.wait()
    before = ticks[0]
    _, stats = spheres.render(camera=LENS, render={**SMALL, "spp": 256, "adaptive": False},
                              stats=True)
    during = ticks[0] - before
    done.set()
    t.join()
    # With the GIL held by the render, the spinning thread would get no
    # turn at all until it returned; Python's switch interval is 5 ms.
    assert stats["seconds"] > 0.05
    assert during > 1000


class FakeBar:
    made: list["FakeBar"] = []

    def __init__(self, total, **kw):
        self.total = total
        self.n = 0
        self.seen = []
        self.closed = False
        FakeBar.made.append(self)

    def update(self, k):
        self.n += k
        self.seen.append(self.n)

    def close(self):
        self.closed = True


@pytest.mark.parametrize("path", ["lr_progress_store", "python callback"])
def test_progress_bar_counts_pixels(spheres, monkeypatch, path):
    from lensray import _capi, _core
    FakeBar.made = []
    monkeypatch.setattr(_core, "_progress_bar", lambda enabled: FakeBar)
    if path == "lr_progress_store":
        assert _capi.progress_store() is not None
    else:
        # A library without lr_progress_store.
        monkeypatch.setattr(_capi, "progress_store", lambda: None)
    render = {"width": 160, "height": 90, "spp": 512, "adaptive": False,
              "tile_size": 8, "threads": 1}
    spheres.render(camera=LENS, render=render)
    assert len(FakeBar.made) == 1
    bar = FakeBar.made[0]
    assert bar.total == 160 * 90
    assert bar.closed and bar.n == bar.total
    assert bar.seen == sorted(bar.seen) and len(bar.seen) >= 2


def test_tqdm_is_used_when_installed():
    import tqdm.auto
    from lensray import _core
    assert _core._progress_bar(None) is tqdm.auto.tqdm
    assert _core._progress_bar(False) is None


def test_a_closed_scene_refuses_to_render():
    s = lensray.load(SCENES / "spheres.json")
    s.close()
    s.close()
    with pytest.raises(ValueError):
        s.render(render=SMALL)


def test_close_while_a_render_prepares_is_refused():
    """close() from anywhere while a render holds the scene raises
    RuntimeError, even before the library is called: render() read the
    handle and counted itself as rendering only later, and a close() from
    another thread in between freed the scene (a segfault in an
    independent check's loop of 3000).  Here the close comes from inside
    the render's reading of its overrides, deterministically."""
    s = lensray.load(SCENES / "spheres.json")
    seen = []

    class Closing(Mapping):
        def __init__(self, d):
            self.d = d

        def __getitem__(self, k):
            return self.d[k]

        def __len__(self):
            return len(self.d)

        def __iter__(self):
            try:
                s.close()
                seen.append("closed")
            except RuntimeError as e:
                seen.append(str(e))
            return iter(self.d)

    img = s.render(camera=Closing({"fov": 30}), render=SMALL, progress=False)
    assert seen == ["the scene is being rendered"]
    assert img.shape[2] == 3
    s.close()
    with pytest.raises(ValueError):
        s.render(render=SMALL)


def test_threads_render_one_scene_at_once(spheres):
    """Two Python threads rendering the same scene with different cameras
    get what each would alone."""
    cams = [LENS, {**LENS, "focus_distance": 9}]
    alone = [spheres.render(camera=c, render=SMALL) for c in cams]
    got = [None, None]

    def go(i):
        got[i] = spheres.render(camera=cams[i], render={**SMALL, "threads": 1},
                                progress=False)

    ts = [threading.Thread(target=go, args=(i,)) for i in range(2)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert all(same_bits(g, a) for g, a in zip(got, alone))
    assert not same_bits(alone[0], alone[1])


def test_lr_progress_store_stores_both_numbers():
    import ctypes
    from lensray import _capi
    box = (ctypes.c_uint64 * 2)()
    _capi.lib().lr_progress_store(ctypes.addressof(box), 2**40 + 3, 2**41 + 5)
    assert list(box) == [2**40 + 3, 2**41 + 5]


def test_light_side_through_python():
    """render.light reaches the library from Python: the night lights go
    to the light side by default (all 24 of scenes/night.json) and stay
    with the camera when it is off; the light side's disc energy is the
    camera's within the camera's noise at this budget."""
    night = lensray.load(SCENES / "night.json")
    small = {"width": 160, "height": 100, "spp": 64}
    lit, s_on = night.render(render=small, stats=True)
    cam, s_off = night.render(render={**small, "light": False, "spp": 1024,
                                      "plan": False, "adaptive": False},
                              stats=True)
    assert s_on["light_lights"] == 24 and s_on["light_landed"] > 0
    assert s_off["light_lights"] == 0 and s_off["light_paths"] == 0
    assert abs(lit.mean() / cam.mean() - 1.0) < 0.05


def test_progress_callable_counts_pixels(spheres):
    # A callable progress(done, total) (what the Blender add-on passes)
    # instead of a bar: called from this thread, rising to the total.
    import threading
    seen = []
    me = threading.get_ident()

    def progress(done, total):
        assert threading.get_ident() == me
        seen.append((done, total))

    render = {"width": 160, "height": 90, "spp": 512, "adaptive": False,
              "tile_size": 8, "threads": 1}
    spheres.render(camera=LENS, render=render, progress=progress)
    assert seen and all(t == 160 * 90 for _, t in seen)
    dones = [d for d, _ in seen]
    assert dones == sorted(dones) and dones[-1] == 160 * 90


def plan_pixels(cells: np.ndarray, w: int, h: int, bit: int) -> int:
    """Pixels of a w x h frame whose block has the bit set."""
    b = lensray.PLAN_BLOCK
    full = np.repeat(np.repeat(cells & bit, b, axis=0), b, axis=1)[:h, :w]
    return int(np.count_nonzero(full))


def test_plan_is_the_render_s_own(spheres):
    # The plan Scene.plan gives is the one the render worked from: its
    # lens blocks' pixels are the render's lens_pixels, and the thin lens
    # focused at 16.5 leaves some blocks unsampled.
    render = {"width": 200, "height": 120, "spp": 4}
    cells = spheres.plan(camera=LENS, render=render)
    assert cells.dtype == np.uint8 and cells.shape == (8, 13)
    _, stats = spheres.render(camera=LENS, render=render, stats=True)
    lens = plan_pixels(cells, 200, 120, lensray.PLAN_LENS)
    assert lens == stats["lens_pixels"] and 0 < lens < 200 * 120
    off = spheres.plan(camera=LENS, render={**render, "plan": False})
    assert np.all(off & lensray.PLAN_LENS)
    with pytest.raises(lensray.SceneError) as e:
        spheres.plan(camera={"fov": -1})
    assert e.value.path == "camera.fov"
