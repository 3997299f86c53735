"""lensray.Client against a real lensrayd started by a fixture."""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest

import lensray

from conftest import LENS, SCENES, SMALL, Daemon, same_bits


def test_render_by_name_equals_in_process(daemon, spheres):
    c = lensray.Client(daemon.url)
    rgb, z = c.render("spheres", camera=LENS, render=SMALL, depth=True)
    ref, ref_z = spheres.render(camera=LENS, render=SMALL, depth=True)
    assert rgb.dtype == np.float32 and rgb.shape == ref.shape
    assert same_bits(rgb, ref) and same_bits(z, ref_z)
    assert isinstance(rgb, lensray.Image)
    assert not same_bits(rgb, c.render("spheres", render=SMALL))


def test_render_inline_scene_equals_in_process(daemon):
    doc = json.loads((SCENES / "spheres.json").read_text())
    doc["objects"][1]["radius"] = 1.5
    rgb = lensray.Client(daemon.url).render(doc, camera=LENS, render=SMALL)
    with lensray.load(doc, base_dir=SCENES) as s:
        assert same_bits(rgb, s.render(camera=LENS, render=SMALL))


def test_errors_name_the_field(daemon):
    c = lensray.Client(daemon.url)
    with pytest.raises(lensray.SceneError) as e:
        c.render("spheres", camera={"model": "thinlens", "aperture_radius": -0.5})
    assert e.value.path == "camera.aperture_radius"
    assert "must be >= 0" in e.value.message
    assert e.value.status == "invalid_value" and e.value.http_status == 422
    with pytest.raises(lensray.SceneError) as e:
        c.render("no_such_scene")
    assert e.value.path == "scene" and e.value.http_status == 404
    doc = json.loads((SCENES / "spheres.json").read_text())
    doc["objects"][0]["radius"] = -1
    with pytest.raises(lensray.SceneError) as e:
        c.submit(doc)
    assert e.value.path.startswith("scene.objects[0]")


def test_non_finite_numbers_name_the_field(daemon):
    c = lensray.Client(daemon.url)
    with pytest.raises(lensray.SceneError) as e:
        c.render("spheres", camera={"fov": float("nan")})
    assert e.value.path == "camera.fov" and "finite" in e.value.message
    doc = json.loads((SCENES / "spheres.json").read_text())
    doc["objects"][0]["radius"] = float("inf")
    with pytest.raises(lensray.SceneError) as e:
        c.submit(doc)
    assert e.value.path == "scene.objects[0].radius"
    with pytest.raises(TypeError, match="scene must be"):
        c.render(5)


def test_submit_wait_result(daemon, spheres):
    c = lensray.Client(daemon.url)
    job = c.submit("spheres", camera=LENS, render=SMALL)
    assert len(job.id) == 32
    doc = job.wait(timeout=60)
    assert doc["status"] == "done" and job.status == "done"
    assert job.progress == 1.0
    assert same_bits(job.result(), spheres.render(camera=LENS, render=SMALL))
    # The same job, found again by id, with its Z channel.
    job2 = c.submit("spheres", render=SMALL, depth=True)
    rgb, z = c.job(job2.id, depth=True).result(timeout=60)
    ref, ref_z = spheres.render(render=SMALL, depth=True)
    assert same_bits(rgb, ref) and same_bits(z, ref_z)


def test_cancel_a_running_job(daemon):
    c = lensray.Client(daemon.url)
    job = c.submit("spheres", camera=LENS,
                   render={"width": 320, "height": 180, "spp": 4096,
                           "adaptive": False, "plan": False, "tile_size": 8})
    doc = job.cancel()
    assert doc["status"] in ("cancelled", "running")
    assert job.wait(timeout=30)["status"] == "cancelled"
    with pytest.raises(lensray.CancelledError):
        job.result()


