"""Start-up of the package and the command line, each in a fresh interpreter (issue 15 item 2).

``timeraw_`` benchmarks time their code in a new Python process, so they measure what a user
or a spawned worker pays: ``import replication``, ``replication --help``, and whole commands
``replication adt --random 200 -o x.vtk`` and ``replication nurbs --random 200 -o x.json``. These
run on the kernels compiled when the package was built (:mod:`replication._aot`), so their time
is also that of the first command in a fresh environment (``timeraw_adt_200_aot``,
``timeraw_nurbs_200_aot``); ``timeraw_adt_200`` and ``timeraw_nurbs_200`` run them on numba's
kernels, their on-disk cache filled by ``setup``, as an installation that could not build them
would (and as every run did before the compiled kernels existed: the history of
``timeraw_adt_200`` stays comparable). The interpreter's own start-up is outside the timed
statement (asv times ``exec`` of the code).
Goals: ``--help`` <= 0.3 s, the warm adt command <= 0.6 s and the first one <= 3 s (issues 14
and 15).
"""

import os
import subprocess
import sys

#: Output of the commands goes to a buffer: asv reads the timing from the child's stdout.
_QUIET = "import contextlib, io\n_out = io.StringIO()\n"


def _main(argv, *, aot: bool = True):
    """Code that runs ``replication ARGV`` (argparse exits after --help: that is caught)."""
    switch = "" if aot else "import os\nos.environ['REPLICATION_AOT'] = '0'\n"
    return (
        switch + _QUIET + "from replication.cli import main\n"
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


class _WarmCommand:
    """A whole command on 200 random points, on the ahead-of-time kernels and on numba's (its
    cache already warm)."""

    timeout = 300
    args: tuple[str, ...] = ()
    output = ""

    def setup(self):
        from .common import scratch_dir

        self.out = os.path.join(scratch_dir(), self.output)
        self.argv = [*self.args, "--random", "200", "--seed", "1", "-o", self.out]
        # the first run fills numba's on-disk cache (compiling in a fresh environment)
        subprocess.run([sys.executable, "-c", _main(self.argv, aot=False)], check=True, capture_output=True)

    def teardown(self):
        import shutil

        shutil.rmtree(os.path.dirname(self.out), ignore_errors=True)


class WarmADTCommand(_WarmCommand):
    """``replication adt --random 200 --seed 1 -o x.vtk``."""

    args, output = ("adt",), "x.vtk"

    def timeraw_adt_200(self):
        return _main(self.argv, aot=False)

    def timeraw_adt_200_aot(self):
        return _main(self.argv)


class WarmNURBSCommand(_WarmCommand):
    """``replication nurbs --random 200 --seed 1 -o x.json`` (the gridding compiled ahead of time too)."""

    args, output = ("nurbs",), "x.json"

    def timeraw_nurbs_200(self):
        return _main(self.argv, aot=False)

    def timeraw_nurbs_200_aot(self):
        return _main(self.argv)
