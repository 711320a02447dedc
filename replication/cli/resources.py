"""Resources a command will need, checked before it starts: memory for NURBS samples or a random cloud."""

from __future__ import annotations

import os

__all__ = [
    "BYTES_PER_COMPARE_SAMPLE",
    "BYTES_PER_POINT",
    "BYTES_PER_SAMPLE",
    "BYTES_PER_WRITTEN_POINT",
    "available_memory",
    "cgroup_headroom",
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
    """Bytes of memory available to a new allocation, or None if unknown: Linux MemAvailable,
    or less where the process's memory cgroup (a container's limit) allows less."""
    free = _mem_available()
    headroom = cgroup_headroom()
    if free is None or headroom is None:
        return free if headroom is None else headroom
    return min(free, headroom)


def _mem_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


#: cgroup v1 reports "no limit" as a huge number (the largest page-aligned 64-bit value).
_NO_LIMIT = 2**60


def cgroup_headroom(
    root: str | os.PathLike[str] = "/sys/fs/cgroup", membership: str | os.PathLike[str] = "/proc/self/cgroup"
) -> int | None:
    """Bytes the process's memory cgroup still allows (its limit less its usage), or None.

    A container's memory limit is not in MemAvailable, which is the whole machine's: a
    command the machine could hold was killed by the container's limit without a word. Reads
    cgroup v2 (``memory.max``, ``memory.current``) or v1 (``memory.limit_in_bytes``,
    ``memory.usage_in_bytes``) of the process's own group; the limits of enclosing groups
    are not read. None when there is no limit or it cannot be read.
    """
    from pathlib import Path

    try:
        lines = Path(membership).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        hierarchy, controllers, group = parts
        if hierarchy == "0" and controllers == "":  # cgroup v2: one unified hierarchy
            here = Path(root) / group.lstrip("/")
            limit_file, usage_file = here / "memory.max", here / "memory.current"
        elif "memory" in controllers.split(","):  # cgroup v1: the memory controller's own
            here = Path(root) / "memory" / group.lstrip("/")
            limit_file, usage_file = here / "memory.limit_in_bytes", here / "memory.usage_in_bytes"
        else:
            continue
        try:
            limit_text = limit_file.read_text(encoding="ascii").strip()
            usage = int(usage_file.read_text(encoding="ascii").strip())
            limit = _NO_LIMIT if limit_text == "max" else int(limit_text)
        except (OSError, ValueError, UnicodeDecodeError):
            continue
        if limit < _NO_LIMIT:
            return max(limit - usage, 0)
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
