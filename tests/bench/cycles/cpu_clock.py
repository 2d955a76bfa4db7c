"""CPU time: of one running process, of this process's finished children, and of the whole machine (to tell how much
of it other processes took while a bake was timed)."""
import os
import resource

TICK = os.sysconf("SC_CLK_TCK")


def of_process(pid):
    """User + system CPU seconds a running process has used (all its threads), from /proc/PID/stat."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime, stime: fields 14 and 15


def of_children():
    """User + system CPU seconds of this process's children that have ended (and been waited for)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def of_machine():
    """CPU seconds every CPU has spent busy, by anyone, since boot (/proc/stat: all but idle and iowait; steal, the
    time a virtual machine's host gave to others, counts as busy)."""
    with open("/proc/stat") as f:
        fields = [int(x) for x in f.readline().split()[1:9]]
    user, nice, system, idle, iowait, irq, softirq, steal = fields
    return (user + nice + system + irq + softirq + steal) / TICK


class Others:
    """The CPU seconds other processes (and a VM's host) took between start and stop, given ours."""

    def __init__(self):
        self.start = of_machine()

    def stop(self, ours):
        return max(0.0, of_machine() - self.start - ours)
