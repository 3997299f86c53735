"""A client for lensrayd, the HTTP render daemon (docs/api.md)."""

from __future__ import annotations

import json
import os
import tempfile
import time
import http.client
import urllib.parse
from typing import Any, Mapping, Optional, Union

import numpy as np

from . import _exr
from ._core import Image, _overrides_dict, _to_json
from ._errors import CancelledError, LensrayError, SceneError

SceneRef = Union[str, Mapping[str, Any]]

# Error codes of the daemon that are about the job's input.
_INPUT_CODES = {"invalid_value", "forbidden_path", "scene_not_found",
                "malformed_json", "too_deep", "image_too_large",
                "too_many_samples", "too_large"}
_CANCEL_CODES = {"cancelled", "job_cancelled"}


def decode_exr(data: bytes) -> tuple[np.ndarray, Optional[np.ndarray]]:
    """(rgb, z) float32 arrays from the bytes of an EXR file; z is None
    when the file has no Z channel.  Read with the ``OpenEXR`` package
    when it is installed; otherwise with lensray's own reader (_exr.py),
    which reads what lensrayd writes (scanlines, no, ZIPS or ZIP
    compression) and raises ValueError for anything else."""
    try:
        import OpenEXR
    except ImportError:
        ch = _exr.read(data)
        rgb = np.stack([ch[c] for c in ("R", "G", "B")], axis=2)
        return np.ascontiguousarray(rgb), ch.get("Z")
    # OpenEXR reads files, not bytes.
    fd, path = tempfile.mkstemp(suffix=".exr")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        with OpenEXR.File(path, separate_channels=True) as exr:
            ch = exr.channels()
            rgb = np.stack([np.asarray(ch[c].pixels, dtype=np.float32)
                            for c in ("R", "G", "B")], axis=2)
            z = (np.asarray(ch["Z"].pixels, dtype=np.float32)
                 if "Z" in ch else None)
    finally:
        os.unlink(path)
    return np.ascontiguousarray(rgb), z


def _error_from(status: int, reason: str, body: bytes) -> LensrayError:
    """The exception for an error answer ({"error": {code, message, path}})."""
    code, message, path = "", "", ""
    try:
        doc = json.loads(body)["error"]
        code = doc.get("code", "")
        message = doc.get("message", "")
        path = doc.get("path", "") or ""
    except (ValueError, KeyError, TypeError):
        message = body.decode("utf-8", "replace").strip()
    message = message or f"HTTP {status} {reason}"
    return _error(code, message, path, status)


def _error(code: str, message: str, path: str,
           http_status: Optional[int] = None) -> LensrayError:
    if code in _CANCEL_CODES:
        return CancelledError(message, path, code, http_status)
    if code in _INPUT_CODES:
        return SceneError(message, path, code, http_status)
    return LensrayError(message, path, code, http_status)


