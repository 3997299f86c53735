"""In-process rendering through liblensray: scenes, renders, images."""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import threading
from ctypes import byref, c_int, c_size_t, c_void_p
from typing import Any, Literal, Mapping, Optional, Sequence, Union, overload

import numpy as np

from . import _capi
from ._capi import lib
from ._errors import CancelledError, LensrayError, LensrayIOError, SceneError

PathLike = Union[str, "os.PathLike[str]"]
Overrides = Union[Mapping[str, Any], Sequence[str], None]


def version() -> str:
    """The version of the loaded liblensray, e.g. ``"0.1.0"``."""
    return lib().lr_version().decode()


def _raise(status: int, err: _capi.lr_error,
           stats: Optional[dict[str, Any]] = None) -> None:
    """Raises the exception for a failed call's status and lr_error."""
    message = err.message.decode("utf-8", "replace")
    path = err.path.decode("utf-8", "replace")
    name = (lib().lr_status_name(status) or b"").decode()
    if status == _capi.LR_ERR_INVALID:
        raise SceneError(message, path, name)
    if status == _capi.LR_ERR_IO:
        raise LensrayIOError(message, path, name)
    if status == _capi.LR_ERR_CANCELLED:
        raise CancelledError(message, path, name, stats=stats)
    if status == _capi.LR_ERR_NOMEM:
        raise MemoryError(message)
    raise LensrayError(message, path, name)