def test_token(token_daemon, spheres):
    d, token = token_daemon
    with pytest.raises(lensray.LensrayError) as e:
        lensray.Client(d.url).render("spheres", render=SMALL)
    assert e.value.http_status == 401 and e.value.status == "unauthorized"
    rgb = lensray.Client(d.url, token=token).render("spheres", render=SMALL)
    assert same_bits(rgb, spheres.render(render=SMALL))
    assert lensray.Client(d.url, token=token).health()["status"] == "ok"


def test_render_split_stitches_the_full_frame(daemon, spheres):
    c = lensray.Client(daemon.url)
    render = {**SMALL, "height": 55}
    rgb = lensray.render_split([c, c], "spheres", camera=LENS, render=render, parts=3)
    assert same_bits(rgb, spheres.render(camera=LENS, render=render))
    # The scene's own size when the overrides leave it out.
    doc = json.loads((SCENES / "spheres.json").read_text())
    doc["render"].update(width=40, height=22, spp=2)
    strips = lensray.render_split(c, doc, parts=2)
    with lensray.load(doc, base_dir=SCENES) as s:
        assert same_bits(strips, s.render())
    with pytest.raises(ValueError):
        lensray.render_split(c, "spheres", render={"region": [0, 0, 4, 4]})
    # A size that is not a whole number is the daemon's error, not cut
    # down to one (64.5 rendered 64 columns; nan raised int()'s error).
    for bad in (64.5, float("nan"), "64", True):
        with pytest.raises(lensray.SceneError) as e:
            lensray.render_split(c, "spheres", render={**SMALL, "width": bad})
        assert e.value.path == "render.width"
    for bad in (0, -3):
        with pytest.raises(ValueError, match="parts"):
            lensray.render_split(c, "spheres", render=SMALL, parts=bad)


def test_render_split_waits_for_a_full_queue(spheres):
    """More strips than the daemon takes at once (one worker, no queue):
    each one the daemon refuses with 429 is sent again once one of ours
    there has finished.  Every strip was queued at once, and the second
    failed the whole frame with 'the queue is full'."""
    d = Daemon("--queue", "0")
    try:
        c = lensray.Client(d.url)
        rgb = lensray.render_split(c, "spheres", camera=LENS, render=SMALL, parts=5)
        assert same_bits(rgb, spheres.render(camera=LENS, render=SMALL))
        assert any(" 429 " in line for line in d.log), "no strip was ever refused"
    finally:
        d.stop()


def cancelled_jobs(client) -> int:
    text = client._request("GET", "/metrics")[0].decode()
    for line in text.splitlines():
        if line.startswith('lensrayd_jobs_finished_total{state="cancelled"}'):
            return int(float(line.split()[-1]))
    return 0


def test_ctrl_c_during_a_synchronous_render_cancels_it_on_the_daemon(daemon):
    import signal
    import threading
    import time
    c = lensray.Client(daemon.url)
    before = cancelled_jobs(c)
    main = threading.main_thread().ident
    threading.Timer(0.5, signal.pthread_kill, (main, signal.SIGINT)).start()
    with pytest.raises(KeyboardInterrupt):
        c.render("spheres", camera=LENS,
                 render={"width": 320, "height": 180, "spp": 4096,
                         "adaptive": False, "plan": False, "tile_size": 8})
    # The connection closed at once, so the daemon cancels the render
    # (within a tile) and its worker is free again.
    deadline = time.monotonic() + 20
    while cancelled_jobs(c) == before and time.monotonic() < deadline:
        time.sleep(0.1)
    assert cancelled_jobs(c) == before + 1
    assert c.health()["running"] == 0


def test_job_plan_equals_scene_plan(daemon, spheres):
    job = lensray.Client(daemon.url).submit("spheres", camera=LENS, render=SMALL)
    job.wait(timeout=60)
    plan = job.plan()
    assert plan.dtype == np.uint8 and plan.shape == (4, 6)
    assert np.array_equal(plan, spheres.plan(camera=LENS, render=SMALL))
    assert plan.any() and not plan.all()