class Client:
    """A lensrayd daemon, e.g. ``Client("http://localhost:8080")``.

    Args:
        url: the daemon's base URL.
        token: the bearer token, when the daemon runs with --token-file.
        timeout: seconds to wait for any one answer; None (the default)
            waits as long as a render takes.

    Renders come back as the same float32 arrays as :meth:`Scene.render`
    (the daemon sends float EXR, decoded with the ``OpenEXR`` package).
    """

    def __init__(self, url: str, token: Optional[str] = None,
                 timeout: Optional[float] = None) -> None:
        self.url = url.rstrip("/")
        self.token = token
        self.timeout = timeout
        parts = urllib.parse.urlsplit(self.url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"not an http:// or https:// URL: {url!r}")
        self._conn_cls = (http.client.HTTPSConnection if parts.scheme == "https"
                          else http.client.HTTPConnection)
        self._netloc = parts.netloc
        self._base = parts.path

    def __repr__(self) -> str:
        return f"<lensray.Client {self.url}>"

    def _request(self, method: str, path: str, body: Any = None,
                 raw: Optional[bytes] = None) -> tuple[bytes, Any]:
        data = raw
        headers = {"Connection": "close"}
        if raw is not None:
            headers["Content-Type"] = "application/octet-stream"
        if body is not None:
            data = _to_json(body)
            headers["Content-Type"] = "application/json"
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        # http.client rather than urllib, to close the connection the moment
        # the call is interrupted (Ctrl-C): the daemon cancels a synchronous
        # render whose client has gone.
        conn = self._conn_cls(self._netloc, timeout=self.timeout)
        try:
            conn.request(method, self._base + path, body=data, headers=headers)
            resp = conn.getresponse()
            payload = resp.read()
            if resp.status >= 400:
                raise _error_from(resp.status, resp.reason, payload)
            return payload, resp.headers
        finally:
            conn.close()

    def _json(self, method: str, path: str, body: Any = None) -> Any:
        return json.loads(self._request(method, path, body)[0])

    @staticmethod
    def _job(scene: SceneRef, camera: Optional[Mapping[str, Any]],
             render: Optional[Mapping[str, Any]], depth: bool) -> dict[str, Any]:
        if not isinstance(scene, (str, Mapping)):
            raise TypeError("scene must be the name of a scene of the daemon "
                            f"or a scene as a dict, got {type(scene).__name__}")
        job: dict[str, Any] = {"scene": scene if isinstance(scene, str) else dict(scene)}
        if camera is not None and _overrides_dict(camera, "camera"):
            job["camera"] = dict(camera)
        if render is not None and _overrides_dict(render, "render"):
            job["render"] = dict(render)
        job["output"] = {"format": "exr", "depth": bool(depth)}
        return job

    def health(self) -> dict[str, Any]:
        """``GET /healthz``: status, version, workers, running, queue_depth."""
        return self._json("GET", "/healthz")

    def scenes(self) -> list[dict[str, Any]]:
        """``GET /v1/scenes``: the daemon's scenes with their cameras."""
        return self._json("GET", "/v1/scenes")["scenes"]

    def upload(self, path: Union[str, os.PathLike]) -> str:
        """Stores a file (mesh, texture, lens, environment map) on the
        daemon as an asset (``PUT /v1/assets/{sha256}``), unless it has it
        already, and returns the name a scene gives it: ``"sha256:HEX"``.

        Raises:
            LensrayError: the daemon has no asset store (``.status``
                ``"no_asset_store"``: it runs without --assets) or refused
                the file.
            OSError: the file could not be read.
        """
        import hashlib
        with open(path, "rb") as f:
            data = f.read()
        digest = hashlib.sha256(data).hexdigest()
        try:
            self._request("GET", f"/v1/assets/{digest}")
        except LensrayError as e:
            if e.status != "asset_not_found":
                raise
            self._request("PUT", f"/v1/assets/{digest}", raw=data)
        return "sha256:" + digest

    def render(self, scene: SceneRef, camera: Optional[Mapping[str, Any]] = None,
               render: Optional[Mapping[str, Any]] = None,
               depth: bool = False) -> Any:
        """Renders on the daemon and waits for the image.

        Args:
            scene: the name of one of the daemon's scenes (``"spheres"``)
                or a whole scene as a dict (its meshes must be in the
                daemon's scenes directory).
            camera, render: overrides, as for :meth:`Scene.render`.
            depth: also return the Z channel.

        Returns:
            an :class:`Image` (H, W, 3) float32, bit-identical to
            ``lensray.load(...).render(camera, render)`` for the same scene;
            ``(rgb, z)`` with ``depth=True``.

        Raises:
            SceneError: the daemon refused the job's input (422, 404 for an
                unknown scene, 413 for a limit); ``.path`` names the field
                in the job, e.g. ``"camera.fov"`` or
                ``"scene.objects[0].radius"``.
            CancelledError: another client cancelled the render.
            LensrayError: any other error answer; ``.status`` is its code.

        Ctrl-C closes the connection, which makes the daemon cancel the
        render.
        """
        data, _ = self._request("POST", "/v1/render",
                                self._job(scene, camera, render, depth))
        rgb, z = decode_exr(data)
        rgb = rgb.view(Image)
        return (rgb, z) if depth else rgb

    def submit(self, scene: SceneRef, camera: Optional[Mapping[str, Any]] = None,
               render: Optional[Mapping[str, Any]] = None,
               depth: bool = False) -> "Job":
        """Queues a job (``POST /v1/jobs``) and returns it at once.

        The arguments are those of :meth:`render`.  Errors in the job's
        input are raised here, as by :meth:`render`.
        """
        doc = self._json("POST", "/v1/jobs", self._job(scene, camera, render, depth))
        return Job(self, doc["id"], depth)

    def job(self, job_id: str, depth: bool = False) -> "Job":
        """A job already on the daemon, by its id."""
        return Job(self, job_id, depth)


