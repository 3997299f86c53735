"""lensray from Python: depth of field, bokeh and chromatic aberration.

In process, through liblensray (the GIL is released while it renders)::

    import lensray
    scene = lensray.load("scenes/spheres.json")
    rgb = scene.render(camera={"model": "thinlens", "aperture_radius": 0.2,
                               "focus_distance": 16.5},
                       render={"spp": 64})
    rgb.shape, rgb.dtype          # (480, 640, 3) float32, linear RGB
    lensray.write("out.png", rgb)

Or from a lensrayd daemon over HTTP, with the same arrays back::

    client = lensray.Client("http://localhost:8080")
    rgb = client.render("spheres", camera={"fov": 30})

The library is looked for in this order: the file named by the
environment variable LENSRAY_LIB; a copy installed beside this package
(``pip install ./python`` after ``make`` puts one there); ``build/`` of a
lensray checkout above the package; the system's library path (``make
install``).  ``lensray.library_path()`` says which was loaded.
"""

from ._capi import DEPTH_NONE, PLAN_BLOCK, PLAN_CHROMA, PLAN_LENS, library_path
from ._client import Client, Job, decode_exr, render_split
from ._core import Image, Scene, encode_png, load, version, write
from ._errors import CancelledError, LensrayError, LensrayIOError, SceneError

__version__ = "0.1.0"

__all__ = [
    "DEPTH_NONE",
    "CancelledError",
    "Client",
    "Image",
    "Job",
    "LensrayError",
    "LensrayIOError",
    "PLAN_BLOCK",
    "PLAN_CHROMA",
    "PLAN_LENS",
    "Scene",
    "SceneError",
    "decode_exr",
    "encode_png",
    "library_path",
    "load",
    "render_split",
    "version",
    "write",
]
