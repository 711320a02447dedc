"""``reports/index.md``: links to every report that exists, with its headline verdicts."""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from replication.errors import CloudFileError
from replication.experiments.paper import PAPER_TABLE1
from replication.experiments.table1_claims import STORAGE_HEADLINE
from replication.io.atomic import atomic_write_text
from replication.report.casestudy_validation import validation_headline
from replication.report.markdown import write_report
from replication.report.pages import is_ours
from replication.report.settings import TITLES, describe, saved_settings, settings_note
from replication.report.store import read_csv, read_provenance

__all__ = ["REPORTS", "fill_block", "has_block", "headline", "render_index", "update_readme"]

START, END = "<!-- headline:start -->", "<!-- headline:end -->"

#: (file, title, what it reproduces)
REPORTS: tuple[tuple[str, str, str], ...] = (
    (
        "table1.md",
        "Table 1 and Fig. 6",
        "ADT vs NURBS: file size, computation time, paired statistics (sections 4-5)",
    ),
    (
        "casestudy.md",
        "Figs. 8 and 9",
        "the water-jet case study: force model and genetic algorithm (section 6)",
    ),
    (
        "sph.md",
        "The case study on a real SPH solver",
        "SPlisHSPlasH: convergence, and the paper's forces examined (section 6)",
    ),
    (
        "jet_validation.md",
        "The thin-sheet jet model checked against SPH",
        "37 surfaces (plates, cups, the GA's winners, random lattices) ranked by both (section 6)",
    ),
    (
        "performance.md",
        "Performance history",
        "asv benchmarks of ADT, NURBS and the case study across commits",
    ),
)


def _claim(claims: pd.DataFrame, prefix: str) -> pd.Series | None:
    rows = claims[claims["claim"].str.startswith(prefix)]
    return None if rows.empty else rows.iloc[0]


def _mc(mc: pd.DataFrame, n: int, quantity: str, column: str = "median") -> float:
    rows = mc[(mc["n"] == n) & (mc["quantity"] == quantity)]
    return float(rows.iloc[0][column]) if not rows.empty else float("nan")


def _storage_and_speed(claims: pd.DataFrame, mc: pd.DataFrame, n: int) -> list[str]:
    """The storage and speed lines, from the claims' verdicts and explanations."""
    storage = _claim(claims, STORAGE_HEADLINE)
    geomdl = _claim(claims, "ADT is almost 3 times faster than NURBS (geomdl")
    fast = _claim(claims, "ADT is almost 3 times faster than NURBS (fast")
    if storage is None or geomdl is None or fast is None:
        return _storage_and_speed_before_families(claims, n)
    return [
        f"- **Storage** (ADT/NURBS file size, medians over random clouds; the paper says "
        f"{storage['paper']}): **{storage['verdict']}** {storage['why']}.",
        f"- **Speed** (NURBS/ADT build time, median at n = {n}; decided over n = "
        f"{int(mc['n'].min())}..{n}): {geomdl['ours']:.0f}x with geomdl, "
        f"{fast['ours']:.1f}x with a fast NURBS evaluator; the paper says {geomdl['paper']}: "
        f"**{geomdl['verdict']}** / **{fast['verdict']}**{_by_n_note(fast, 'the fast evaluator')}.",
    ]


def _by_n_note(claim: pd.Series, what: str) -> str:
    """ " (<what>, verdicts by n: ...)" when some n could not be decided, else nothing."""
    why = str(claim["why"])
    marker = "verdicts by n: "
    if marker not in why or "cannot be decided" not in why.split(marker, 1)[1]:
        return ""
    return f" ({what}, {why.split(marker, 1)[1]})"