def _json_default(value: Any) -> Any:
    # numpy scalars and arrays, as a sweep over np.linspace produces them.
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _check_finite(value: Any, path: str) -> None:
    """Raises SceneError naming the field of a NaN or infinite number.

    JSON has neither (RFC 8259, section 6), so Python's json module would
    write the non-standard ``NaN`` and the library would refuse the whole
    text as invalid JSON, naming no field."""
    if isinstance(value, (float, np.floating)):
        if not np.isfinite(value):
            raise SceneError(f"{path} must be a finite number, got {float(value)!r}",
                             path, "invalid")
    elif isinstance(value, np.ndarray):
        _check_finite(value.tolist(), path)
    elif isinstance(value, Mapping):
        for k, v in value.items():
            _check_finite(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            _check_finite(v, f"{path}[{i}]")


def _to_json(value: Any, path: str = "") -> bytes:
    """JSON text of `value`, whose fields' paths start with `path`."""
    _check_finite(value, path)
    return json.dumps(value, default=_json_default, allow_nan=False).encode()


def _overrides_dict(value: Any, name: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise TypeError(f"{name} must be a dict of the scene format's "
                        f"{name} keys, got {type(value).__name__}")
    return dict(value)


class _Camera:
    """A camera the library allocated (lr_camera_new) and frees when this
    object goes: Python sets it only by the scene format's keys, so it
    never needs to know lr_camera's fields.  Whoever passes ``ptr`` to a
    call keeps the object alive until the call returns."""

    def __init__(self) -> None:
        self.ptr: Optional[int] = lib().lr_camera_new()
        if not self.ptr:
            raise MemoryError("out of memory for a camera")

    def __del__(self) -> None:
        ptr, self.ptr = getattr(self, "ptr", None), None
        if ptr:
            lib().lr_camera_free(ptr)


class Image(np.ndarray):
    """A float32 (H, W, 3) array of linear RGB radiance that Jupyter shows.

    It is an ordinary ``numpy.ndarray`` in every other way (a subclass
    that adds ``_repr_png_``); ``np.asarray(image)`` gives the plain array.
    The picture is the library's own PNG encoding: sRGB, clamped to [0, 1].
    """

    def __array_finalize__(self, obj: Any) -> None:
        pass

    def __array_wrap__(self, obj: Any, context: Any = None,
                       return_scalar: bool = False) -> Any:
        # Reductions (img.mean(), img.max()) give numbers, not 0-d Images.
        if obj.ndim == 0:
            return obj[()]
        if return_scalar:  # numpy 2 passes it; numpy 1 has no such argument
            return np.ndarray.__array_wrap__(self, obj, context, return_scalar)
        return np.ndarray.__array_wrap__(self, obj, context)

    def _repr_png_(self) -> Optional[bytes]:
        # Slices and reductions of an Image are Images too; only the
        # shapes that are pictures are shown as one.
        if self.ndim != 3 or self.shape[2] != 3 or self.size == 0:
            return None
        return encode_png(np.asarray(self))


def _as_image(array: Any) -> "np.ndarray":
    """(H, W, 3) float32, C-contiguous, from anything array-like."""
    if array is None:
        raise TypeError("an image must be an (H, W, 3) or (H, W) array, got None")
    # The shape is checked before np.ascontiguousarray, which makes a
    # scalar one-dimensional and would report a shape never given.
    a = np.asarray(array, dtype=np.float32)
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    if a.ndim != 3 or a.shape[2] not in (3, 4) or a.shape[0] < 1 or a.shape[1] < 1:
        raise ValueError(
            f"an image must be (H, W, 3) or (H, W); got shape {a.shape}")
    return np.ascontiguousarray(a[:, :, :3])


def _lr_image(array: Any, depth: Any = None) -> c_void_p:
    """A new lr_image holding a copy of `array` (and `depth`); the caller
    frees it with lr_image_free."""
    rgb = _as_image(array)
    h, w = rgb.shape[:2]
    # The library's writers keep NaN and infinity out of every file (a
    # render's, as any image's), so they would be written as 0: refused
    # here instead, where they are the caller's data.
    bad = ~np.isfinite(rgb)
    if bad.any():
        y, x = (int(v) for v in np.argwhere(bad)[0][:2])
        raise ValueError(f"array holds {int(bad.sum())} NaN or infinite values "
                         f"(the first at row {y}, column {x}); lensray's images "
                         "hold finite values only")
    z = None
    if depth is not None:
        z = np.ascontiguousarray(np.asarray(depth, dtype=np.float32))
        if z.shape != (h, w):
            raise ValueError(f"depth must be ({h}, {w}); got {z.shape}")
        # (The writers store a non-finite depth as 1e10, the sky's.)
        if np.isnan(z).any() or np.isneginf(z).any():
            y, x = (int(v) for v in np.argwhere(np.isnan(z) | np.isneginf(z))[0])
            raise ValueError(f"depth holds NaN or -inf (the first at row {y}, "
                             f"column {x}); +inf is written as 1e10, the "
                             "depth of a ray that hits nothing")
    img = c_void_p()
    err = _capi.lr_error()
    st = lib().lr_image_create(w, h, 1 if z is not None else 0, byref(img), byref(err))
    if st != _capi.LR_OK:
        _raise(st, err)
    ctypes.memmove(lib().lr_image_rgb_mut(img), rgb.ctypes.data, rgb.nbytes)
    if z is not None:
        ctypes.memmove(lib().lr_image_depth_mut(img), z.ctypes.data, z.nbytes)
    return img


def encode_png(array: Any, bits: int = 8) -> bytes:
    """PNG bytes of an (H, W, 3) linear-RGB array, with the library's own
    encoder (sRGB transfer curve, clamped to [0, 1]); ``bits`` is 8 or 16."""
    if bits not in (8, 16):
        raise ValueError("bits must be 8 or 16")
    img = _lr_image(array)
    try:
        opts = _capi.lr_output_options()
        lib().lr_output_options_default(byref(opts))
        opts.png_16bit = 1 if bits == 16 else 0
        buf = c_void_p()
        n = c_size_t()
        err = _capi.lr_error()
        st = lib().lr_image_encode(img, _capi.LR_FORMAT_PNG, byref(opts),
                                   byref(buf), byref(n), byref(err))
        if st != _capi.LR_OK:
            _raise(st, err)
        try:
            return ctypes.string_at(buf, n.value)
        finally:
            lib().lr_free(buf)
    finally:
        lib().lr_image_free(img)


def _check_write_options(path: PathLike, depth: Any, half: bool,
                         png16: bool) -> None:
    """Refuses options the file's format cannot honour, as the CLI's
    --depth, --half and --png16 and the daemon's output object do, rather
    than writing a file other than the one asked for."""
    name = os.fsdecode(path).lower()
    if name.endswith(".png"):
        if depth is not None:
            raise ValueError("a PNG has no Z channel: write the depth to an "
                             ".exr, or leave it out")
        if half:
            raise ValueError("half=True applies to .exr only, not .png")
    elif name.endswith(".exr") and png16:
        raise ValueError("png16=True applies to .png only, not .exr")


def write(path: PathLike, array: Any, depth: Any = None, *,
          half: bool = False, png16: bool = False) -> None:
    """Writes an image with liblensray's own encoders.

    The format follows the extension: ``.exr`` (linear float32 RGB, or half
    floats with ``half=True``; plus a Z channel when ``depth`` is given) or
    ``.png`` (sRGB, clamped to [0, 1]; 16 bits per channel with
    ``png16=True``).  ``array`` is (H, W, 3) linear RGB (an (H, W) array is
    written as grey; a fourth channel is dropped).  The file is written
    beside its name and renamed into place, so a failed write never leaves
    a partial file.

    Raises:
        SceneError: an extension other than .exr or .png.
        LensrayIOError: the file could not be written.
        ValueError: an array of the wrong shape or with NaN or infinite
            values (a file would hold them as 0), ``depth`` with a ``.png``
            (which has no Z channel to keep it in), ``half`` with a ``.png``
            or ``png16`` with an ``.exr``.
    """
    _check_write_options(path, depth, half, png16)
    img = _lr_image(array, depth)
    try:
        opts = _capi.lr_output_options()
        lib().lr_output_options_default(byref(opts))
        opts.exr_half = 1 if half else 0
        opts.png_16bit = 1 if png16 else 0
        err = _capi.lr_error()
        st = lib().lr_image_write(img, os.fsencode(path), byref(opts), byref(err))
        if st != _capi.LR_OK:
            _raise(st, err)
    finally:
        lib().lr_image_free(img)


def _stats_dict(st: _capi.lr_render_stats) -> dict[str, Any]:
    return {f[0]: getattr(st, f[0]) for f in st._fields_}


def _progress_bar(enabled: Optional[bool]) -> Any:
    """A tqdm class, or None when there is to be no bar."""
    if enabled is False:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if enabled:
            raise
        return None
    return tqdm


class Scene:
    """A loaded scene: geometry, lights, and its own camera and settings.

    Made by :func:`lensray.load`.  A scene is read-only once loaded: any
    number of threads may render from it at once with different cameras
    and settings.  Its memory (meshes, Embree's BVH) is freed when the
    object is garbage-collected, or at once with :meth:`close` or a
    ``with`` block.
    """

    def __init__(self, handle: c_void_p, source: str) -> None:
        self._h: Optional[c_void_p] = handle
        self._source = source
        self._lock = threading.Lock()
        self._active = 0

    def __repr__(self) -> str:
        if self._h is None:
            return f"<lensray.Scene {self._source} (closed)>"
        w, h = self.size
        return (f"<lensray.Scene {self._source}: {self.primitive_count} "
                f"primitives, {w} x {h}>")

    def __enter__(self) -> "Scene":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass

    def close(self) -> None:
        """Frees the scene now.  Rendering it afterwards raises ValueError.

        Raises:
            RuntimeError: a render from another thread is still using it.
        """
        with self._lock:
            if self._active:
                raise RuntimeError("the scene is being rendered")
            h, self._h = self._h, None
        if h is not None:
            lib().lr_scene_free(h)

    @contextlib.contextmanager
    def _using(self) -> Any:
        """The handle, counted as in use until the block ends, so that
        close() from another thread raises RuntimeError meanwhile instead
        of freeing it: the count is taken with the handle, under the lock
        (render() read the handle first and counted it later, and a close()
        in between freed a scene about to be rendered: a segfault)."""
        with self._lock:
            if self._h is None:
                raise ValueError("the scene is closed")
            h = self._h
            self._active += 1
        try:
            yield h
        finally:
            with self._lock:
                self._active -= 1

    @property
    def primitive_count(self) -> int:
        """Triangles + spheres + planes."""
        with self._using() as h:
            return int(lib().lr_scene_primitive_count(h))

    @property
    def warnings(self) -> list[str]:
        """What loading read but ignored (parts of a glTF file lensray
        does not render), a line each; the CLI prints them as
        ``lensray: warning: ...``."""
        with self._using() as h:
            text = lib().lr_scene_warnings(h) or b""
        return [w for w in text.decode("utf-8", "replace").split("\n") if w]

    @property
    def size(self) -> tuple[int, int]:
        """The scene's own image size (width, height), before overrides."""
        rs = _capi.lr_render_settings()
        with self._using() as h:
            lib().lr_scene_settings(h, byref(rs))
        return rs.width, rs.height

    def _setup(self, h: c_void_p, camera: Optional[Mapping[str, Any]],
               render: Optional[Mapping[str, Any]]
               ) -> tuple[_Camera, _capi.lr_render_settings]:
        cam = _Camera()
        rs = _capi.lr_render_settings()
        lib().lr_scene_camera(h, cam.ptr)
        lib().lr_scene_settings(h, byref(rs))
        err = _capi.lr_error()
        if camera is not None:
            camera = _overrides_dict(camera, "camera")
        if render is not None:
            render = _overrides_dict(render, "render")
        if camera:
            text = _to_json(camera, "camera")
            st = lib().lr_camera_apply_json(cam.ptr, text, len(text), byref(err))
            if st != _capi.LR_OK:
                _raise(st, err)
        if render:
            text = _to_json(render, "render")
            st = lib().lr_render_settings_apply_json(byref(rs), text, len(text),
                                                     byref(err))
            if st != _capi.LR_OK:
                _raise(st, err)
        return cam, rs

    def plan(self, camera: Optional[Mapping[str, Any]] = None,
             render: Optional[Mapping[str, Any]] = None) -> np.ndarray:
        """The effect plan :meth:`render` works from, for the same
        overrides (``lr_render_plan_map``: built the same way, autofocus
        first, without tracing).

        Returns:
            a uint8 (rows, columns) array, one cell per block of
            ``PLAN_BLOCK`` x ``PLAN_BLOCK`` pixels, rows from the top (the
            last row and column may cover fewer pixels): bit ``PLAN_LENS``
            set where the lens is sampled, ``PLAN_CHROMA`` where the
            colours are traced apart.  With ``render.plan`` off every block
            is the full simulation.

        Raises:
            SceneError: a bad override (``.path`` names the field), or
                autofocus on nothing.
        """
        cells = c_void_p()
        cols, rows = c_int(0), c_int(0)
        err = _capi.lr_error()
        with self._using() as h:
            cam, rs = self._setup(h, camera, render)
            st = lib().lr_render_plan_map(h, cam.ptr, byref(rs), byref(cells),
                                          byref(cols), byref(rows), byref(err))
        if st != _capi.LR_OK:
            _raise(st, err)
        try:
            ptr = ctypes.cast(cells, ctypes.POINTER(ctypes.c_uint8))
            return np.ctypeslib.as_array(ptr, shape=(rows.value, cols.value)).copy()
        finally:
            lib().lr_free(cells)

    @overload
    def render(self, camera: Optional[Mapping[str, Any]] = ...,
               render: Optional[Mapping[str, Any]] = ...,
               depth: Literal[False] = ..., stats: Literal[False] = ..., *,
               progress: Optional[bool] = ...,
               cancel: Optional[threading.Event] = ...) -> Image: ...

    @overload
    def render(self, camera: Optional[Mapping[str, Any]] = ...,
               render: Optional[Mapping[str, Any]] = ...,
               *, depth: Literal[True], stats: Literal[False] = ...,
               progress: Optional[bool] = ...,
               cancel: Optional[threading.Event] = ...
               ) -> tuple[Image, np.ndarray]: ...

    @overload
    def render(self, camera: Optional[Mapping[str, Any]] = ...,
               render: Optional[Mapping[str, Any]] = ...,
               depth: Literal[False] = ..., *, stats: Literal[True],
               progress: Optional[bool] = ...,
               cancel: Optional[threading.Event] = ...
               ) -> tuple[Image, dict[str, Any]]: ...

    @overload
    def render(self, camera: Optional[Mapping[str, Any]] = ...,
               render: Optional[Mapping[str, Any]] = ...,
               *, depth: Literal[True], stats: Literal[True],
               progress: Optional[bool] = ...,
               cancel: Optional[threading.Event] = ...
               ) -> tuple[Image, np.ndarray, dict[str, Any]]: ...

    @overload
    def render(self, camera: Optional[Mapping[str, Any]] = ...,
               render: Optional[Mapping[str, Any]] = ...,
               depth: bool = ..., stats: bool = ..., *,
               progress: Optional[bool] = ...,
               cancel: Optional[threading.Event] = ...) -> Any: ...

    def render(self, camera: Optional[Mapping[str, Any]] = None,
               render: Optional[Mapping[str, Any]] = None,
               depth: bool = False, stats: bool = False, *,
               progress: Any = None,
               cancel: Optional[threading.Event] = None) -> Any:
        """Renders the scene and returns its pixels as numpy arrays.

        Args:
            camera: keys that override the scene's ``camera`` object, with
                the scene format's names and rules, e.g.
                ``{"model": "thinlens", "f_number": 2.8,
                "focal_length_mm": 50, "focus_distance": 4}``.  Keys left
                out keep the scene's values.
            render: keys that override the scene's ``render`` object, e.g.
                ``{"width": 320, "height": 240, "spp": 64, "seed": 1}``.
            depth: also return the Z channel.
            stats: also return the render's statistics as a dict
                (``seconds``, ``cpu_seconds``, ``pixels``, ``samples``,
                ``rays``, ``nan_samples``, ``threads``, and the effect
                plan's ``lens_pixels``, ``chroma_pixels``, ``camera_rays``,
                ``full_camera_rays``, ``full_samples``).
            progress: ``None`` (the default) shows a tqdm bar, once the
                render has taken a second, when tqdm is installed;
                ``False`` never does; ``True`` requires tqdm.  A callable
                ``progress(done, total)`` (pixels) is called instead, from
                the calling thread, about every 0.1 s and once at the end.
            cancel: a ``threading.Event``; setting it from another thread
                stops the render within a tile and raises CancelledError.

        Returns:
            ``rgb``: an :class:`Image`, a float32 (H, W, 3) ndarray of
            linear RGB radiance, rows from the top, bit-identical to the
            pixels the CLI writes to a float EXR for the same scene and
            overrides.  With ``depth=True`` a tuple ``(rgb, z)`` where z is
            float32 (H, W): distance along the view axis of the pixel
            centre's first hit, 1e10 where the ray hits nothing.  With
            ``stats=True`` the stats dict is appended: ``(rgb, stats)`` or
            ``(rgb, z, stats)``.

        The GIL is released while the library renders (on all cores unless
        ``render={"threads": n}``), so other Python threads keep running.
        Ctrl-C (KeyboardInterrupt) cancels the render within a tile, waits
        for its threads to stop, and re-raises KeyboardInterrupt.

        Raises:
            SceneError: a bad override; ``.path`` names the field
                (``"camera.aperture_radius"``) and ``.message`` is the
                library's sentence.
            CancelledError: ``cancel`` was set; ``.stats`` has what was
                rendered before it stopped.
            KeyboardInterrupt: Ctrl-C, after the render has stopped.
        """
        # Checked before the render starts: the loop below first asks it
        # after 0.1 s, so a wrong value would fail only in longer renders.
        if cancel is not None and not callable(getattr(cancel, "is_set", None)):
            raise TypeError("cancel must be a threading.Event, got "
                            f"{type(cancel).__name__}")
        with self._using() as h:
            return self._render(h, camera, render, depth, stats, progress,
                                cancel)

    def _render(self, h: c_void_p, camera: Optional[Mapping[str, Any]],
                render: Optional[Mapping[str, Any]], depth: bool,
                stats: bool, progress: Any,
                cancel: Optional[threading.Event]) -> Any:
        """render() with the handle held (_using)."""
        cam, rs = self._setup(h, camera, render)
        if depth:
            rs.want_depth = 1
        # An event set already stops the render before it starts (the
        # loop below first looks at it after 0.1 s, when a small render is
        # over).
        flag = c_int(1 if cancel is not None and cancel.is_set() else 0)
        rs.cancel = ctypes.pointer(flag)

        # A callable progress(done, total) is called from this thread (the
        # caller's) about every 0.1 s with pixels done and in all.
        progress_fn = progress if callable(progress) else None
        bar_cls = None if progress_fn is not None else _progress_bar(progress)
        bar = None
        # Pixels done and in all, read by the loop below that draws the bar.
        # The library's lr_progress_store writes them from the render
        # threads without entering Python; with an older library a Python
        # callback does, taking the GIL for a moment after each tile.
        done: Any = (ctypes.c_uint64 * 2)()
        if bar_cls is not None or progress_fn is not None:
            store = _capi.progress_store()
            if store is not None:
                rs.progress = store
                rs.progress_user = ctypes.addressof(done)
            else:
                def on_progress(_user: Any, d: int, t: int) -> None:
                    done[0] = d
                    done[1] = t
                callback = _capi.lr_progress_fn(on_progress)
                rs.progress = callback

        out = c_void_p()
        st = _capi.lr_render_stats()
        err = _capi.lr_error()
        result: list[Optional[int]] = [None]
        handle = h

        # Completion is signalled with an Event rather than read from the
        # thread: a Thread.join interrupted by Ctrl-C can leave is_alive()
        # False while the thread still runs (CPython before 3.12).
        finished = threading.Event()

        def work() -> None:
            try:
                result[0] = lib().lr_render(handle, cam.ptr, byref(rs),
                                            byref(out), byref(st), byref(err))
            finally:
                finished.set()

        worker = threading.Thread(target=work, name="lensray-render", daemon=True)
        try:
            worker.start()
            try:
                while not finished.wait(0.1):
                    if cancel is not None and cancel.is_set():
                        flag.value = 1
                    if progress_fn is not None and done[1]:
                        progress_fn(int(done[0]), int(done[1]))
                    if bar_cls is not None and done[1]:
                        if bar is None:
                            # delay: no bar for renders under a second.
                            bar = bar_cls(total=done[1], unit="px",
                                          unit_scale=True, leave=False,
                                          desc="lensray", delay=1.0)
                        bar.update(done[0] - bar.n)
                if bar is not None:
                    bar.update(done[0] - bar.n)
                if progress_fn is not None and done[1]:
                    progress_fn(int(done[0]), int(done[1]))
                worker.join()
            except BaseException:
                # Ctrl-C (or any exception in this thread): stop the render
                # and wait for its threads before anything it uses is
                # freed; further Ctrl-Cs do not abandon it.
                flag.value = 1
                while not finished.is_set():
                    try:
                        finished.wait()
                    except BaseException:
                        pass
                worker.join()
                if out:
                    lib().lr_image_free(out)
                raise
        finally:
            if bar is not None:
                bar.close()

        status = result[0]
        assert status is not None
        if status != _capi.LR_OK:
            _raise(status, err, _stats_dict(st))
        try:
            w = lib().lr_image_width(out)
            h = lib().lr_image_height(out)
            rgb = np.ctypeslib.as_array(lib().lr_image_rgb(out), shape=(h, w, 3))
            rgb = rgb.copy().view(Image)
            z = None
            if depth:
                zp = lib().lr_image_depth(out)
                z = np.ctypeslib.as_array(zp, shape=(h, w)).copy()
        finally:
            lib().lr_image_free(out)
        ret: list[Any] = [rgb]
        if depth:
            ret.append(z)
        if stats:
            ret.append(_stats_dict(st))
        return rgb if len(ret) == 1 else tuple(ret)


def _override_strings(overrides: Overrides) -> list[bytes]:
    if overrides is None:
        return []
    if isinstance(overrides, Mapping):
        return [f"{k}={_to_json(v, str(k)).decode()}".encode()
                for k, v in overrides.items()]
    if isinstance(overrides, (str, bytes)):
        raise TypeError("overrides must be a dict or a list of 'path=value' strings")
    out = []
    for s in overrides:
        # (bytes(5) would be five NUL bytes, reported as an empty override.)
        if not isinstance(s, (str, bytes)):
            raise TypeError("each override must be a 'path=value' string, got "
                            f"{type(s).__name__}")
        out.append(s.encode() if isinstance(s, str) else s)
    return out


def load(source: Union[PathLike, Mapping[str, Any]],
         overrides: Overrides = None, *,
         base_dir: Optional[PathLike] = None) -> Scene:
    """Loads a scene from a JSON file or from a dict in the scene format.

    Args:
        source: the path of a scene file (``"scenes/spheres.json"``; mesh
            paths are relative to its directory), or a dict with the
            scene's JSON structure (docs/scene-format.md).
        overrides: values to change before the scene is checked, by JSON
            path, as the CLI's ``--set``: a dict
            ``{"camera.fov": 30, "objects[2].radius": 0.5}`` or a list of
            ``"path=value"`` strings (the value parsed as JSON, else taken
            as a string).
        base_dir: for a dict, the directory its relative mesh paths are
            resolved from; the current directory by default.

    Returns:
        A :class:`Scene`; render it with :meth:`Scene.render`.

    Raises:
        SceneError: bad JSON, an invalid value or a bad mesh; ``.path`` is
            the field's JSON path (``"objects[3].radius"``) and
            ``.message`` the library's sentence, which names it too.
        LensrayIOError: the file (or a mesh) could not be read.
    """
    sets = _override_strings(overrides)
    arr = (ctypes.c_char_p * max(len(sets), 1))(*sets)
    out = c_void_p()
    err = _capi.lr_error()
    if isinstance(source, Mapping):
        text = _to_json(dict(source))
        base = os.fsencode(base_dir) if base_dir is not None else None
        st = lib().lr_scene_load_json(text, len(text), base, arr, len(sets),
                                      byref(out), byref(err))
        name = "(dict)"
    else:
        st = lib().lr_scene_load_file(os.fsencode(source), arr, len(sets),
                                      byref(out), byref(err))
        name = os.fspath(source)
    if st != _capi.LR_OK:
        _raise(st, err)
    return Scene(out, name)
