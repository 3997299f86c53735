"""Copies liblensray into the package when it is built.

`pip install ./python` after `make` puts build/liblensray.so.0 beside the
package, so that it works from any directory without LENSRAY_LIB.  The
library is taken from $LENSRAY_BUILD (default ../build, the repository's
build directory).  Without one the package installs anyway and looks for
the library at import time (LENSRAY_LIB, the system's library path).
Nothing is compiled.  `pip wheel ./python` makes a wheel with the
library inside, for this platform; it still needs the library's own
shared libraries (Embree 3, OpenEXRCore, cJSON, libpng) on the machine.
"""

import os
import shutil
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
LIB = Path(os.environ.get("LENSRAY_BUILD", HERE.parent / "build")) / "liblensray.so.0"


class BinaryDistribution(Distribution):
    """With the library inside, a wheel is for this platform only
    (cp3X-cp3X-linux_x86_64), not a pure-Python py3-none-any one."""

    def has_ext_modules(self):
        return True


class build_py_with_lib(build_py):
    def run(self):
        super().run()
        lib = LIB
        if lib.exists():
            dest = Path(self.build_lib) / "lensray" / "liblensray.so.0"
            # The versioned file itself, not the symlink.
            shutil.copyfile(lib.resolve(), dest)
            print(f"lensray: bundled {lib.resolve()}")
        else:
            print(f"lensray: no {lib}; the package will look for liblensray "
                  "at import time (LENSRAY_LIB, or the system's library path)")


setup(cmdclass={"build_py": build_py_with_lib},
      distclass=BinaryDistribution if LIB.exists() else Distribution)