def _storage_and_speed_before_families(claims: pd.DataFrame, n: int) -> list[str]:
    """The same lines for report data written before the storage families existed."""
    size = _claim(claims, "ADT needs about half")
    geomdl = _claim(claims, "ADT is about 3 times faster than NURBS (geomdl")
    fast = _claim(claims, "ADT is about 3 times faster than NURBS (fast")
    if size is None or geomdl is None or fast is None:
        return []
    return [
        f"- **Storage** (ADT/NURBS file size, compact ASCII, median over random clouds at "
        f"n = {n}): {size['ours']:.2f}; the paper says about half: **{size['verdict']}** (the "
        "ratio swings with n because ASCII sizes depend on the decimals of the NURBS grid).",
        f"- **Speed** (NURBS/ADT build time at n = {n}): {geomdl['ours']:.0f}x with geomdl, "
        f"{fast['ours']:.1f}x with a fast NURBS evaluator; the paper says about 3x: "
        f"**{geomdl['verdict']}** / **{fast['verdict']}**.",
    ]


#: Each experiment's data set (its provenance's prefix) and the command that makes it again.
_DATA_SETS = (
    ("table1", "replication table1"),
    ("sph", "replication sph"),
    ("jet_validation", "replication validate-jet"),
    ("casestudy", "replication casestudy"),
)


def headline(out_dir: str | os.PathLike[str]) -> list[str]:
    """A few sentences of headline results, every number read from the reports' data.

    Each data set is first checked against the checksums its save recorded
    (:func:`~replication.report.store.read_provenance`): ``sph`` or ``table1`` refresh the
    README's headline from every experiment's data, not only their own.
    """
    data = Path(out_dir) / "data"
    for prefix, command in _DATA_SETS:
        if (data / f"{prefix}_provenance.json").is_file():
            read_provenance(data, f"{prefix}_provenance.json", command)
    lines: list[str] = _not_the_papers(data)
    # tables without their provenance (a save cut short, a removed file) are not drawn: unchecked
    if (data / "table1_claims.csv").is_file() and (data / "table1_provenance.json").is_file():
        claims, mc = read_csv(data / "table1_claims.csv"), read_csv(data / "table1_montecarlo.csv")
        n = int(mc["n"].max())
        lines += _storage_and_speed(claims, mc, n)
        similar = _mc(mc, n, "b_both_similar", "fraction")
        equivalent = _mc(mc, n, "b_equivalent", "fraction")
        rms = _mc(mc, n, "b_rms_pct")
        lines.append(
            f"- **Similarity**: at the cloud's points (n = {n}) the paper's t-test and Wilcoxon test find "
            f"the surfaces 'similar' for {100 * similar:.0f} % of clouds and TOST shows their mean depths "
            f"equivalent within 5 % for {100 * equivalent:.0f} %, but the RMS deviation is {rms:.0f} % of "
            f"the depth range (the paper says {PAPER_TABLE1['deviation_pct']}): the surfaces agree on "
            "average, not point by point."
        )
        scale = read_csv(data / "table1_scale.csv")
        big = scale[scale["method"] == "ADT (sweephull)"].sort_values("n").iloc[-1]
        lines.append(f"- **ADT at scale**: {int(big['n']):,} points in {big['median']:.2f} s (median).")
    if (data / "casestudy_shapes.csv").is_file() and (data / "casestudy_provenance.json").is_file():
        shapes = read_csv(data / "casestudy_shapes.csv").set_index("shape")
        runs = read_csv(data / "casestudy_runs.csv")
        flat, bucket = shapes.loc["flat plate"], shapes.loc["pelton bucket"]
        validated = validation_headline(out_dir)  # issue 11: which fitness, and SPH beside it
        fitness = ", thin-sheet model" if validated else ""
        lines.append(
            f"- **Case study** (half jet{fitness}): flat plate {flat['axial_N']:.2f} N, bucket "
            f"{bucket['axial_N']:.2f} N, best GA surfaces {runs['best_N'].min():.2f}-"
            f"{runs['best_N'].max():.2f} N; the paper's SPH "
            f"gives {_paper_force(flat)} and {_paper_force(bucket)}, above the momentum bound "
            "2 rho Q V of any steady jet force, so its forces cannot be reproduced by a momentum balance."
        )
        lines += validated
    return lines


def _not_the_papers(data: Path) -> list[str]:
    """A first headline line naming the data sets made with other settings than the paper's
    (a quick run's numbers are not findings), or none."""
    others = []
    for prefix, _ in _DATA_SETS:
        settings = saved_settings(data, prefix)
        if settings:
            others.append(f"the {TITLES[prefix]} with {describe(settings)}")
    if not others:
        return []
    return [
        f"- *Not the paper's settings*: {'; '.join(others)}. Numbers drawn from "
        f"{'it' if len(others) == 1 else 'them'} are a trial's, not the replication's findings."
    ]


def _paper_force(shape: pd.Series) -> str:
    """The paper's SPH force of a reference shape, verbatim ("21.96 N")."""
    if "paper_sph" in shape.index:
        return str(shape["paper_sph"])
    return f"{shape['paper_sph_N']:.2f} N"  # report data written before the verbatim column


def update_readme(readme: str | os.PathLike[str], out_dir: str | os.PathLike[str]) -> Path:
    """Replace the block between the headline markers of a README with :func:`headline`.

    The README keeps its line ends (CRLF stays CRLF) and, when it is a symbolic link, stays
    one: the file it points to is rewritten.
    """
    return fill_block(readme, START, END, headline(out_dir))


def has_block(readme: str | os.PathLike[str], start: str, end: str) -> bool:
    """Whether ``readme`` holds a ``start ... end`` block.

    Parameters
    ----------
    readme : path
    start, end : str
        The block's marker lines.

    Returns
    -------
    bool
        False also when the file cannot be read as UTF-8 text.
    """
    try:
        text = Path(readme).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return start in text and end in text and text.index(start) < text.index(end)


def fill_block(readme: str | os.PathLike[str], start: str, end: str, lines: list[str]) -> Path:
    """Replace the lines between the markers ``start`` and ``end`` of a README with ``lines``.

    The README keeps its line ends (CRLF stays CRLF) and, when it is a symbolic link, stays
    one: the file it points to is rewritten.

    Parameters
    ----------
    readme : path
    start, end : str
        The block's marker lines.
    lines : list of str
        The block's new content (an item may hold several lines).

    Returns
    -------
    Path
        ``readme``.

    Raises
    ------
    CloudFileError
        When the README has no such block.
    """
    path = Path(readme).resolve()  # a link's target, not the link replaced by a file
    with open(path, encoding="utf-8", newline="") as stream:  # newline="": \r\n read as written
        text = stream.read()
    if start not in text or end not in text or text.index(end) < text.index(start):
        raise CloudFileError(f"{path} has no {start} ... {end} block to fill")
    before, rest = text.split(start, 1)
    after = rest.split(end, 1)[1]
    newline = "\r\n" if "\r\n" in before + after else "\n"
    block = newline.join([start, *"\n".join(lines).split("\n"), end])
    atomic_write_text(path, before + block + after)
    return Path(readme)


def render_index(out_dir: str | os.PathLike[str]) -> Path:
    """Write ``index.md`` linking the reports present in ``out_dir``."""
    out = Path(out_dir)
    lines = [
        "# Reports",
        "",
        "Every report is generated by the committed code. The paper's reports come from `replication",
        "reproduce`, and each states the command, commit, software, machine, seeds and run time that",
        "made it; the performance history comes from asv's results (`replication report --performance`)",
        "and names the machine and commit of every value. Their data lie under `data/` as CSV.",
        "",
    ]
    for name, title, what in REPORTS:
        if (out / name).is_file() and is_ours(out / name):  # not a file of somebody else's of that name
            prefix = name.removesuffix(".md")
            note = "" if name == "performance.md" else settings_note(out / "data", prefix)
            if name != "performance.md" and not (out / "data" / f"{prefix}_provenance.json").is_file():
                note = (
                    " (*out of date*: its data under data/ have no provenance, so it is not drawn from them)"
                )
            lines.append(f"- [{title}]({name}): {what}{note}")
        else:
            lines.append(f"- {title}: {what} - *not generated yet*")
    lines += ["", "## Headline results", "", *headline(out)]
    claims = out / "data" / "table1_claims.csv"
    if claims.is_file():
        frame = read_csv(claims)
        lines += ["", "## Table 1 at a glance", ""]
        for _, r in frame.iterrows():
            if r["verdict"] != "cannot be compared":
                lines.append(f"- {r['claim']}: **{r['verdict']}**")
    return write_report(out / "index.md", "\n".join(lines) + "\n")
