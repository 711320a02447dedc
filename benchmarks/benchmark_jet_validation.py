"""How well the thin-sheet model ranks surfaces like SPH, against the committed study data.

The jet-model validation study (``replication validate-jet``, reports/jet_validation.md)
scored surfaces with SPH; its data (surfaces, their vertices and triangles, SPH forces) are
committed under reports/data. These ``track_`` benchmarks score the same surfaces with the
model of the commit being measured and track its rank agreement with SPH, so a model change
that ranks worse shows up across commits. Skipped (NotImplementedError in setup) where the
data are absent. Only ``jet_force`` is taken from the package (it exists in every commit);
the statistics are scipy's.
"""

from pathlib import Path

from .common import quiet

#: The committed study data (the working tree's, whichever commit's model is measured).
DATA = Path(__file__).resolve().parents[1] / "reports" / "data"
#: The SPH quantity the study ranks (force over the simulated jet's momentum flux).
SPH_COLUMN = "sph_over_measured_flux"


def load_study(data_dir):
    """Surfaces SPH scored: [(name, points, triangles, sph value)], or None without data."""
    import pandas as pd

    paths = [data_dir / f"jet_validation_{name}.csv" for name in ("surfaces", "vertices", "triangles")]
    if not all(p.is_file() for p in paths):
        return None
    table, vertices, triangles = (pd.read_csv(p) for p in paths)
    table = table[table["sph_status"] == "ok"]
    v = {name: g[["x_mm", "y_mm", "z_mm"]].to_numpy() for name, g in vertices.groupby("surface")}
    t = {name: g[["a", "b", "c"]].to_numpy() for name, g in triangles.groupby("surface")}
    return [
        (r["surface"], v[r["surface"]], t[r["surface"]], float(r[SPH_COLUMN])) for _, r in table.iterrows()
    ]


class ModelRanksLikeSPH:
    """Spearman and Kendall of the model's forces against SPH's over the study's surfaces."""

    data_dir = DATA
    number = 1
    repeat = 1
    timeout = 600

    def setup(self):
        quiet()
        self.study = load_study(self.data_dir)
        if not self.study:
            raise NotImplementedError(f"no committed SPH study data in {self.data_dir}")
        from replication.casestudy.jet import jet_force

        self.model = [jet_force(points, triangles).axial_force for _, points, triangles, _ in self.study]
        self.sph = [value for *_, value in self.study]

    def track_model_spearman(self):
        from scipy.stats import spearmanr

        return float(spearmanr(self.model, self.sph).statistic)

    track_model_spearman.unit = "Spearman rho"

    def track_model_kendall(self):
        from scipy.stats import kendalltau

        return float(kendalltau(self.model, self.sph).statistic)

    track_model_kendall.unit = "Kendall tau-b"
