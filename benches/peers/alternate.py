"""Runs labelled commands alternately and compares their process CPU times.

Usage: python3 alternate.py K LABEL=COMMAND [LABEL=COMMAND ...]

Each round runs every command once, in the given order (K rounds); a command's time is the
user + system CPU time of its process and its children (getrusage), its output discarded.
Prints each run's time, then each command's median and range and the ratio of its median to
the first command's. The machine is shared: repeat, and read the ranges.
"""

import resource
import shlex
import statistics
import subprocess
import sys


def cpu_seconds(cmd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    k = int(sys.argv[1])
    runs = [arg.split("=", 1) for arg in sys.argv[2:]]
    times = {label: [] for label, _ in runs}
    for r in range(k):
        for label, cmd in runs:
            t = cpu_seconds(shlex.split(cmd))
            times[label].append(t)
            print(f"round {r + 1}: {label} {t:.3f} s", flush=True)
    base = statistics.median(times[runs[0][0]])
    print("| command | CPU s (median) | range | ratio of medians |")
    print("|---|---|---|---|")
    for label, _ in runs:
        m = statistics.median(times[label])
        print(f"| {label} | {m:.3f} | {min(times[label]):.3f}-{max(times[label]):.3f} | {m / base:.2f} |")


if __name__ == "__main__":
    main()
