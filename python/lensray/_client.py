"""A client for lensrayd, the HTTP render daemon (docs/api.md)."""

from __future__ import annotations

import errno
import json
import os
import select
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

# Error codes of the daemon that are about the job's input (docs/api.md,
# section 5): besides these, every 413 (a limit) and 422 (a value) answer
# is one, so a code the daemon adds later is still a SceneError.
_INPUT_CODES = {"invalid_value", "forbidden_path", "scene_not_found",
                "malformed_json", "too_deep", "image_too_large",
                "too_many_samples", "too_large", "body_too_large",
                "asset_not_found", "asset_hash_mismatch",
                "idempotency_key_reused"}
_INPUT_HTTP = {413, 422}
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
    # asset_not_found is also GET /v1/assets/{sha256}'s 404 for an asset
    # the daemon does not have, which is no one's input error.
    if http_status in _INPUT_HTTP or (
            code in _INPUT_CODES
            and not (code == "asset_not_found" and http_status == 404)):
        return SceneError(message, path, code, http_status)
    return LensrayError(message, path, code, http_status)


def _send(conn: http.client.HTTPConnection, method: str, url: str,
          data: Optional[bytes], headers: dict[str, str]) -> Optional[OSError]:
    """Sends the request; returns the error that stopped the body, if any.

    The daemon refuses a body over --max-body (or an asset over
    --max-asset-bytes) from its Content-Length, answers 413 at once and
    closes the connection: a client still sending gets EPIPE or ECONNRESET
    rather than the answer.  So the body goes in pieces, stopping as soon
    as the daemon has answered (the socket is readable) or the send fails;
    the caller then reads the answer, which is usually there."""
    conn.putrequest(method, url)
    for k, v in headers.items():
        conn.putheader(k, v)
    if data is not None or method in ("POST", "PUT"):
        conn.putheader("Content-Length", str(len(data or b"")))
    try:
        conn.endheaders()
    except (BrokenPipeError, ConnectionResetError) as e:
        return e
    if not data:
        return None
    view = memoryview(data)
    sock = conn.sock
    step = 1 << 16
    for at in range(0, len(view), step):
        try:
            # An answer before the whole body is sent is a refusal.
            if select.select([sock], [], [], 0)[0]:
                return ConnectionAbortedError(
                    errno.ECONNABORTED,
                    "it answered or closed before the whole body was sent")
            sock.sendall(view[at:at + step])
        except (BrokenPipeError, ConnectionResetError) as e:
            return e
    return None


