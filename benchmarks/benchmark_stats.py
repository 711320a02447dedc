"""Paired deviations and statistics (paper section 4)."""

from replication.compare import compare

from .common import PAPER_NS, cloud


class PairedStatistics:
    params = [PAPER_NS]
    param_names = ["n"]

    def setup(self, n):
        self.points = cloud(n)
        compare(self.points)

    def time_compare_both_pairings(self, n):
        compare(self.points)