def test_upload_assets_and_render_them(tmp_path, daemon):
    # A scene whose mesh is only on this machine: uploaded as an asset,
    # named "sha256:...", rendered on the daemon the same as in process.
    obj = tmp_path / "quad.obj"
    obj.write_text("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 4 3 2\n")
    scene = {"camera": {"position": [0, 2, 3], "look_at": [0, 0, 0], "fov": 40},
             "render": {"width": 32, "height": 24, "spp": 2},
             "lights": [{"type": "point", "position": [0, 3, 1], "intensity": 10}],
             "objects": [{"type": "mesh", "file": str(obj)}]}
    store = tmp_path / "assets"
    store.mkdir()
    d = Daemon("--assets", str(store))
    try:
        c = lensray.Client(d.url)
        name = c.upload(obj)
        assert name == "sha256:" + __import__("hashlib").sha256(obj.read_bytes()).hexdigest()
        assert (store / name[7:]).exists() and c.upload(obj) == name
        remote = {**scene, "objects": [{"type": "mesh", "file": name}]}
        with lensray.load(scene) as s:
            ref = s.render()
        got = c.render(remote)
        assert ref.mean() > 0.01 and same_bits(got, ref)
    finally:
        d.stop()
    with pytest.raises(lensray.LensrayError) as e:
        lensray.Client(daemon.url).upload(obj)
    assert e.value.status == "no_asset_store"


def test_render_split_fetches_strips_before_the_daemon_drops_them(spheres):
    """A daemon that keeps only 4 finished jobs and a frame of 12 strips:
    every strip was queued before any image was fetched, so the first
    ones were dropped (job_not_found) and the frame failed."""
    d = Daemon("--max-finished-jobs", "4")
    try:
        c = lensray.Client(d.url)
        ref = spheres.render(camera=LENS, render=SMALL)
        rgb = lensray.render_split(c, "spheres", camera=LENS, render=SMALL, parts=12)
        assert same_bits(rgb, ref)
        # Three frames at once, sharing the daemon's 4 finished jobs.
        import threading
        out: list = []

        def frame() -> None:
            try:
                out.append(lensray.render_split(lensray.Client(d.url), "spheres",
                                                camera=LENS, render=SMALL, parts=9))
            except Exception as e:  # noqa: BLE001 - reported below
                out.append(e)
        threads = [threading.Thread(target=frame) for _ in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(120)
        assert len(out) == 3 and all(same_bits(x, ref) for x in out), out
    finally:
        d.stop()


def test_render_split_queues_a_dropped_strip_again(daemon, spheres):
    """A strip whose job is gone before its image was fetched (dropped by
    the daemon) is queued again rather than failing the frame."""
    class Dropping(lensray.Client):
        dropped: list = []

        def _request(self, method, path, body=None, raw=None, **kw):
            if method == "GET" and path.endswith("/image") and len(self.dropped) < 2:
                job = path.split("/")[3]
                lensray.Job(self, job).wait(timeout=60)
                super()._request("DELETE", f"/v1/jobs/{job}")
                self.dropped.append(job)
            return super()._request(method, path, body, raw, **kw)
    c = Dropping(daemon.url)
    rgb = lensray.render_split(c, "spheres", camera=LENS, render=SMALL, parts=3)
    assert len(c.dropped) == 2
    assert same_bits(rgb, spheres.render(camera=LENS, render=SMALL))


def test_wait_times_out_when_the_daemon_does_not_answer():
    """A daemon that accepts connections but never answers (stopped,
    hung host): wait(timeout=) and result(timeout=) raise TimeoutError at
    the deadline.  Each status request used the client's socket timeout
    (None), so they waited for ever."""
    import socket
    import threading
    import time
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(16)
    try:
        job = lensray.Client("http://127.0.0.1:%d" % srv.getsockname()[1]).job("0" * 32)
        for call in (job.wait, job.result):
            got: dict = {}

            def run() -> None:
                t0 = time.monotonic()
                try:
                    call(timeout=0.5)
                except BaseException as e:  # noqa: BLE001 - checked below
                    got["e"] = e
                got["s"] = time.monotonic() - t0
            t = threading.Thread(target=run, daemon=True)
            t.start()
            t.join(10)
            assert not t.is_alive(), f"{call.__name__}(timeout=0.5) still waiting after 10 s"
            assert isinstance(got["e"], TimeoutError) and got["s"] < 3, got
            assert job.id in str(got["e"])
    finally:
        srv.close()


def test_a_body_over_the_limit_is_the_daemons_413(tmp_path):
    """The daemon refuses a body over --max-body (and an asset over
    --max-asset-bytes) from its Content-Length and closes the connection:
    the client, still sending, raised BrokenPipeError or
    ConnectionResetError rather than the daemon's answer."""
    store = tmp_path / "assets"
    store.mkdir()
    d = Daemon("--max-body", "64k", "--assets", str(store), "--max-asset-bytes", "64k")
    try:
        c = lensray.Client(d.url)
        scene = {"objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1}],
                 "description": "x" * 16_000_000}
        for _ in range(5):
            with pytest.raises(lensray.SceneError) as e:
                c.render(scene)
            assert e.value.http_status == 413 and e.value.status == "body_too_large"
            assert "--max-body" in e.value.message
        big = tmp_path / "big.bin"
        big.write_bytes(os.urandom(16_000_000))
        for _ in range(3):
            with pytest.raises(lensray.LensrayError) as e:
                c.upload(big)
            assert e.value.http_status == 413 and e.value.status == "body_too_large"
            assert "--max-asset-bytes" in e.value.message
        # Under the limits all is as before.
        small = tmp_path / "small.bin"
        small.write_bytes(b"v 0 0 0\n")
        assert c.upload(small).startswith("sha256:")
        assert c.render({**scene, "description": "x" * 1000},
                        render={"width": 8, "height": 8, "spp": 1}).shape == (8, 8, 3)
        assert c.health()["status"] == "ok"
    finally:
        d.stop()
    # A server that closes during the upload without answering: the
    # connection error says the body may be over the limit.
    import socket
    import threading
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)

    def close_early() -> None:
        conn, _ = srv.accept()
        conn.recv(1000)
        conn.close()
    t = threading.Thread(target=close_early, daemon=True)
    t.start()
    try:
        with pytest.raises(ConnectionError, match="--max-body"):
            lensray.Client("http://127.0.0.1:%d" % srv.getsockname()[1]).render(scene)
    finally:
        t.join(10)
        srv.close()


