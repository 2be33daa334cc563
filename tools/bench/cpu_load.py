"""CPU-time readings shared by the benchmark scripts (the VM is shared: wall time alone misleads)."""
import os


def cpu_busy_s():
    """Seconds of busy CPU time summed over all cores since boot (/proc/stat)."""
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    idle = v[3] + (v[4] if len(v) > 4 else 0)
    return (sum(v[:8]) - idle) / os.sysconf("SC_CLK_TCK")


def child_cpu_s():
    """User + system CPU seconds of the finished child processes."""
    import resource
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime
