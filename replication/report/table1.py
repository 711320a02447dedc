"""The Table 1 / Fig. 6 report: save the experiment's data, render markdown and figures from it.

:func:`save_table1_data` writes every table of :class:`~replication.experiments.table1.Table1Results`
as CSV under ``data/`` (plus the provenance JSON and the meshes of the Table 1 clouds);
:func:`render_table1` reads only those files, so the report can be re-rendered (restyled)
without re-running the experiment. Every number in the markdown comes from the CSV files.
"""

from __future__ import annotations

import functools
import math
import os
from pathlib import Path
from typing import Any

import pandas as pd

from replication.experiments.storage import COORDINATES, EQUAL_PRECISION, FAMILIES
from replication.experiments.table1_claims import STORAGE_HEADLINE, WHY_ABSOLUTE
from replication.io.nurbs import write_nurbs
from replication.io.vtk import read_surface, write_vtk
from replication.report.figures import clear_figures, fig6, figure_files, scale_figure
from replication.report.markdown import fmt, iqr, provenance_section, table, write_report
from replication.report.parallel import run_figure_tasks
from replication.report.render3d import render_views
from replication.report.store import data_set, read_csv, read_provenance, run_again, write_csv, write_json

__all__ = ["TABLES", "save_table1_data", "load_table1_data", "render_table1"]

TABLES = (
    "sizes",
    "clouds",
    "timings_raw",
    "timings",
    "stats",
    "montecarlo_raw",
    "montecarlo",
    "scale_raw",
    "scale",
    "growth",
    "storage_raw",
    "storage",
    "claims",
)
#: The columns of the tables that hold text; the others must hold numbers (see :func:`.store.read_csv`).
TEXT_COLUMNS = frozenset({
    "claim", "paper", "unit", "verdict", "why", "seed", "depth_axis", "net", "net_rule", "method",
    "quantity", "a_recommended", "b_recommended", "pairing", "recommended", "format", "coordinates",
    "family", "task",
})  # fmt: skip


class _Mesh:
    def __init__(self, points: Any, triangles: Any) -> None:
        self.points, self.triangles = points, triangles


def save_table1_data(results: Any, out_dir: str | os.PathLike[str]) -> Path:
    """Write the results' tables (CSV), provenance (JSON) and meshes under ``out_dir/data``."""
    data = Path(out_dir) / "data"
    # meshes of sizes this run does not have are removed
    with data_set(data, "table1_provenance.json", stale=["table1_meshes/*"], checksums=True) as staged:
        meshes = staged / "table1_meshes"
        meshes.mkdir()
        for name in TABLES:
            write_csv(getattr(results, name), staged / f"table1_{name}.csv")
        for n, (surface, nurbs) in results.meshes.items():
            write_vtk(surface, meshes / f"n{n}_adt.vtk")
            write_nurbs(nurbs.patch, meshes / f"n{n}_nurbs.smesh")
            write_vtk(
                _Mesh(*nurbs.tessellation_mesh()),
                meshes / f"n{n}_nurbs_tessellation.vtk",
                title="NURBS tessellation",
            )
        write_json(results.provenance, staged / "table1_provenance.json")
    return data


#: The tables with a row for each size n of the run and each combination of these columns
#: (the same combinations for every n, except in :data:`RAGGED`).
GRIDS = {
    "montecarlo": ("quantity",),
    "sizes": ("method", "format"),
    "stats": ("pairing",),
    "storage": ("coordinates", "family"),
    "timings": ("quantity",),
    "clouds": (),
    "montecarlo_raw": ("replicate",),
    "timings_raw": ("repeat", "task"),
    "storage_raw": ("replicate", "coordinates"),
}
#: Tables whose rows may differ between sizes: a Monte Carlo quantity that is never computable
#: at a size (no finite value, as in a quick run's smallest clouds) has no row there. Its rows
#: are checked against the raw data it is computed from instead (:func:`_check_summary`).
RAGGED = frozenset({"montecarlo"})


def _damaged(provenance: dict[str, Any], out_dir: str | os.PathLike[str]) -> str:
    """What to do about damaged tables: run the recorded command again, into ``out_dir``."""
    return (
        f"the data are damaged; regenerate them with `{run_again(provenance, 'replication table1', out_dir)}`"
    )


