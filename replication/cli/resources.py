"""Resources a command will need, checked before it starts: memory for NURBS samples or a random cloud."""

from __future__ import annotations

__all__ = [
    "BYTES_PER_COMPARE_SAMPLE",
    "BYTES_PER_POINT",
    "BYTES_PER_SAMPLE",
    "BYTES_PER_WRITTEN_POINT",
    "available_memory",
    "check_compare_samples",
    "check_random_cloud",
    "check_tessellation",
]

#: Peak memory per tessellation sample in bytes: the growth of the peak resident size from
#: 2 x 2 to 1000 x 1000 samples (``/usr/bin/time``), rounded up; geomdl keeps every point as a
#: Python list of floats (435 measured), the fast evaluator numpy arrays (52 measured).
BYTES_PER_SAMPLE = {"geomdl": 450, "fast": 56}

#: Peak memory per sample of ``compare --samples``: the growth of the peak resident size from
#: 2 x 2 to 2000 x 2000 samples on a 1000-point cloud (156 measured), rounded up.
BYTES_PER_COMPARE_SAMPLE = 160

#: Growth of a command's peak memory per point of the cloud (which itself is 24 bytes a point),
#: rounded up: what the process needs beyond what it holds when it checks (``/usr/bin/time``:
#: adt 102-108 from 2 to 4 million points, 1.17 GiB in all at 1e7; nurbs 834 and compare 1425
#: from 200,000 to 1 million points). The adt figure was the peak over the point count (265),
#: which counted the interpreter's own memory and refused runs that fit.
BYTES_PER_POINT = {"adt": 128, "nurbs": 1000, "compare": 1700}
#: Added per point when the points are also written: the legacy ASCII VTK writer holds the
#: whole text (790 measured, VTP 190, a CSV cloud 390).
BYTES_PER_WRITTEN_POINT = 800


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux MemAvailable), or None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        import os

        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def _size(n: float) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} PiB"  # pragma: no cover


def _check_fits(need: int, what: str, detail: str, remedy: str) -> None:
    """Refuse, before any work, what needs ``need`` bytes when less memory is available."""
    from replication.errors import InputError

    available = available_memory()
    if available is not None and need > available:
        raise InputError(
            f"{what} needs about {_size(need)} of memory ({detail}), but {_size(available)} is available: "
            f"{remedy}"
        )


def check_tessellation(shape: tuple[int, int], evaluator: str) -> None:
    """Refuse, before any work, a tessellation whose samples cannot fit in the available memory."""
    s_u, s_v = shape
    per_sample = BYTES_PER_SAMPLE[evaluator]
    detail = f"{s_u * s_v:,} samples x {per_sample} bytes with the {evaluator} evaluator"
    _check_fits(s_u * s_v * per_sample, f"--tessellation {s_u}x{s_v}", detail, "choose fewer samples")


def check_compare_samples(shape: tuple[int, int]) -> None:
    """Refuse, before any work, ``compare --samples`` that cannot fit in the available memory."""
    s_u, s_v = shape
    detail = f"{s_u * s_v:,} samples x {BYTES_PER_COMPARE_SAMPLE} bytes"
    _check_fits(
        s_u * s_v * BYTES_PER_COMPARE_SAMPLE, f"--samples {s_u}x{s_v}", detail, "choose fewer samples"
    )


def check_random_cloud(n: int, command: str, writes_points: bool) -> None:
    """Refuse, before the cloud is drawn, ``--random N`` whose pipeline cannot fit in memory.

    ``writes_points``: the points are also written (a surface file or ``--save-cloud``).
    """
    per_point = BYTES_PER_POINT.get(command, max(BYTES_PER_POINT.values()))
    per_point += BYTES_PER_WRITTEN_POINT if writes_points else 0
    detail = f"{n:,} points x {per_point} bytes for {command}{' and writing them' if writes_points else ''}"
    _check_fits(n * per_point, f"--random {n}", detail, "choose fewer points")