class Job:
    """A job queued on a daemon by :meth:`Client.submit`."""

    def __init__(self, client: Client, job_id: str, depth: bool = False) -> None:
        self.client = client
        self.id = job_id
        self._depth = depth

    def __repr__(self) -> str:
        return f"<lensray.Job {self.id} on {self.client.url}>"

    def info(self) -> dict[str, Any]:
        """The job's status document (``GET /v1/jobs/{id}``)."""
        return self.client._json("GET", f"/v1/jobs/{self.id}")

    def plan(self) -> np.ndarray:
        """The job's effect plan (``GET /v1/jobs/{id}/plan``), as
        :meth:`Scene.plan` gives it: uint8 (rows, columns), one cell per
        16 x 16 block, bits ``PLAN_LENS`` and ``PLAN_CHROMA``."""
        doc = self.client._json("GET", f"/v1/jobs/{self.id}/plan")
        cells = [[int(c) for c in row] for row in doc["cells"]]
        return np.array(cells, dtype=np.uint8).reshape(doc["rows"], doc["columns"])

    @property
    def status(self) -> str:
        """``"queued"``, ``"running"``, ``"done"``, ``"failed"`` or
        ``"cancelled"``, asked of the daemon now."""
        return self.info()["status"]

    @property
    def progress(self) -> float:
        """The fraction of the image's pixels finished, 0 to 1."""
        return float(self.info()["progress"])

    def wait(self, timeout: Optional[float] = None, poll: float = 0.1,
             progress: Optional[bool] = False) -> dict[str, Any]:
        """Waits for the job to finish and returns its status document.

        Args:
            timeout: seconds to wait at most; None waits for ever.
            poll: seconds between status requests.
            progress: show a tqdm bar (None: when tqdm is installed).

        Raises:
            TimeoutError: the job had not finished after ``timeout``.
        """
        from ._core import _progress_bar
        bar_cls = _progress_bar(progress)
        bar = bar_cls(total=1.0, leave=False, desc=f"job {self.id[:8]}") if bar_cls else None
        start = time.monotonic()
        try:
            while True:
                doc = self.info()
                if bar is not None:
                    bar.n = float(doc.get("progress", 0))
                    bar.refresh()
                if doc["status"] in ("done", "failed", "cancelled"):
                    return doc
                if timeout is not None and time.monotonic() - start > timeout:
                    raise TimeoutError(f"job {self.id} still {doc['status']} "
                                       f"after {timeout} s")
                time.sleep(poll)
        finally:
            if bar is not None:
                bar.close()

    def result(self, timeout: Optional[float] = None) -> Any:
        """Waits for the job and returns its image as :meth:`Client.render`
        does.

        Raises:
            CancelledError: the job was cancelled.
            SceneError, LensrayError: the job failed; the daemon's code,
                message and path are in the exception.
            TimeoutError: the job had not finished after ``timeout``.
        """
        doc = self.wait(timeout)
        if doc["status"] != "done":
            e = doc.get("error") or {}
            raise _error(e.get("code", doc["status"]),
                         e.get("message", f"job {self.id} {doc['status']}"),
                         e.get("path", "") or "")
        data, _ = self.client._request("GET", f"/v1/jobs/{self.id}/image")
        rgb, z = decode_exr(data)
        rgb = rgb.view(Image)
        return (rgb, z) if self._depth else rgb

    def cancel(self) -> dict[str, Any]:
        """Cancels the job (``DELETE /v1/jobs/{id}``), or drops it when it
        has finished; returns its last status document."""
        return self.client._json("DELETE", f"/v1/jobs/{self.id}")