def _send_failure(e: OSError, size: int) -> OSError:
    """The send error, explained: the daemon closed the connection during
    the upload without an answer that could be read."""
    msg = (f"lensrayd closed the connection while the {size}-byte body was "
           f"being sent, with no answer ({e.strerror or e}); the body may be "
           "over the daemon's --max-body (or, for an asset, "
           "--max-asset-bytes) limit")
    return type(e)(e.errno or 0, msg)


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
                 raw: Optional[bytes] = None,
                 timeout: Any = ...) -> tuple[bytes, Any]:
        """(body, headers) of the answer; raises the error of an error
        answer.  ``timeout`` overrides the client's for this request."""
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
        conn = self._conn_cls(self._netloc,
                              timeout=self.timeout if timeout is ... else timeout)
        try:
            send_error = _send(conn, method, self._base + path, data, headers)
            try:
                resp = conn.getresponse()
                payload = resp.read()
            except (OSError, http.client.HTTPException) as e:
                if send_error is None:
                    raise
                # The daemon closed the connection during the upload and
                # its answer was lost (or it never gave one).
                raise _send_failure(send_error, len(data or b"")) from e
            if resp.status >= 400:
                raise _error_from(resp.status, resp.reason, payload)
            if send_error is not None:
                raise send_error
            return payload, resp.headers
        finally:
            conn.close()

    def _json(self, method: str, path: str, body: Any = None,
              timeout: Any = ...) -> Any:
        return json.loads(self._request(method, path, body, timeout=timeout)[0])

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
                unknown scene, 413 for a limit, e.g. ``body_too_large``
                over --max-body); ``.path`` names the field in the job,
                e.g. ``"camera.fov"`` or ``"scene.objects[0].radius"``.
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

    def _socket_timeout(self, deadline: Optional[float],
                        at_least: float = 0.1) -> Any:
        """The socket timeout of a request made before ``deadline``: the
        time left (``at_least`` when less, so that a wait with no time
        left still asks once), or the client's when shorter; ``...`` (the
        client's) without a deadline."""
        if deadline is None:
            return ...
        left = max(deadline - time.monotonic(), at_least)
        own = self.client.timeout
        return left if own is None else min(own, left)

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
            timeout: seconds to wait at most, the daemon's answers
                included (each status request may take only the time
                left); None waits for ever.
            poll: seconds between status requests.
            progress: show a tqdm bar (None: when tqdm is installed).

        Raises:
            TimeoutError: the job had not finished after ``timeout``.
        """
        doc, _ = self._wait(timeout, poll, progress)
        return doc

    def _wait(self, timeout: Optional[float], poll: float = 0.1,
              progress: Optional[bool] = False) -> tuple[dict[str, Any], Optional[float]]:
        """wait(), and its deadline (time.monotonic()) or None."""
        from ._core import _progress_bar
        bar_cls = _progress_bar(progress)
        bar = bar_cls(total=1.0, leave=False, desc=f"job {self.id[:8]}") if bar_cls else None
        deadline = None if timeout is None else time.monotonic() + timeout
        doc: dict[str, Any] = {"status": "unknown"}
        try:
            while True:
                # Each status request may take only the time left: a daemon
                # that accepts connections but does not answer (stopped,
                # hung host) must not hold the wait past its timeout.
                try:
                    doc = self.client._json("GET", f"/v1/jobs/{self.id}",
                                            timeout=self._socket_timeout(deadline))
                except TimeoutError as e:
                    if deadline is None or time.monotonic() < deadline:
                        raise  # the client's own timeout
                    raise TimeoutError(
                        f"job {self.id} still {doc['status']} after {timeout} s "
                        f"({self.client.url} did not answer in time)") from e
                if bar is not None:
                    bar.n = float(doc.get("progress", 0))
                    bar.refresh()
                if doc["status"] in ("done", "failed", "cancelled"):
                    return doc, deadline
                if deadline is not None and time.monotonic() >= deadline:
                    raise TimeoutError(f"job {self.id} still {doc['status']} "
                                       f"after {timeout} s")
                pause = poll
                if deadline is not None:
                    pause = min(poll, max(0.0, deadline - time.monotonic()))
                time.sleep(pause)
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
        doc, deadline = self._wait(timeout)
        self._raise_unless_done(doc)
        # The image, in the time left (at least a second, as the job has
        # finished in time): each read waits that long at most.
        try:
            data, _ = self.client._request(
                "GET", f"/v1/jobs/{self.id}/image",
                timeout=self._socket_timeout(deadline, at_least=1.0))
        except TimeoutError as e:
            if deadline is None:
                raise
            raise TimeoutError(f"job {self.id}'s image did not come from "
                               f"{self.client.url} within {timeout} s") from e
        rgb, z = decode_exr(data)
        rgb = rgb.view(Image)
        return (rgb, z) if self._depth else rgb

    def _raise_unless_done(self, doc: Mapping[str, Any]) -> None:
        """The error of a failed or cancelled job's status document."""
        if doc["status"] != "done":
            e = doc.get("error") or {}
            raise _error(e.get("code", doc["status"]),
                         e.get("message", f"job {self.id} {doc['status']}"),
                         e.get("path", "") or "")

    def cancel(self) -> dict[str, Any]:
        """Cancels the job (``DELETE /v1/jobs/{id}``), or drops it when it
        has finished; returns its last status document."""
        return self.client._json("DELETE", f"/v1/jobs/{self.id}")


def _window(client: Client) -> int:
    """How many of a frame's strips may be on ``client``'s daemon at once:
    twice its workers, so that a worker finds the next strip queued."""
    try:
        workers = int(client.health().get("workers", 1))
    except (LensrayError, OSError, ValueError, TypeError,
            http.client.HTTPException):
        workers = 1
    return max(2, min(2 * workers, 64))


