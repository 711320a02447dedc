"""``replication compare``: paired statistics of ADT vs NURBS depths (paper section 4)."""

from __future__ import annotations

import argparse
from typing import Any

from replication.cli.common import about_the_input, emit_json, frame_kwargs, load_or_generate, relay_warnings
from replication.cli.files import check_outputs, save_generated_cloud, write_all_or_none
from replication.cli.resources import check_compare_samples

__all__ = ["EPILOG_COMPARE", "cmd_compare"]

EPILOG_COMPARE = """\
examples:
  replication compare cloud.csv
  replication compare --random 200 --seed 1 --step 1 --json

Two pairings of depths at the same position: (a) nurbs-samples, at points evaluated on the
NURBS surface (ADT depth by barycentric interpolation; samples outside the ADT footprint are
excluded), and (b) cloud-points, at the cloud's own positions (NURBS depth by Newton
inversion to 1e-9). For each: the paper's paired t-test and Wilcoxon signed-rank test with
its verdict ("similar" when both tests fail to reject), and what that logic lacks: the mean
difference (ADT - NURBS) with its 95 % confidence interval, Cohen's d_z, RMS and maximum
deviation as a percentage of the depth range, a normality check, and a TOST equivalence
test with a margin of 5 % of the depth range.
"""


def _format_stats(name: str, pairs: Any, st: Any) -> list[str]:
    head = f"pairing {name}: {pairs.n} pairs of {pairs.n_candidates}"
    excluded = pairs.n_outside_adt + pairs.n_outside_nurbs
    if excluded:
        where = "ADT" if pairs.n_outside_adt else "NURBS"
        head += f" ({excluded} outside the {where} footprint, excluded)"
    if st is None:
        return [head, "  too few pairs for the tests (need 3)"]
    lo, hi = st.ci95
    rounding = []
    if st.rounding_only:
        rounding = [
            f"  note               every deviation is at most {st.max_abs:.2g}, float64 rounding of depths "
            f"of range {st.depth_range:.4g} and size {st.magnitude:.4g} (up to {st.rounding_tolerance:.2g}): "
            "the surfaces agree, and both tests take rounding for no difference (on the raw noise the "
            "paper's t-test rejects or not with the units); the mean difference, its interval and d_z "
            "below are those of the noise"
        ]

    def reading(similar: bool) -> str:
        return f"{'fails to reject' if similar else 'rejects'} at alpha = {st.alpha:g}"

    why = (
        "neither test rejects" if st.paper_verdict == "similar"
        else "both tests reject" if not (st.t_test.similar or st.wilcoxon.similar)
        else f"the {'t-test' if not st.t_test.similar else 'Wilcoxon test'} rejects"
    )  # fmt: skip
    return [
        head,
        f"  paired t-test      t = {st.t_test.statistic:.4g}, p {_p(st.t_test.p_value, '.4g')}  -> "
        f"{reading(st.t_test.similar)}",
        f"  Wilcoxon test      W = {st.wilcoxon.statistic:.4g}, p {_p(st.wilcoxon.p_value, '.4g')}  -> "
        f"{reading(st.wilcoxon.similar)}",
        f"  paper's verdict    {st.paper_verdict} ({why}; 'similar' needs both to fail to reject)",
        *rounding,
        f"  mean difference    {st.mean_difference:.4g} (ADT - NURBS; 95% CI {lo:.4g} to {hi:.4g}), "
        f"Cohen's d_z {st.cohens_dz:.3g}" + (" (rounding noise)" if st.rounding_only else ""),
        f"  deviation          RMS {st.rms:.4g} ({st.rms_percent:.1f}% of depth range), "
        f"max {st.max_abs:.4g} ({st.max_abs_percent:.1f}%)",
        f"  normality          {st.normality_test} p {_p(st.normality_p, '.3g')} -> "
        f"use the {st.recommended_test}",
        f"  equivalence (TOST) margin +-{st.margin:.4g} ({100 * st.margin_fraction:g}% of range): "
        f"p {_p(st.tost_p, '.3g')} -> {'equivalent' if st.equivalent else 'NOT shown equivalent'}",
    ]


#: The smallest positive normal double: a p-value of 0.0 underflowed below it.
_TINY = 2.2250738585072014e-308


def _p(value: float, spec: str) -> str:
    """ "= 0.0312", or "< 2.2e-308" for a p-value that underflowed to 0 (it is not zero)."""
    return f"< {_TINY:.2g}" if value == 0 else f"= {value:{spec}}"


def cmd_compare(args: argparse.Namespace) -> int:
    from replication.cli import progress
    from replication.cli.progress import stage
    from replication.compare import compare

    check_outputs(args)
    if args.samples is not None:  # was: "unexpected MemoryError" after building both surfaces
        check_compare_samples(args.samples)
    with relay_warnings():
        cloud, source, meta = load_or_generate(args)
        # 20 s at a million points: said as adt and nurbs say their long steps (stderr)
        comparing = f"building both surfaces of {len(cloud):,} points and comparing their depths"
        with about_the_input(args), stage(comparing, shown=len(cloud) >= progress.LARGE_CLOUD):
            result = compare(
                cloud,
                degree=args.degree,
                net=args.net,
                sample_shape=args.samples,
                margin_fraction=args.margin,
                alpha=args.alpha,
                **frame_kwargs(args),
            )
    write_all_or_none((args.save_cloud, lambda: save_generated_cloud(cloud, args, meta)))
    m_u, m_v = result.nurbs.patch.net_shape
    pairings: dict[str, Any] = {}
    for name, p in result.pairings.items():
        st = result.statistics[name]
        pairings[name] = {
            "pairs": p.n,
            "candidates": p.n_candidates,
            "outside_adt": p.n_outside_adt,
            "outside_nurbs": p.n_outside_nurbs,
            "statistics": None if st is None else st.as_dict(),
        }
    report: dict[str, Any] = {
        "input": source,
        "points": int(cloud.shape[0]),
        "points_merged": result.adt.n_merged,
        "depth_axis": result.adt.depth_axis_name,
        "depth_range": result.depth_range,
        "adt": {"vertices": result.adt.n_vertices, "triangles": result.adt.n_triangles},
        "nurbs": {"degree": args.degree, "net": [m_u, m_v], "net_rule": result.nurbs.net.rule},
        "alpha": args.alpha,
        "margin_fraction": args.margin,
        "differences": "ADT depth - NURBS depth at each pair",
        "pairings": pairings,
        **meta,
    }
    if args.json:
        emit_json(report)
        return 0
    print(
        f"ADT vs NURBS for {source}: depth axis {report['depth_axis']}, "
        f"depth range {result.depth_range:.4g}; NURBS degree {args.degree}, {m_u} x {m_v} net"
    )
    if result.adt.n_merged:  # the net counts every point (Table 1's rule), merged or not: say so
        print(
            f"merged {result.adt.n_merged} point(s) sharing a projected position (policy {args.duplicates}); "
            f"the NURBS net is sized by all {cloud.shape[0]} points of the cloud"
        )
    for name in result.pairings:
        print("\n".join(_format_stats(name, result.pairings[name], result.statistics[name])))
    if "cloud_file" in meta:
        print(f"wrote the cloud to {meta['cloud_file']} ({meta['cloud_bytes']:,} bytes)")
    return 0
