"""The NURBS baseline (paper section 3.1): build, write, file size, evaluator speed."""

import os

import numpy as np

from replication.io import write_vtk
from replication.io.nurbs import write_nurbs
from replication.surfaces import adt
from replication.surfaces.bspline import evaluate_grid
from replication.surfaces.nurbs import NurbsPatch, clamped_uniform_knots, fit_nurbs

from .common import PAPER_NS, cloud, scratch_dir


class NURBSPaperSizes:
    params = [PAPER_NS]
    param_names = ["n"]

    def setup(self, n):
        self.points = cloud(n)
        self.tmp = scratch_dir()
        self.nurbs = fit_nurbs(self.points)
        fit_nurbs(self.points, evaluator="fast")

    def teardown(self, n):
        for name in os.listdir(self.tmp):
            os.unlink(os.path.join(self.tmp, name))
        os.rmdir(self.tmp)

    def time_nurbs_geomdl(self, n):
        fit_nurbs(self.points, evaluator="geomdl")

    def time_nurbs_fast(self, n):
        fit_nurbs(self.points, evaluator="fast")

    def time_nurbs_write_smesh(self, n):
        write_nurbs(self.nurbs.patch, os.path.join(self.tmp, "n.smesh"))

    def time_nurbs_geomdl_build_write(self, n):
        write_nurbs(fit_nurbs(self.points).patch, os.path.join(self.tmp, "n.smesh"))

    def track_nurbs_smesh_bytes(self, n):
        return write_nurbs(self.nurbs.patch, os.path.join(self.tmp, "n.smesh"))

    track_nurbs_smesh_bytes.unit = "bytes"

    def track_size_ratio_nurbs_over_adt(self, n):
        nurbs = write_nurbs(self.nurbs.patch, os.path.join(self.tmp, "n.smesh"))
        return nurbs / write_vtk(adt(self.points), os.path.join(self.tmp, "s.vtk"))

    track_size_ratio_nurbs_over_adt.unit = "ratio"


class NURBSScale:
    """fit_nurbs(fast) from 1e3 to 1e6 points (issue 15 item 4: the 1e6 hot spot)."""

    params = [[1_000, 10_000, 100_000, 1_000_000]]
    param_names = ["n"]
    timeout = 600

    def setup(self, n):
        self.points = cloud(n)
        fit_nurbs(cloud(50), evaluator="fast")

    def time_nurbs_fast(self, n):
        fit_nurbs(self.points, evaluator="fast")

    def peakmem_nurbs_fast(self, n):
        fit_nurbs(self.points, evaluator="fast")


class Evaluator:
    """geomdl against the fast evaluator on a 20 x 20 net at 50 x 50 samples (target: >= 20x)."""

    def setup(self):
        rng = np.random.default_rng(7)
        k = clamped_uniform_knots(20, 2)
        self.patch = NurbsPatch(2, 2, k, k, rng.random((20, 20, 3)), np.ones((20, 20)))
        self.geo = self.patch.to_geomdl()
        self.geo.sample_size_u = self.geo.sample_size_v = 50
        evaluate_grid(self.patch, (50, 50))

    def time_geomdl_50x50(self):
        self.geo.evaluate()
        return self.geo.evalpts

    def time_fast_50x50(self):
        evaluate_grid(self.patch, (50, 50))

    def track_speedup_fast_over_geomdl(self):
        import time

        def best(func, repeat=7):
            times = []
            for _ in range(repeat):
                t0 = time.perf_counter()
                func()
                times.append(time.perf_counter() - t0)
            return min(times)

        return best(self.time_geomdl_50x50) / best(self.time_fast_50x50)

    track_speedup_fast_over_geomdl.unit = "x"


class NURBSOverADT:
    """fit_nurbs(fast) time over adt() time at 1e6 points, timed alternately (issue 14: <= 1.5)."""

    timeout = 600

    def setup(self):
        from .benchmark_adt import median_ratio

        self.median_ratio = median_ratio
        self.points = cloud(1_000_000)
        fit_nurbs(self.points, evaluator="fast")

    def track_nurbs_fast_over_adt(self):
        return self.median_ratio(lambda: fit_nurbs(self.points, evaluator="fast"), lambda: adt(self.points))

    track_nurbs_fast_over_adt.unit = "x"


class CompareScale:
    """compare(): both surfaces, both pairings and the statistics, at scale (issue 15 item 4)."""

    params = [[10_000, 100_000]]
    param_names = ["n"]
    timeout = 600

    def setup(self, n):
        from replication.compare import compare

        self.compare = compare
        self.points = cloud(n)
        compare(cloud(200))

    def time_compare(self, n):
        self.compare(self.points)
