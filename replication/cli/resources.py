"""Resources a command will need, checked before it starts: memory for a NURBS tessellation."""

from __future__ import annotations

__all__ = ["BYTES_PER_SAMPLE", "available_memory", "check_tessellation"]

#: Peak memory per tessellation sample in bytes: the growth of the peak resident size from
#: 2 x 2 to 1000 x 1000 samples (``/usr/bin/time``), rounded up; geomdl keeps every point as a
#: Python list of floats (435 measured), the fast evaluator numpy arrays (52 measured).
BYTES_PER_SAMPLE = {"geomdl": 450, "fast": 56}


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


def check_tessellation(shape: tuple[int, int], evaluator: str) -> None:
    """Refuse, before any work, a tessellation whose samples cannot fit in the available memory."""
    from replication.errors import InputError

    s_u, s_v = shape
    need = s_u * s_v * BYTES_PER_SAMPLE[evaluator]
    available = available_memory()
    if available is not None and need > available:
        raise InputError(
            f"--tessellation {s_u}x{s_v} needs about {_size(need)} of memory ({s_u * s_v:,} samples x "
            f"{BYTES_PER_SAMPLE[evaluator]} bytes with the {evaluator} evaluator), but {_size(available)} "
            "is available: choose fewer samples"
        )
