"""Build step of the package: compile the ahead-of-time kernels (replication/_aot.py).

Everything else about the package is declared in pyproject.toml. The extension module
``_replication_kernels`` is compiled by numba.pycc (``python -m replication._aotbuild``) in a
child process, with numba's JIT cache sent to a scratch directory and no bytecode written, so
that the build writes nothing into the source tree. If it cannot be built (no C compiler,
say), the build goes on without it and the package compiles its kernels with numba on first
use, as it always could.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = os.path.dirname(os.path.abspath(__file__))
#: Seconds the kernels may take to compile (about 40 s on a 2-core machine) before the build
#: goes on without them.
BUILD_TIMEOUT = 900


class BuildKernels(build_ext):
    """Build the kernels' extension module with numba.pycc instead of a C compiler's sources."""

    def build_extensions(self) -> None:
        # an extension that could not be built is dropped, so nothing later copies or lists it
        self.extensions = [ext for ext in self.extensions if self._build(ext)]

    def _build(self, ext: Extension) -> bool:
        target = os.path.abspath(self.get_ext_fullpath(ext.name))
        with tempfile.TemporaryDirectory(prefix="replication-numba-cache-") as cache:
            # the rest of the environment is passed on: pip's isolated build finds numba through it
            path = os.pathsep.join(p for p in (HERE, os.environ.get("PYTHONPATH")) if p)
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=path)
            command = [sys.executable, "-m", "replication._aotbuild", target]
            try:
                run = subprocess.run(command, cwd=HERE, env=env, check=False, timeout=BUILD_TIMEOUT)
                done = run.returncode == 0
            except (OSError, subprocess.TimeoutExpired) as exc:
                print(f"replication: ahead-of-time kernels not built ({exc})", file=sys.stderr)
                done = False
        if not done:
            print(
                "replication: building without ahead-of-time kernels; numba compiles them on first use",
                file=sys.stderr,
            )
        return done


setup(
    ext_modules=[Extension("_replication_kernels", sources=[])],
    cmdclass={"build_ext": BuildKernels},
)
