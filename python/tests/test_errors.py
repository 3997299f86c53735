"""Errors carry the library's JSON path and sentence; cancellation."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest

import lensray

from conftest import BUILD, LENS, SCENES, SMALL


def bad_scene(tmp_path, edit) -> str:
    doc = json.loads((SCENES / "spheres.json").read_text())
    edit(doc)
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(doc))
    return str(p)


def test_bad_scene_file_names_the_field(tmp_path):
    def edit(doc):
        doc["objects"][2]["radius"] = -2
    with pytest.raises(lensray.SceneError) as e:
        lensray.load(bad_scene(tmp_path, edit))
    assert e.value.path == "objects[2].radius"
    assert "objects[2].radius" in e.value.message and "-2" in e.value.message
    assert str(e.value) == e.value.message
    assert e.value.status == "invalid"
    assert isinstance(e.value, ValueError)


def test_bad_scene_dict_names_the_field():
    doc = json.loads((SCENES / "spheres.json").read_text())
    doc["camera"]["fov"] = 200
    with pytest.raises(lensray.SceneError) as e:
        lensray.load(doc, base_dir=SCENES)
    assert e.value.path == "camera.fov"


def test_bad_override_at_load_names_the_field():
    with pytest.raises(lensray.SceneError) as e:
        lensray.load(SCENES / "spheres.json", {"render.spp": 0})
    assert e.value.path == "render.spp"


def test_bad_render_overrides_name_the_field(spheres):
    with pytest.raises(lensray.SceneError) as e:
        spheres.render(camera={"model": "thinlens", "aperture_radius": -0.5})
    assert e.value.path == "camera.aperture_radius"
    assert "camera.aperture_radius must be >= 0" in e.value.message
    with pytest.raises(lensray.SceneError) as e:
        spheres.render(render={"spp": -3})
    assert e.value.path == "render.spp"
    with pytest.raises(lensray.SceneError) as e:
        spheres.render(camera={"model": "fisheye"})
    assert e.value.path == "camera.model"
    # The library's sentence reaches the exception: a misspelt key is
    # named, with the keys a camera takes.
    with pytest.raises(lensray.SceneError) as e:
        spheres.render(camera={"model": "thinlens", "aperture_radiuss": 0.2})
    assert e.value.path == "camera.aperture_radiuss"
    assert 'unknown key "aperture_radiuss"' in e.value.message
    assert "aperture_radius," in e.value.message
    with pytest.raises(lensray.SceneError) as e:
        spheres.render(render={"no_such_key": 1})
    assert e.value.path.startswith("render")


def test_non_finite_numbers_name_the_field(spheres):
    # JSON has no NaN or infinity: a Python float that is one is refused
    # before it becomes JSON, with the field's path, wherever it is given.
    import numpy as np
    cases = [(lambda: spheres.render(camera={"fov": float("nan")}), "camera.fov"),
             (lambda: spheres.render(camera={"position": [0, np.inf, 1]}),
              "camera.position[1]"),
             (lambda: spheres.render(render={"adaptive": {"threshold": -np.inf}}),
              "render.adaptive.threshold"),
             (lambda: lensray.load({"objects": [{"type": "sphere", "center": [0, 0, -3],
                                                 "radius": float("inf")}]}),
              "objects[0].radius"),
             (lambda: lensray.load(SCENES / "spheres.json", {"camera.fov": np.float32("nan")}),
              "camera.fov")]
    for call, path in cases:
        with pytest.raises(lensray.SceneError) as e:
            call()
        assert e.value.path == path
        assert e.value.message.startswith(path + " must be a finite number, got ")


def test_overrides_that_are_not_dicts_are_type_errors(spheres):
    for bad in ([1, 2], "thinlens", 5):
        with pytest.raises(TypeError, match="camera must be a dict"):
            spheres.render(camera=bad)
        with pytest.raises(TypeError, match="render must be a dict"):
            spheres.render(render=bad)


def test_cancel_that_is_not_an_event_is_a_type_error(spheres):
    # Refused before rendering, whatever the render's length (the render
    # first looks at cancel after 0.1 s).
    for bad in (5, "stop", True):
        with pytest.raises(TypeError, match="cancel must be a threading.Event"):
            spheres.render(render={"width": 8, "height": 8, "spp": 1}, cancel=bad)


def test_cancel_set_before_the_render_stops_it(spheres):
    # A small render was over before the loop first looked at the event
    # (0.1 s), and an event set beforehand was ignored.
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(lensray.CancelledError):
        spheres.render(render={"width": 8, "height": 8, "spp": 1}, cancel=cancel)


def test_override_list_items_must_be_strings():
    # bytes(5) made five NUL bytes: 'override "" must look like path=value'.
    with pytest.raises(TypeError, match="each override must be a 'path=value' string, got int"):
        lensray.load(SCENES / "spheres.json", [5])


def test_glTF_warnings_reach_python(tmp_path):
    # The CLI prints them; Python had no way to see them.
    writer = SCENES.parent / "tests" / "gltf_writer.py"
    subprocess.run([sys.executable, str(writer), "camera-light",
                    str(tmp_path / "cl.gltf")], check=True)
    text = (tmp_path / "cl.gltf").read_text().replace(
        '"type": "point"', '"type": "point", "range": 5')
    (tmp_path / "range.gltf").write_text(text)
    with lensray.load(tmp_path / "range.gltf") as s:
        assert len(s.warnings) == 1 and s.warnings[0].startswith(
            "range.gltf: extensions.KHR_lights_punctual.lights[0].range is ignored")
    with lensray.load(SCENES / "spheres.json") as s:
        assert s.warnings == []


def test_missing_file_is_an_io_error(tmp_path):
    with pytest.raises(lensray.LensrayIOError) as e:
        lensray.load(tmp_path / "none.json")
    assert isinstance(e.value, OSError)
    assert "none.json" in e.value.message


def test_cancel_event_stops_the_render(spheres):
    render = {"width": 320, "height": 180, "spp": 4096, "adaptive": False,
              "plan": False, "tile_size": 8, "threads": 1}
    cancel = threading.Event()
    threading.Timer(0.3, cancel.set).start()
    with pytest.raises(lensray.CancelledError) as e:
        spheres.render(camera=LENS, render=render, cancel=cancel)
    # It stopped part-way: some tiles were done, most were not.
    assert e.value.stats is not None
    assert 0 < e.value.stats["samples"] < e.value.stats["full_samples"]
    assert e.value.status == "cancelled"
    # The scene is intact and renders again.
    assert spheres.render(camera=LENS, render=SMALL).shape == (54, 96, 3)


def test_keyboard_interrupt_in_process_cancels(spheres):
    """SIGINT to the main thread mid-render: KeyboardInterrupt comes out
    after the render's threads have stopped."""
    render = {"width": 320, "height": 180, "spp": 4096, "adaptive": False,
              "plan": False, "tile_size": 8, "threads": 1}
    main = threading.main_thread().ident
    threading.Timer(0.3, signal.pthread_kill, (main, signal.SIGINT)).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        spheres.render(camera=LENS, render=render)
    elapsed = time.monotonic() - t0
    # The whole render takes about a minute on one thread (235 M samples,
    # every one traced); it stopped within a tile of the interrupt.
    assert elapsed < 20
    assert not any(t.name == "lensray-render" for t in threading.enumerate())
    assert spheres.render(render=SMALL).shape == (54, 96, 3)


def test_ctrl_c_in_a_script_exits_cleanly():
    """A real SIGINT to a Python process that renders: it stops, the
    KeyboardInterrupt can be caught, and nothing crashes."""
    script = textwrap.dedent(f"""
        import sys, lensray
        s = lensray.load({str(SCENES / "spheres.json")!r})
        print("rendering", flush=True)
        try:
            s.render(render={{"spp": 4096, "adaptive": False, "plan": False,
                              "tile_size": 8}},
                     camera={{"model": "thinlens", "aperture_radius": 0.2}})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            s.close()
            sys.exit(0)
        print("finished", flush=True)
        sys.exit(1)
    """)
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "rendering"
    time.sleep(0.5)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0, err
    assert out.strip() == "interrupted"