def load_table1_data(out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """The saved tables (DataFrames) and provenance of a Table 1 run.

    Raises
    ------
    ReportDataError
        A table that is not whole: a size n that is not the run's or has no rows, a row
        twice, or a row that the other sizes have and one lacks (a deleted or edited line).
    """
    data = Path(out_dir) / "data"
    loaded: dict[str, Any] = {
        name: read_csv(data / f"table1_{name}.csv", strings=TEXT_COLUMNS) for name in TABLES
    }
    loaded["provenance"] = read_provenance(data, "table1_provenance.json", "replication table1")
    ns = [int(n) for n in loaded["provenance"].get("config", {}).get("ns", [])]
    if ns:
        damaged = _damaged(loaded["provenance"], out_dir)
        for name, keys in GRIDS.items():
            path = data / f"table1_{name}.csv"
            _check_grid(loaded[name], path, ns, keys, damaged, complete=name not in RAGGED)
        _check_summary(loaded["montecarlo"], loaded["montecarlo_raw"], data, damaged)
    return loaded


def _check_summary(summary: pd.DataFrame, raw: pd.DataFrame, data: Path, damaged: str) -> None:
    """Refuse a Monte Carlo summary that differs from the one computed from the raw data.

    The summary may lack a quantity at a size (never computable there), so a deleted row
    cannot be told from the summary alone; the raw data, from which it is computed, tell.
    Both are saved at full precision, but pandas 2's CSV reader may read a number back one
    unit in the last place off, so the recomputed numbers must agree to 1e-12, relatively.
    ``damaged`` ends each refusal (what to run again).
    """
    from replication.errors import ReportDataError
    from replication.experiments.table1 import summarize_montecarlo

    keys = ["n", "quantity"]
    expected = summarize_montecarlo(raw)
    path = data / "table1_montecarlo.csv"
    absent = [column for column in expected.columns if column not in summary.columns]
    if absent:
        raise ReportDataError(f"{path}: no column {absent[0]!r}: {damaged}")
    both = summary.merge(expected, on=keys, how="outer", suffixes=("", " from raw"), indicator=True)
    why = f"it is computed from {data / 'table1_montecarlo_raw.csv'}: {damaged}"
    for _, row in both.iterrows():
        named = f"n = {row['n']:g}, quantity = {row['quantity']}"
        if row["_merge"] != "both":
            said = "lacks the row of" if row["_merge"] == "right_only" else "has a row not in the raw data:"
            raise ReportDataError(f"{path}: {said} {named}; {why}")
        for column in expected.columns.drop(keys):
            ours, theirs = row[column], row[f"{column} from raw"]
            if not (pd.isna(ours) and pd.isna(theirs)) and not math.isclose(ours, theirs, rel_tol=1e-12):
                raise ReportDataError(
                    f"{path}: {column} of {named} is {ours}, not {theirs} as the raw data give; {why}"
                )


def _check_grid(
    frame: pd.DataFrame,
    path: Path,
    ns: list[int],
    keys: tuple[str, ...],
    damaged: str,
    *,
    complete: bool = True,
) -> None:
    """Refuse a table that is not a row for each n of ``ns`` and each combination of ``keys``
    (a row deleted from the storage table was drawn as missing, without a word); with
    ``complete=False`` the combinations may differ between sizes, but a size and a row must
    still be the run's and there once. ``damaged`` ends each refusal (what to run again)."""
    from replication.errors import ReportDataError

    sizes = set(frame["n"].tolist())
    stray = sorted(n for n in sizes if n not in ns)
    if stray:
        raise ReportDataError(f"{path}: n = {stray[0]:g} is not one of the run's sizes {ns}: {damaged}")
    absent = [n for n in ns if n not in sizes]
    if absent:
        raise ReportDataError(f"{path}: no rows for n = {absent[0]}: {damaged}")
    twice = frame.duplicated(["n", *keys])
    if twice.any():
        row = frame[twice].iloc[0]
        named = ", ".join(f"{k} = {row[k]}" for k in ("n", *keys))
        raise ReportDataError(f"{path}: the row of {named} is there twice: {damaged}")
    if not keys or not complete:
        return
    rows = {n: set(map(tuple, group[list(keys)].astype(str).to_numpy())) for n, group in frame.groupby("n")}
    every = set().union(*rows.values())
    for n in ns:
        lacking = sorted(every - rows[n])
        if lacking:
            named = ", ".join(f"{k} = {v}" for k, v in zip(keys, lacking[0]))
            said = f"n = {n} lacks the row of {named} that other sizes have"
            raise ReportDataError(f"{path}: {said}; {damaged}")


def _q(frame: pd.DataFrame, n: int, quantity: str) -> pd.Series:
    """The summary row of a quantity at n (all NaN when the quantity was never computable)."""
    rows = frame[(frame["n"] == n) & (frame["quantity"] == quantity)]
    if rows.empty:
        return pd.Series(float("nan"), index=frame.columns)
    return rows.iloc[0]


def _ms(frame: pd.DataFrame, n: int, task: str) -> str:
    r = _q(frame, n, f"{task} [s]")
    return iqr(1e3 * r["median"], 1e3 * r["q1"], 1e3 * r["q3"])


def _ratio(frame: pd.DataFrame, n: int, quantity: str) -> str:
    r = _q(frame, n, quantity)
    return iqr(r["median"], r["q1"], r["q3"])


def _images(ns: list[int], out: Path) -> tuple[str, str]:
    """The 3-D views of the saved meshes of each n: the markdown table and the renderer used."""
    figures = out / "figures"
    meshes = out / "data" / "table1_meshes"
    views, rows = {}, []
    for n in ns:
        adt_mesh = read_surface(meshes / f"n{n}_adt.vtk")
        nurbs_mesh = read_surface(meshes / f"n{n}_nurbs_tessellation.vtk")
        names = {kind: figures / f"table1_n{n}_{kind}.png" for kind in ("adt", "nurbs", "overlay")}
        views[names["adt"]] = [("ADT", adt_mesh)]
        views[names["nurbs"]] = [("NURBS", nurbs_mesh)]
        views[names["overlay"]] = [("ADT", adt_mesh), ("NURBS", nurbs_mesh)]
        rows.append([str(n)] + [f"![{k} n={n}](figures/{p.name})" for k, p in names.items()])
    renderer = render_views(views)
    return table(rows, ["n", "ADT", "NURBS", "superimposed"], "cccc"), renderer


def _sizes_table(d: dict[str, Any]) -> str:
    clouds, sizes = d["clouds"], d["sizes"]
    rows = []
    for _, c in clouds.iterrows():
        head = sizes[(sizes["n"] == c["n"]) & sizes["headline"]]
        adt_b = float(head[head["method"] == "ADT"]["bytes"].iloc[0])
        nurbs_b = float(head[head["method"] == "NURBS"]["bytes"].iloc[0])
        rows.append([
            str(c["n"]), fmt(c["vertices"], "int"), fmt(c["merged"], "int"), fmt(c["triangles"], "int"),
            f"{c['net']} ({c['net_rule']})", fmt(c["grid_filled"], "int"), fmt(adt_b, "int"),
            fmt(nurbs_b, "int"), fmt(adt_b / nurbs_b, ".3g"),
        ])  # fmt: skip
    header = ["n", "vertices", "merged points", "triangles", "NURBS net", "grid nodes filled",
              "ADT file [bytes]", "NURBS file [bytes]", "ADT / NURBS"]  # fmt: skip
    return table(rows, header)


def _timing_table(d: dict[str, Any]) -> str:
    t = d["timings"]
    rows = [
        [str(n), _ms(t, n, "adt"), _ms(t, n, "nurbs_geomdl"), _ms(t, n, "nurbs_fast"),
         _ratio(t, n, "nurbs_geomdl/adt"), _ratio(t, n, "nurbs_fast/adt"), _ms(t, n, "adt+write"),
         _ms(t, n, "nurbs_geomdl+write"), _ratio(t, n, "nurbs_geomdl+write/adt+write")]
        for n in d["clouds"]["n"]
    ]  # fmt: skip
    header = ["n", "ADT [ms]", "NURBS geomdl [ms]", "NURBS fast [ms]", "NURBS geomdl / ADT",
              "NURBS fast / ADT", "ADT + write [ms]", "NURBS geomdl + write [ms]",
              "ratio (+ write)"]  # fmt: skip
    return table(rows, header)


def _stats_table(d: dict[str, Any]) -> str:
    rows = []
    for _, r in d["stats"].iterrows():
        computed = pd.notna(r.get("t_p"))
        verdict = (
            ("similar" if (r["t_similar"] and r["wilcoxon_similar"]) else "different")
            if computed
            else "too few pairs"
        )
        rows.append([
            str(r["n"]), r["pairing"], fmt(r["pairs"], "int"), fmt(r["excluded"], "int"), fmt(r.get("t_p")),
            fmt(r.get("wilcoxon_p")), verdict,
            f"{fmt(r.get('mean_diff'))} [{fmt(r.get('ci95_low'))}, {fmt(r.get('ci95_high'))}]",
            fmt(r.get("cohens_dz")), fmt(r.get("rms_pct")), fmt(r.get("max_pct")), fmt(r.get("normality_p")),
            fmt(r.get("tost_p")), fmt(bool(r["equivalent"])) if computed else "–",
        ])  # fmt: skip
    header = ["n", "pairing", "pairs", "excluded", "t-test p", "Wilcoxon p", "paper's verdict",
              "mean difference [95 % CI] (mm)", "Cohen's d_z", "RMS [% of depth range]",
              "max [% of depth range]", "normality p", "TOST p", "equivalent (5 %)"]  # fmt: skip
    return table(rows, header)


def _claims_table(d: dict[str, Any]) -> str:
    rows = []
    for _, r in d["claims"].iterrows():
        spec = ".3g"
        ours = fmt(r["ours"], spec)
        if pd.notna(r["ours_q1"]):
            ours = iqr(r["ours"], r["ours_q1"], r["ours_q3"], spec)
        unit = "" if r["unit"] in ("ratio", "fraction") else f" {r['unit']}"
        paper = str(r["paper"]) if pd.notna(r["paper"]) else "–"  # the paper's words, verbatim
        rows.append([r["claim"], paper, ours + unit, fmt(r["ratio_ours_to_paper"], spec),
                     f"**{r['verdict']}**", r["why"]])  # fmt: skip
    return table(rows, ["claim", "paper", "ours (median [IQR])", "ours / paper", "verdict", "why"], "lrrrll")


def _mc_iqr(mc: pd.DataFrame, n: int, name: str, scale: float = 1.0, spec: str = ".3g") -> str:
    r = _q(mc, n, name)
    return iqr(scale * r["median"], scale * r["q1"], scale * r["q3"], spec)


def _mc_tables(d: dict[str, Any]) -> tuple[str, str]:
    mc = d["montecarlo"]
    rows = []
    for n in sorted(mc["n"].unique()):
        rows.append(
            [str(n), _mc_iqr(mc, n, "adt_bytes", spec=".4g"), _mc_iqr(mc, n, "nurbs_bytes", spec=".4g"),
             _mc_iqr(mc, n, "size_ratio"), _mc_iqr(mc, n, "adt_s", 1e3),
             _mc_iqr(mc, n, "nurbs_geomdl_s", 1e3), _mc_iqr(mc, n, "nurbs_fast_s", 1e3),
             _mc_iqr(mc, n, "time_ratio_geomdl"), _mc_iqr(mc, n, "time_ratio_fast")]
        )  # fmt: skip
    header = ["n", "ADT file [bytes]", "NURBS file [bytes]", "ADT / NURBS", "ADT [ms]", "NURBS geomdl [ms]",
              "NURBS fast [ms]", "NURBS geomdl / ADT", "NURBS fast / ADT"]  # fmt: skip
    sizes = table(rows, header)
    rows = []
    kinds = ("t_similar", "wilcoxon_similar", "both_similar", "equivalent", "normal")
    for n in sorted(mc["n"].unique()):
        for prefix, pairing in (("a_", "nurbs-samples"), ("b_", "cloud-points")):
            f = {k: _q(mc, n, f"{prefix}{k}") for k in kinds}
            rows.append(
                [str(n), pairing, fmt(f["t_similar"]["count"], "int")]
                + [fmt(f[k]["fraction"], "pct") for k in kinds]
                + [_mc_iqr(mc, n, f"{prefix}rms_pct")]
            )
    header = ["n", "pairing", "clouds with tests", "t-test: similar", "Wilcoxon: similar", "both: similar",
              "TOST: equivalent", "normal differences", "RMS deviation [% of range]"]  # fmt: skip
    return sizes, table(rows, header)


def _formats_table(d: dict[str, Any]) -> str:
    sizes = d["sizes"]
    ns = list(d["clouds"]["n"])
    rows = []
    for (method, form), g in sizes.groupby(["method", "format"], sort=False):
        headline = " (headline)" if bool(g["headline"].iloc[0]) else ""
        rows.append(
            [f"{method}: {form}{headline}"] + [fmt(g[g["n"] == n]["bytes"].iloc[0], "int") for n in ns]
        )
    return table(rows, ["format"] + [f"n = {n} [bytes]" for n in ns])


def _storage_tables(d: dict[str, Any]) -> tuple[str, str]:
    """Ratios ADT / NURBS by family, coordinates and n (with verdicts), and bytes at the largest n."""
    storage, claims = d["storage"], d["claims"]
    ns = sorted(storage["n"].unique())
    kinds = [(k, text) for k, text in COORDINATES if (storage["coordinates"] == k).any()]
    rows, sizes = [], []
    for family, description in FAMILIES:
        for kind, kind_text in kinds:
            sel = storage[(storage["family"] == family) & (storage["coordinates"] == kind)].set_index("n")
            claim = claims[claims["claim"].str.startswith(f"ADT needs almost half the storage of NURBS: "
                                                          f"{description}, {kind_text}")]  # fmt: skip
            verdict = f"**{claim['verdict'].iloc[0]}**" if not claim.empty else "–"
            equal = "yes" if family in EQUAL_PRECISION else "no"
            rows.append([description, kind, equal]
                        + [iqr(sel.loc[n, "ratio"], sel.loc[n, "ratio_q1"], sel.loc[n, "ratio_q3"], ".2f")
                           for n in ns] + [verdict])  # fmt: skip
            big = sel.loc[ns[-1]]
            sizes.append([description, kind, fmt(big["adt_bytes"], "int"), fmt(big["nurbs_bytes"], "int"),
                          fmt(big["vertices"], "int"), fmt(big["triangles"], "int"),
                          fmt(big["control_points"], "int"), fmt(big["knots"], "int")])  # fmt: skip
    header = ["family", "coordinates", "equal precision", *(f"ADT / NURBS, n = {n}" for n in ns), "verdict"]
    ratios = table(rows, header, "lll" + "r" * len(ns) + "l")
    header = ["family", "coordinates", f"ADT [bytes], n = {ns[-1]}", f"NURBS [bytes], n = {ns[-1]}",
              "ADT vertices", "ADT triangles", "NURBS control points", "NURBS knots"]  # fmt: skip
    return ratios, table(sizes, header, "ll" + "r" * 6)


def _counts_paragraph(d: dict[str, Any]) -> str:
    """Why the families disagree, with the counts of the largest clouds."""
    storage = d["storage"]
    big = storage[storage["n"] == storage["n"].max()]
    parts = []
    for kind, _ in COORDINATES:
        rows = big[big["coordinates"] == kind]
        if rows.empty:
            continue
        r = rows.iloc[0]
        v, t, c, k = (float(r[q]) for q in ("vertices", "triangles", "control_points", "knots"))
        parts.append(
            f"with {kind} coordinates at n = {int(r['n'])}, an ADT file stores {fmt(v, 'int')} vertices (3 "
            f"numbers each) and {fmt(t, 'int')} triangles (3 indices each), {(3 * v + 3 * t) / v:.1f} "
            f"numbers per vertex, while a NURBS file stores {fmt(c, 'int')} control points (4 numbers each "
            f"with the weight) and {fmt(k, 'int')} knots, {(4 * c + k) / c:.1f} numbers per control point"
        )
    return (
        "Why the families disagree, in counts (medians): "
        + "; ".join(parts)
        + ". At equal bytes per number ADT is therefore about twice as large; it is smaller only where "
        "its numbers are much shorter than NURBS's, as integer-millimetre coordinates and small "
        "indices are in ASCII beside the long decimals of a grid over the cloud's bounding box. "
        "Continuous coordinates remove that advantage (compare the continuous rows)."
    )


def _paper_files(d: dict[str, Any]) -> str:
    """What the paper's 9-point file sizes suggest (the readings in the claims' explanations)."""
    claims = d["claims"].set_index("claim")
    found = []
    for label in ("ADT file size, 9 points", "NURBS file size, 9 points"):
        why = str(claims["why"].get(label, ""))
        reading = why[len(WHY_ABSOLUTE) :].lstrip("; ") if why.startswith(WHY_ABSOLUTE) else ""
        if reading:
            found.append(f"- {label.split(',')[0]}: {reading}.")
    if len(found) < 2:
        return ""
    return (
        "What the paper's 9-point files suggest about how they were written:\n\n" + "\n".join(found) + "\n\n"
        "The paper's ADT numbers were short and its NURBS numbers long, which suggests that its two "
        "files were not written at equal precision (headers or metadata the paper does not describe "
        "could account for part of the NURBS file too)."
    )


def _span(values: pd.Series, spec: str) -> str:
    """The range of ``values`` ("11-26"), or one value ("100") when both ends read the same."""
    low, high = format(values.min(), spec), format(values.max(), spec)
    return low if low == high else f"{low}-{high}"


def _exponent(exponent: float, stderr: float) -> str:
    """A growth exponent with its standard error, which a fit through two sizes does not have."""
    if not math.isfinite(float(stderr)):
        return f"{fmt(exponent, '.2f')} (too few sizes for a standard error)"
    return f"{fmt(exponent, '.2f')} ± {fmt(stderr, '.2f')}"


def _scale_tables(d: dict[str, Any]) -> tuple[str, str, str]:
    scale, growth, raw = d["scale"], d["growth"], d["scale_raw"]
    rows = [[str(r["n"]), r["method"], iqr(r["median"], r["q1"], r["q3"])] for _, r in scale.iterrows()]
    times = table(rows, ["n", "method", "build time [s] median [IQR]"])
    rows = [
        [r["method"], _exponent(r["exponent"], r["stderr"]),
         f"{fmt(r['n_min'], 'int')} to {fmt(r['n_max'], 'int')}"]
        for _, r in growth.iterrows()
    ]  # fmt: skip
    exps = table(rows, ["method", "growth exponent b (time ∝ n^b)", "fitted over n"])
    files = raw[raw["bytes"].notna()]
    rows = [[str(r["n"]), r["method"], fmt(r["bytes"], "int")] for _, r in files.iterrows()]
    return times, exps, table(rows, ["n", "file", "bytes"])


def _interpretation(d: dict[str, Any]) -> str:
    """A paragraph reading the Monte Carlo numbers (every number from the data)."""
    mc = d["montecarlo"]
    both = mc[mc["quantity"].isin(["a_both_similar", "b_both_similar"])]["fraction"].dropna()
    rms = mc[mc["quantity"].isin(["a_rms_pct", "b_rms_pct"])]["median"].dropna()
    peak = mc[mc["quantity"].isin(["a_max_pct", "b_max_pct"])]["median"].dropna()
    if both.empty or rms.empty:
        return ""
    return (
        "Both surfaces interpolate the same cloud, so their mean depth difference is close to zero by "
        f"construction: the paper's two tests fail to reject a difference for {_span(100 * both, '.0f')} "
        "% of the clouds, about the 95 % expected of tests at the 5 % level when "
        "there is no mean difference at all. That is what the paper reads as similarity, but it says "
        "nothing about how close the surfaces are: point by point they differ by a median RMS of "
        f"{_span(rms, '.0f')} % of the depth range (median maximum {_span(peak, '.0f')} %), far above "
        'the paper\'s "under 5 %". An equivalence test of the mean '
        "difference (TOST) is passed more often as n grows, because it tests the mean only."
    )


def _survival(d: dict[str, Any]) -> str:
    claims = d["claims"]

    def verdict(prefix: str) -> list[str]:
        return [
            f"{r['claim']}: **{r['verdict']}**" for _, r in claims.iterrows() if r["claim"].startswith(prefix)
        ]

    parts = verdict(STORAGE_HEADLINE) + verdict("ADT is almost 3 times") + verdict("t-test and Wilcoxon")
    parts += verdict("equivalent within") + verdict("deviation under 5")
    return "\n".join(f"- {p}" for p in parts)


def render_table1(out_dir: str | os.PathLike[str], *, workers: int = 1) -> Path:
    """Render ``table1.md`` and its figures from the saved data in ``out_dir``.

    The figures (Fig. 6, the scale sweep's and the 3-D views, about 2 s each) are drawn on up
    to ``workers`` processes at once (:func:`.parallel.run_figure_tasks`); the files are the
    same for any number.
    """
    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    d = load_table1_data(out)
    earlier = figure_files(out / "figures", "table1_")  # those not drawn again are an earlier run's
    prov, config = d["provenance"], d["provenance"]["config"]
    # the 3-D views take about as long as the two plots together: on two workers, this order
    # ends with both at once. One process draws them in this order too, so corrupt Monte Carlo
    # data are named before missing meshes, and missing meshes before corrupt scale data
    drawn = run_figure_tasks(
        [
            functools.partial(fig6, d["montecarlo"], out / "figures" / "table1_fig6"),
            functools.partial(_images, [int(n) for n in d["clouds"]["n"]], out),
            functools.partial(scale_figure, d["scale"], out / "figures" / "table1_scale"),
        ],
        workers=workers,
    )
    images, renderer = drawn[1]
    mc_sizes, mc_verdicts = _mc_tables(d)
    scale_times, scale_exps, scale_files = _scale_tables(d)
    storage_ratios, storage_sizes = _storage_tables(d)
    storage_claim = d["claims"][d["claims"]["claim"].str.startswith(STORAGE_HEADLINE)].iloc[0]
    box = config["box"]
    warmups = f"{config['warmup']} warm-up run{'' if config['warmup'] == 1 else 's'}"
    full_mark, quick_mark = ("", " (this report)") if config.get("quick") else (" (this report)", "")
    lattice = f"on a {config['step']:g} mm lattice" if config["step"] else "continuous"
    quick = (
        (
            "\n> **Quick run** (reduced repeats, seeds and scale sweep, and a coarser NURBS tessellation, "
            "for smoke testing): not the committed full run.\n"
        )
        if config.get("quick")
        else ""
    )
    text = f"""# Table 1 and Fig. 6: ADT versus NURBS

Generated by `replication table1` from the data in `data/table1_*.csv`; every number below is
read from those files (re-render with `replication report`). Do not edit by hand.
{quick}
## Does the paper's conclusion survive?

{_survival(d)}

{_interpretation(d)}

The details, the paper's numbers side by side and the reasons follow.

## Set-up

- **Clouds**: for each n, points drawn uniformly in the box x {box[0]:g}..{box[1]:g},
  y {box[2]:g}..{box[3]:g}, z {box[4]:g}..{box[5]:g} mm {lattice} (paper eq. 1-4). The paper's
  Table 1 domain is unstated ("a discretised domain"); this is the only domain the paper gives
  (section 6), and integer-mm coordinates come nearest to the size of its 9-point file (see
  "Storage"). Points that share an (x, y) node are merged by ADT's mean-depth policy (counted
  below). Table 1 uses one cloud per n, as the paper did; the Monte Carlo section repeats
  everything over {config["mc_seeds"]} clouds per n.
- **ADT**: paper section 3.2 steps 4-10 (`replication.adt`), depth axis by minimum spread.
- **NURBS**: paper section 3.1 (`replication.fit_nurbs`): degree {config["degree"]} (the paper says
  "the degree of the curve is taken as three", but its knot vectors have order 3: see the README), control net
  m_u x m_v = n where n factors near the cloud's aspect ratio, linear gridding (nodes outside the
  convex hull take the nearest point's depth), clamped uniform knots, weights 1, evaluated on a
  {config["tessellation"][0]} x {config["tessellation"][1]} tessellation with geomdl (the
  paper-faithful reference) or with the fast NdBSpline evaluator.
- **File sizes**: the headline formats of Table 1 are the most compact complete ASCII
  representation of each surface: legacy VTK for ADT, smesh for NURBS, both with shortest exact
  decimals. The storage claim is decided in four representation families, for these lattice
  clouds and for continuous clouds in the same box (section "Storage" below).
- **Times**: {config["repeats"]} repeats after {warmups}, all tasks interleaved
  in one process in rotating order; median [inter-quartile range]; ratios formed per repeat pair.
- **Statistics**: depths paired (a) at NURBS samples (a parameter grid the size of the net) and (b)
  at the cloud's distinct positions; the paper's t-test and Wilcoxon test at the {config["alpha"]:g}
  level, and a TOST equivalence test with a margin of {100 * config["margin_fraction"]:g} % of
  the depth range. The Wilcoxon test takes deviations that differ by no more than float64
  rounding (1e-12 of the depth range plus 64 machine epsilons of the depths' size) as tied,
  and such deviations from zero as zero, so that its ranks do not depend on the cloud's units
  or offset; on these lattice clouds that restores ties that rounding had split.

## Table 1: one cloud per n, as in the paper

Surfaces (rendered with {renderer}; ADT gold with edges, NURBS blue):

{images}

Sizes and counts (data: `data/table1_clouds.csv`, `data/table1_sizes.csv`; the files measured, ADT
`.vtk` and NURBS `.smesh`, and the NURBS tessellation drawn, in `data/table1_meshes/`):

{_sizes_table(d)}

Computation time, median [IQR] (data: `data/table1_timings.csv`, raw: `data/table1_timings_raw.csv`):

{_timing_table(d)}

Paired statistics (data: `data/table1_stats.csv`). "Paper's verdict" is the paper's reading: similar
when neither test rejects at the 5 % level. Failing to reject is not evidence of similarity; the
equivalence test (TOST) is the test that can show it, and it concerns the *mean* difference: RMS and
maximum deviations show how far apart the surfaces are point by point.

{_stats_table(d)}

## The paper's numbers beside ours

(data: `data/table1_claims.csv`; sizes are Monte Carlo medians, times come from the interleaved
harness on the Table 1 cloud.)

{_claims_table(d)}

## Storage: four representation families, two kinds of coordinates

The paper does not say how its files were written, and a size ratio depends on the
representation as much as on the method. Both surfaces of every Monte Carlo cloud are measured
in four families that treat the two methods alike:

- **shortest exact ASCII**: compact legacy VTK / compact smesh, every number with the shortest
  decimal that reads back exactly (Table 1's headline formats);
- **6 significant digits**: the same formats with every number at 6 significant digits (C's `%g`,
  trailing zeros dropped), the same digits for both methods;
- **float32 binary**: complete raw files, float32 numbers and int32 indices (ADT: two counts,
  x y z per vertex, three indices per triangle; NURBS: degrees and net size, knots, x y z w per
  control point);
- **information floor**, float32, for a reader who knows the method: ADT stores its vertices
  only (the triangles are recomputed, ADT being a deterministic function of the points); NURBS
  its control net (x y z) and knots (weights are all 1). Were the knots recomputed too, NURBS
  would lose 4 bytes per knot; were the net's x, y recomputed from its uniform grid, NURBS would
  need only 4 bytes per control point plus 16, a third of ADT's floor.

Clouds: the lattice clouds of this experiment (integer millimetres) and continuous clouds in the
same box (points not on a lattice, as scanned clouds are), {config["mc_seeds"]} of each per n.
ADT / NURBS file size, median [IQR] over the clouds (data: `data/table1_storage.csv`, raw:
`data/table1_storage_raw.csv`); the verdict per row follows the rules of the claims table:

{storage_ratios}

**{storage_claim["claim"]}: {storage_claim["verdict"]}**, {storage_claim["why"]}.

{_counts_paragraph(d)} Counts and bytes at the largest n (medians):

{storage_sizes}

{_paper_files(d)}

## Fig. 6

![Fig. 6: storage and computation time against n](figures/table1_fig6.png)

([SVG](figures/table1_fig6.svg).) Markers: Monte Carlo medians; bars: inter-quartile range over the
clouds; open squares: the paper's 9-point values (its 200-point values are given only as
differences, which the table above compares).

## Monte Carlo: {config["mc_seeds"]} clouds per n

Sizes and single-shot build times per cloud, median [IQR] (data: `data/table1_montecarlo.csv`,
raw: `data/table1_montecarlo_raw.csv`):

{mc_sizes}

How often each test reaches each conclusion (clouds whose pairing had at least 3 pairs):

{mc_verdicts}

## All file formats (Table 1 clouds)

(data: `data/table1_sizes.csv`.) The raw binary and information-floor rows follow the families of
the storage section above.

{_formats_table(d)}

## Scale sweep

Continuous clouds (so that points stay distinct) in the same box; build times, median [IQR]
over {config["scale_repeats"]} interleaved repeats (data: `data/table1_scale.csv`). The times are
this run's and move with the machine's state between runs (on a shared virtual machine, by tens
of per cent for the same code): compare the ratios and growth exponents within one run, and see
asv's record (performance.md) for the history of a time.

{scale_times}

![Scale sweep](figures/table1_scale.png)

([SVG](figures/table1_scale.svg); per-repeat times: `data/table1_scale_raw.csv`.)

Growth exponents from a least-squares fit of log(time) on log(n) (data: `data/table1_growth.csv`):

{scale_exps}

File sizes at scale:

{scale_files}

## Reproduce

```bash
replication table1            # the full run{full_mark}, then renders it
replication table1 --quick    # a reduced run for smoke testing (under a minute){quick_mark}
replication report            # re-render the markdown and figures from data/ only
```

{provenance_section(prov, "data/table1_provenance.json")}
"""
    path = out / "table1.md"
    write_report(path, text)
    clear_figures(out / "figures", "table1_", before=earlier)  # no earlier run's figure stays beside these
    return path
