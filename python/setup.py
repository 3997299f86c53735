"""Copies liblensray into the package when it is built.

`pip install ./python` after `make` puts build/liblensray.so.0 beside the
package, so that it works from any directory without LENSRAY_LIB.  The
library is taken from $LENSRAY_BUILD (default ../build, the repository's
build directory).  Without one the package installs anyway and looks for
the library at import time (LENSRAY_LIB, the system's library path).
Nothing is compiled.
"""

import os
import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent


class build_py_with_lib(build_py):
    def run(self):
        super().run()
        build = Path(os.environ.get("LENSRAY_BUILD", HERE.parent / "build"))
        lib = build / "liblensray.so.0"
        if lib.exists():
            dest = Path(self.build_lib) / "lensray" / "liblensray.so.0"
            # The versioned file itself, not the symlink.
            shutil.copyfile(lib.resolve(), dest)
            print(f"lensray: bundled {lib.resolve()}")
        else:
            print(f"lensray: no {lib}; the package will look for liblensray "
                  "at import time (LENSRAY_LIB, or the system's library path)")


setup(cmdclass={"build_py": build_py_with_lib})
