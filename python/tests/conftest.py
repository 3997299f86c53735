"""Fixtures for the lensray package's tests (run by `make test-python`).

The repository's build directory is $LENSRAY_BUILD_DIR (default build/):
the CLI there is the reference the in-process renders are compared with,
and its daemon is started for the client's tests.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Iterator

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("LENSRAY_BUILD_DIR", REPO / "build")).resolve()
SCENES = REPO / "scenes"

# Python turns SIGINT into KeyboardInterrupt only when its parent left
# SIGINT alone; a make started in the background by a non-interactive
# shell (`make test &`, some CI runners) ignores it, and the Ctrl-C tests
# would then see their render run to the end.  Restore the default here,
# for this process and the Python processes the tests start.
signal.signal(signal.SIGINT, signal.default_int_handler)

# A small, fast version of the spheres scene with a thin lens: the blur
# makes every pixel depend on the lens samples as well as the pixel's.
SMALL = {"width": 96, "height": 54, "spp": 8}
LENS = {"model": "thinlens", "aperture_radius": 0.2, "focus_distance": 16.5}


def read_exr(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """RGB and Z of an EXR, read with the OpenEXR package (not lensray)."""
    import OpenEXR
    with OpenEXR.File(str(path), separate_channels=True) as f:
        ch = f.channels()
        rgb = np.stack([ch[c].pixels for c in "RGB"], axis=2)
        z = ch["Z"].pixels if "Z" in ch else None
    return rgb, z


def cli_render(scene: Path, out: Path, sets: dict, *extra: str) -> None:
    """Renders with build/lensray, each override as --set PATH=JSON."""
    cmd = [str(BUILD / "lensray"), "render", str(scene), "-o", str(out), "-q"]
    for k, v in sets.items():
        cmd += ["--set", f"{k}={json.dumps(v)}"]
    subprocess.run(cmd + list(extra), check=True, timeout=120)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.ascontiguousarray(a, dtype=np.float32)
    b = np.ascontiguousarray(b, dtype=np.float32)
    return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))


class Daemon:
    def __init__(self, *args: str) -> None:
        self.log: list[str] = []
        self.proc = subprocess.Popen(
            [str(BUILD / "lensrayd"), "--port", "0", "--scenes", str(SCENES),
             "--workers", "1", *args],
            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
        assert self.proc.stderr is not None
        self.url = ""
        for line in self.proc.stderr:
            self.log.append(line)
            m = re.search(r"listening on (http://\S+)", line)
            if m:
                self.url = m.group(1)
                break
        if not self.url:
            self.proc.kill()
            raise RuntimeError("lensrayd did not start:\n" + "".join(self.log))
        # The request log must be read, or the daemon blocks on a full pipe.
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.log.append(line)

    def stop(self) -> None:
        self.proc.kill()
        self.proc.wait(timeout=10)


@pytest.fixture(scope="session")
def daemon() -> Iterator[Daemon]:
    d = Daemon()
    yield d
    d.stop()


@pytest.fixture(scope="session")
def token_daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Daemon, str]]:
    token = "s3cret-" + os.urandom(8).hex()
    f = tmp_path_factory.mktemp("token") / "token"
    f.write_text(token + "\n")
    d = Daemon("--token-file", str(f))
    yield d, token
    d.stop()


@pytest.fixture(scope="session")
def spheres():
    import lensray
    s = lensray.load(SCENES / "spheres.json")
    yield s
    s.close()


# `make test` adds up one "N passed, N failed" line per step (tests/all.sh).
sys.path.insert(0, str(REPO / "tests"))
from pytest_counts import pytest_runtest_logreport, pytest_terminal_summary  # noqa: E402,F401
