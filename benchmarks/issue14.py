"""Measure the kernel rows of issue 14 side by side, in one run: ``python -m benchmarks.issue14``.

Each row is timed in alternation with its reference in the same process (median and
inter-quartile range over ``--repeats`` pairs; ratios are formed per pair), so that the load
of a shared machine affects both alike. Peak memory is the maximum resident size of a fresh
process that loads the cloud (saved as .npy) and builds its ADT surface. CPU time (all
threads) is printed next to wall time: when the machine is loaded, wall time shows the
contention, CPU time the work. The 1e7 row also shows the kernel's (system) share of the CPU
time, and the ratio of user CPU times: the pages a 1e7 call takes fresh from the kernel at
every call are most of what its time adds to ten times the 1e6 time.
``--quick`` skips the 1e7-point rows. Prints a markdown table on stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

_PEAK = """
import json, resource, sys
import numpy as np
from replication.surfaces import adt


def high_water():
    # this process's own peak: on Linux, ru_maxrss carries the parent's peak over fork and
    # exec (a parent holding a 1e7 cloud read as this child's 'peak'); VmHWM is the peak of
    # the address space the exec made
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024  # macOS counts bytes, the others KiB


cloud = np.load(sys.argv[1])  # the cloud only: its generation has temporaries of its own
before = high_water()
adt(cloud)
after = high_water()
gib = {"cloud_gib": cloud.nbytes / 2**30, "before_gib": before / 2**30, "peak_gib": after / 2**30}
print(json.dumps(gib))
"""


def adt_peak(cloud: np.ndarray) -> dict[str, float]:
    """Peak resident size (GiB) of a fresh process that loads ``cloud`` and builds its ADT
    surface: ``peak_gib``, with ``before_gib`` (the process with the cloud loaded) and
    ``cloud_gib``. The caller's own memory does not count, however large."""
    with tempfile.TemporaryDirectory() as scratch:
        path = f"{scratch}/cloud.npy"
        np.save(path, cloud)
        done = subprocess.run([sys.executable, "-c", _PEAK, path], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def _cloud(n: int) -> np.ndarray:
    from replication.surfaces import random_cloud

    return random_cloud(n, rng=np.random.default_rng([1234, n]))


def _timed(task) -> tuple[float, float, float]:
    """Wall time, CPU time of this process (all threads) and the kernel's share of that CPU
    time (system time: page faults of fresh memory, mostly)."""
    w, c, k = time.perf_counter(), time.process_time(), os.times().system
    task()
    return time.perf_counter() - w, time.process_time() - c, os.times().system - k


def _pairs(first, second, repeats: int) -> dict[str, np.ndarray]:
    """Wall and CPU times of ``first`` and ``second``, alternately (the order swaps every
    repeat), ``repeats`` times."""
    rows = []
    for r in range(repeats):
        if r % 2 == 0:
            a = _timed(first)
            b = _timed(second)
        else:
            b = _timed(second)
            a = _timed(first)
        rows.append((*a, *b))
    t = np.array(rows)
    names = ("first", "first_cpu", "first_sys", "second", "second_cpu", "second_sys")
    return {name: t[:, k] for k, name in enumerate(names)}


def _summary(values: np.ndarray, scale: float = 1.0, digits: int = 3) -> str:
    q1, med, q3 = np.percentile(np.asarray(values) * scale, [25, 50, 75])
    return f"{med:.{digits}g} (IQR {q1:.{digits}g}-{q3:.{digits}g})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="timed pairs per row (default 7)")
    parser.add_argument("--quick", action="store_true", help="skip the 1e7-point rows")
    args = parser.parse_args(argv)
    from benchmarks.common import warn_if_stale_kernels

    warn_if_stale_kernels()

    import warnings

    import triangle

    from replication.casestudy.ga import GAConfig, points_from_genome
    from replication.casestudy.jet import surface_force
    from replication.casestudy.shapes import pelton_bucket_surface
    from replication.errors import DuplicatePointsWarning
    from replication.kernels import warm_up
    from replication.surfaces import adt
    from replication.surfaces.nurbs import fit_nurbs

    warnings.simplefilter("ignore", DuplicatePointsWarning)  # lattice GA clouds
    warm_up()
    rows = []
    million = _cloud(1_000_000)
    uv = {"vertices": np.ascontiguousarray(adt(million).projected())}
    triangle.triangulate(uv)
    t = _pairs(lambda: triangle.triangulate(uv), lambda: adt(million), args.repeats)
    measured = (
        f"adt {_summary(t['second'])} s (CPU {_summary(t['second_cpu'])}); Triangle {_summary(t['first'])} s"
    )
    ratio = f"Triangle / adt = {_summary(t['first'] / t['second'])}x"
    rows.append(("adt() 1e6 points vs Triangle (same projection)", measured, ratio, ">= 3x"))
    adt_1e6 = t["second"]

    if not args.quick:
        ten = _cloud(10_000_000)
        adt(ten)
        t = _pairs(lambda: adt(ten), lambda: adt(million), max(3, args.repeats // 2))
        peak = adt_peak(ten)
        measured = (
            f"{_summary(t['first'])} s (CPU {_summary(t['first_cpu'])} s, of which system "
            f"{_summary(t['first_sys'])} s; at 1e6 {_summary(t['second_sys'])} s); peak "
            f"{peak['peak_gib']:.2f} GiB (cloud {peak['cloud_gib']:.2f} GiB, "
            f"process with the cloud loaded {peak['before_gib']:.2f} GiB)"
        )
        user = (t["first_cpu"] - t["first_sys"]) / (t["second_cpu"] - t["second_sys"])
        # the 1e7 call's arrays are above malloc's mmap threshold: fresh pages from the kernel at
        # every call, which the 1e6 call (its memory recycled by malloc) does not pay
        ratio = f"1e7 / 1e6 time = {_summary(t['first'] / t['second'])}x; user CPU {_summary(user)}x"
        rows.append(("adt() 1e7 points", measured, ratio, "<= 11x, <= 1.5 GiB"))
        del ten

    small = _cloud(200)
    number = 2000
    t = _pairs(lambda: [adt(small) for _ in range(number)], lambda: None, args.repeats)
    rows.append(("adt() 200 points", f"{_summary(t['first'], 1e3 / number)} ms "
                 f"(CPU {_summary(t['first_cpu'], 1e3 / number)} ms)", "", "<= 0.1 ms"))  # fmt: skip

    fit_nurbs(million, evaluator="fast")
    t = _pairs(lambda: fit_nurbs(million, evaluator="fast"), lambda: adt(million), args.repeats)
    measured = f"{_summary(t['first'])} s (CPU {_summary(t['first_cpu'])})"
    ratio = f"fit_nurbs / adt = {_summary(t['first'] / t['second'])}x"
    rows.append(("fit_nurbs(evaluator='fast') 1e6 points", measured, ratio, "<= 1.5x"))

    surfaces = [pelton_bucket_surface()]
    rng = np.random.default_rng(1234)
    surfaces += [adt(points_from_genome(rng.integers(0, [37, 31, 14] * 101), GAConfig()), depth="z")
                 for _ in range(9)]  # fmt: skip
    number = 100
    t = _pairs(
        lambda: [surface_force(s) for s in surfaces for _ in range(number)], lambda: None, args.repeats
    )
    per = 1e3 / (number * len(surfaces))
    measured = f"{_summary(t['first'], per)} ms (CPU {_summary(t['first_cpu'], per)} ms)"
    rows.append(("surface_force, 101-point surfaces (bucket + 9 random GA ones)", measured, "", "<= 1 ms"))

    print("| row | measured (median, IQR over repeats) | side by side | goal |")
    print("|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"\n{args.repeats} repeats; adt 1e6 median {np.median(adt_1e6):.3f} s; load average {load} on "
          f"{os.cpu_count()} CPUs (wall times above CPU times: other processes competed).")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