def _strip(job: Job) -> tuple[str, Optional[np.ndarray]]:
    """("done", pixels) of a finished strip, ("running", None) while it is
    queued or running, ("gone", None) when the daemon no longer has it
    (the oldest finished jobs go first, --max-finished-jobs); raises a
    failed or cancelled strip's error."""
    try:
        data, _ = job.client._request("GET", f"/v1/jobs/{job.id}/image")
    except LensrayError as e:
        if e.status == "not_ready":
            return "running", None
        if e.status == "job_not_found":
            return "gone", None
        if e.status in ("job_failed", "job_cancelled"):
            # The job's own error (its code and class), not the image's 409.
            try:
                doc = job.info()
            except LensrayError:
                raise e from None
            job._raise_unless_done(doc)
        raise
    return "done", decode_exr(data)[0]


def render_split(clients: "Union[Client, list[Client]]", scene: SceneRef,
                 camera: Optional[Mapping[str, Any]] = None,
                 render: Optional[Mapping[str, Any]] = None,
                 parts: Optional[int] = None) -> Any:
    """Renders one frame as horizontal strips on several daemons at once.

    Each strip is a ``render.region`` crop queued as a job, the strips
    dealt round-robin to ``clients``; since crops are bit-identical to the
    same pixels of the full frame (docs/api.md, section 8), the stitched
    result equals :meth:`Client.render` of the whole frame.  A daemon has
    at most twice its workers of the strips at once; each image is
    fetched as soon as its strip is done, and a strip the daemon dropped
    before that (``job_not_found``) is queued again.

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
    # Strips are queued a few at a time per daemon (_window) and each image
    # is fetched, and the job dropped, as soon as it is done: a daemon
    # keeps only its newest --max-finished-jobs finished jobs, all clients'
    # together, so images left there until the last strip was queued were
    # lost (job_not_found) once the frame had more parts than that.  A
    # strip lost all the same (other clients' jobs pushed it out between
    # two polls) is queued again.
    strips: list[Optional[np.ndarray]] = [None] * n
    todo = list(range(n))               # strips to queue, in order
    pending: dict[int, Job] = {}        # queued strips not yet fetched
    lost = [0] * n                      # times each strip was lost
    window: dict[int, int] = {}         # per client (by id)
    fetched: dict[int, int] = {}        # strips fetched per client
    full: dict[int, tuple[int, float]] = {}  # 429: (fetched then, retry at)
    pause = 0.01
    try:
        while todo or pending:
            moved = False
            for i in list(todo):
                client = clients[i % len(clients)]
                key = id(client)
                if key not in window:
                    window[key] = _window(client)
                    fetched[key] = 0
                mine = sum(1 for j in pending.values() if j.client is client)
                if mine >= window[key]:
                    continue
                if key in full:
                    # The daemon's queue was full: try again once one of
                    # ours there has finished, or after a second when none
                    # is there (the queue is someone else's), as the
                    # answer's Retry-After asks.
                    then, at = full[key]
                    if fetched[key] == then and (mine or time.monotonic() < at):
                        continue
                    del full[key]
                crop = dict(render, width=width, height=height,
                            region=[0, rows[i], width, rows[i + 1]])
                try:
                    pending[i] = client.submit(scene, camera, crop)
                except LensrayError as e:
                    if e.http_status != 429:
                        raise
                    full[key] = (fetched[key], time.monotonic() + 1.0)
                    continue
                todo.remove(i)
                moved = True
            for i, job in sorted(pending.items()):
                state, rgb = _strip(job)
                if state == "running":
                    continue
                del pending[i]
                moved = True
                key = id(job.client)
                if state == "gone":
                    lost[i] += 1
                    if lost[i] > 3:
                        raise LensrayError(
                            f"strip {i} (rows {rows[i]} to {rows[i + 1]}) was "
                            f"dropped by {job.client.url} before its image "
                            f"could be fetched, {lost[i]} times",
                            "", "job_not_found", 404)
                    todo.insert(0, i)
                    continue
                strips[i] = rgb
                fetched[key] += 1
                try:
                    job.cancel()  # drops the finished job, freeing its room
                except (LensrayError, OSError, http.client.HTTPException):
                    pass
            if moved:
                pause = 0.01
            else:
                time.sleep(pause)
                pause = min(pause * 1.5, 0.2)
    except BaseException:
        for job in pending.values():
            try:
                job.cancel()
            except Exception:
                pass
        raise
    return np.concatenate([np.asarray(s) for s in strips], axis=0).view(Image)