def _submit_when_room(client: Client, scene: SceneRef,
                      camera: Optional[Mapping[str, Any]],
                      render: Mapping[str, Any], unfinished: list[Job]) -> Job:
    """Client.submit, sent again while the daemon's queue is full (429).

    A strip more than the daemon's workers and queue hold is not an error
    of the frame: it waits until one of ours on that daemon has finished
    (or a second, when none is: the queue is someone else's), as the
    answer's Retry-After asks."""
    while True:
        try:
            return client.submit(scene, camera, render)
        except LensrayError as e:
            if e.http_status != 429:
                raise
        mine = [j for j in unfinished if j.client is client]
        if mine:
            mine[0].wait()
            unfinished.remove(mine[0])
        else:
            time.sleep(1.0)


def render_split(clients: "Union[Client, list[Client]]", scene: SceneRef,
                 camera: Optional[Mapping[str, Any]] = None,
                 render: Optional[Mapping[str, Any]] = None,
                 parts: Optional[int] = None) -> Any:
    """Renders one frame as horizontal strips on several daemons at once.

    Each strip is a ``render.region`` crop queued as a job, the strips
    dealt round-robin to ``clients``; since crops are bit-identical to the
    same pixels of the full frame (docs/api.md, section 8), the stitched
    result equals :meth:`Client.render` of the whole frame.

    Args:
        clients: one :class:`Client` or a list of them (the same daemon may
            appear more than once).
        scene, camera, render: as for :meth:`Client.render`; ``render``
            may not have a ``region`` of its own.
        parts: the number of strips (a whole number >= 1, at most the
            height); by default one per client.

    Returns:
        an :class:`Image` (H, W, 3) float32.

    Raises:
        SceneError: a width or height that is not a whole number from 1
            to 65536 (``.path`` ``render.width``), and the daemons' errors.
        ValueError: ``parts`` below 1, or a ``render.region`` given.
    """
    if isinstance(clients, Client):
        clients = [clients]
    if not clients:
        raise ValueError("render_split needs at least one client")
    render = dict(render or {})
    if "region" in render:
        raise ValueError("render_split makes the regions: leave render.region out")
    # The frame's size: the overrides, else the scene's own.
    if isinstance(scene, str):
        own = next((s.get("render", {}) for s in clients[0].scenes()
                    if s.get("name") == scene), None)
        if own is None:
            raise SceneError(f"scene '{scene}' not found on {clients[0].url}",
                             "scene", "scene_not_found")
    else:
        own = dict(scene).get("render", {})
    if parts is not None and not (isinstance(parts, int) and parts >= 1):
        raise ValueError(f"parts must be a whole number >= 1, got {parts!r}")
    # The frame's size, checked here since the strips' rows come from it:
    # 64.5 or NaN must fail as the daemon would fail them, not be cut to
    # a whole number.
    size = {}
    for key, default in (("width", 640), ("height", 480)):
        v = render.get(key, own.get(key, default))
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise SceneError(f"render.{key} must be a number, got {v!r}",
                             f"render.{key}", "invalid_value")
        if not (np.isfinite(v) and float(v) == int(v) and 1 <= v <= 65536):
            raise SceneError(f"render.{key} must be a whole number from 1 to "
                             f"65536, got {v!r}", f"render.{key}", "invalid_value")
        size[key] = int(v)
    width, height = size["width"], size["height"]
    n = max(1, min(parts or len(clients), height))
    rows = [height * i // n for i in range(n + 1)]
    jobs: list[Job] = []
    unfinished: list[Job] = []  # of jobs, those not yet seen finished
    try:
        for i in range(n):
            crop = dict(render, width=width, height=height,
                        region=[0, rows[i], width, rows[i + 1]])
            client = clients[i % len(clients)]
            job = _submit_when_room(client, scene, camera, crop, unfinished)
            jobs.append(job)
            unfinished.append(job)
        strips = [job.result() for job in jobs]
    except BaseException:
        for job in jobs:
            try:
                job.cancel()
            except Exception:
                pass
        raise
    return np.concatenate([np.asarray(s) for s in strips], axis=0).view(Image)
