"""Start-up of the package and the command line, each in a fresh interpreter (issue 15 item 2).

``timeraw_`` benchmarks time their code in a new Python process, so they measure what a user
or a spawned worker pays: ``import replication``, ``replication --help`` and a whole warm
``replication adt --random 200 -o x.vtk`` (numba's on-disk cache filled by ``setup``). The
interpreter's own start-up is outside the timed statement (asv times ``exec`` of the code).
Goals: ``--help`` <= 0.3 s and the warm adt command <= 0.6 s (issue 14).
"""

import os
import subprocess
import sys

#: Output of the commands goes to a buffer: asv reads the timing from the child's stdout.
_QUIET = "import contextlib, io\n_out = io.StringIO()\n"


def _main(argv):
    """Code that runs ``replication ARGV`` (argparse exits after --help: that is caught)."""
    return (
        _QUIET + "from replication.cli import main\n"
        "with contextlib.redirect_stdout(_out):\n"
        "    try:\n"
        f"        status = main({argv!r})\n"
        "    except SystemExit as exc:\n"
        "        status = exc.code\n"
        "assert status in (0, None), status\n"
    )


def timeraw_import_replication():
    return "import replication"


def timeraw_import_numpy():
    """The reference: a fresh ``import numpy``."""
    return "import numpy"


def timeraw_help():
    return _main(["--help"])


class WarmADTCommand:
    """``replication adt --random 200 --seed 1 -o x.vtk`` with numba's cache already warm."""

    timeout = 300

    def setup(self):
        from .common import scratch_dir

        self.out = os.path.join(scratch_dir(), "x.vtk")
        self.argv = ["adt", "--random", "200", "--seed", "1", "-o", self.out]
        # the first run fills numba's on-disk cache (compiling in a fresh environment)
        subprocess.run([sys.executable, "-c", _main(self.argv)], check=True, capture_output=True)

    def teardown(self):
        import shutil

        shutil.rmtree(os.path.dirname(self.out), ignore_errors=True)

    def timeraw_adt_200(self):
        return _main(self.argv)