def test_every_input_refusal_is_a_scene_error(tmp_path):
    """Each 413 (a limit) and 422 (a value) of docs/api.md's error table is
    a SceneError, as Client.render's docstring says: asset_not_found (422)
    and body_too_large (413) were plain LensrayErrors."""
    from lensray._client import _error_from
    from conftest import REPO
    table = (REPO / "docs" / "api.md").read_text()
    rows = re.findall(r"^\| (413|422) \| `(\w+)`", table, re.M)
    assert {c for _, c in rows} >= {"body_too_large", "asset_not_found",
                                    "invalid_value", "too_many_samples"}
    for status, code in rows:
        body = json.dumps({"error": {"code": code, "message": "m", "path": "p"}})
        e = _error_from(int(status), "", body.encode())
        assert isinstance(e, lensray.SceneError), code
        assert e.status == code and e.http_status == int(status) and e.path == "p"
    # The 404 of GET /v1/assets/{sha256} is no input error.
    e = _error_from(404, "", b'{"error": {"code": "asset_not_found", "message": "m"}}')
    assert not isinstance(e, lensray.SceneError)
    # The daemon's own answer for a scene naming an asset it does not have.
    store = tmp_path / "assets"
    store.mkdir()
    d = Daemon("--assets", str(store))
    try:
        c = lensray.Client(d.url)
        with pytest.raises(lensray.SceneError) as e:
            c.render({"objects": [{"type": "mesh", "file": "sha256:" + "1" * 64}]})
        assert e.value.http_status == 422 and e.value.status == "asset_not_found"
        assert e.value.path == "scene.objects[0].file"
    finally:
        d.stop()
