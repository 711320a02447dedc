"""ADT (paper section 3.2): build, build + write, memory and file size."""

import os

from replication.io import write_vtk, write_vtp
from replication.surfaces import adt

from .common import PAPER_NS, SCALE_NS, cloud, scratch_dir


class ADTPaperSizes:
    """Table 1's point counts."""

    params = [PAPER_NS, ["sweephull", "scipy"]]
    param_names = ["n", "backend"]

    def setup(self, n, backend):
        self.points = cloud(n)
        self.tmp = scratch_dir()
        adt(self.points, backend=backend)  # warm the JIT cache

    def teardown(self, n, backend):
        for name in os.listdir(self.tmp):
            os.unlink(os.path.join(self.tmp, name))
        os.rmdir(self.tmp)

    def time_adt(self, n, backend):
        adt(self.points, backend=backend)

    def time_adt_write_vtk(self, n, backend):
        write_vtk(adt(self.points, backend=backend), os.path.join(self.tmp, "s.vtk"))

    def track_adt_vtk_bytes(self, n, backend):
        return write_vtk(adt(self.points, backend=backend), os.path.join(self.tmp, "s.vtk"))

    track_adt_vtk_bytes.unit = "bytes"


class ADTScale:
    """1e3 to 1e6 points with the default backend."""

    params = [SCALE_NS]
    param_names = ["n"]
    timeout = 180

    def setup(self, n):
        self.points = cloud(n)
        self.tmp = scratch_dir()
        adt(cloud(50))

    def teardown(self, n):
        for name in os.listdir(self.tmp):
            os.unlink(os.path.join(self.tmp, name))
        os.rmdir(self.tmp)

    def time_adt(self, n):
        adt(self.points)

    def time_adt_write_vtp(self, n):
        write_vtp(adt(self.points), os.path.join(self.tmp, "s.vtp"))

    def peakmem_adt(self, n):
        adt(self.points)

    def track_adt_vtp_bytes(self, n):
        return write_vtp(adt(self.points), os.path.join(self.tmp, "s.vtp"))

    track_adt_vtp_bytes.unit = "bytes"
