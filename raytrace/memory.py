"""The memory the host can still give this process, for the checks that refuse work it cannot hold (a render's
sums and images, a texture's levels) with one line before any of it is done."""
import os
import resource


def _proc_kib(path, field):
    """A `field: N kB` line of a /proc file, in bytes; None where there is none."""
    try:
        with open(path) as f:
            fields = dict(line.split(":", 1) for line in f)
        return int(fields[field].split()[0]) * 1024
    except (OSError, KeyError, ValueError):
        return None


def available_memory():
    """Bytes the host can still give this process: MemAvailable (free and reclaimable), else the free
    physical pages, and at most what the address-space limit (ulimit -v) leaves beside the address space
    the process holds already (the OpenCL runtime's alone is about 0.5 GB on PoCL)."""
    available = _proc_kib("/proc/meminfo", "MemAvailable")
    if available is None:
        available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    if limit == resource.RLIM_INFINITY:
        return available
    return min(available, limit - (_proc_kib("/proc/self/status", "VmSize") or 0))
