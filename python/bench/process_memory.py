#!/usr/bin/python3
"""Runs a command and reports the memory of it and every process it starts (a Dask cluster's
workers and nanny), sampled from /proc every 0.2 s (docs/datasets.md, "Acceptance runs"):

    /usr/bin/python3 python/bench/process_memory.py -- tac3d dataset generate ...

Per process: VmHWM (the kernel's peak resident size: shared pages, such as a mapped body
model, counted whole in every process), and the largest Pss (shared pages divided among the
processes mapping them) and USS (Private_Clean + Private_Dirty: the process's own) seen in
/proc/PID/smaps_rollup. Prints one line a process, largest VmHWM first, then the command's
exit code."""
import os
import subprocess
import sys
import time


def children(pid):
    """Of every thread: a process started from another thread (Dask's nanny starts its
    worker from its event loop's) is listed under that thread only."""
    found = []
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as f:
                found += [int(c) for c in f.read().split()]
    except OSError:
        pass
    return found


def descendants(pid):
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        found.append(p)
        todo += children(p)
    return found


def sample(pid):
    """{field: kB} of VmHWM, Pss, Private_Clean, Private_Dirty, or None if it has gone."""
    fields = {}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    fields["VmHWM"] = int(line.split()[1])
        with open(f"/proc/{pid}/smaps_rollup") as f:
            for line in f:
                key = line.split(":")[0]
                if key in ("Pss", "Private_Clean", "Private_Dirty"):
                    fields[key] = int(line.split()[1])
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            fields["cmd"] = f.read().replace(b"\0", b" ").decode(errors="replace")[:90]
    except OSError:
        return None
    return fields


def main():
    if "--" not in sys.argv:
        sys.exit(__doc__)
    command = sys.argv[sys.argv.index("--") + 1:]
    run = subprocess.Popen(command)
    peaks = {}
    while run.poll() is None:
        for pid in descendants(run.pid):
            s = sample(pid)
            if not s or "VmHWM" not in s:
                continue
            peak = peaks.setdefault(pid, {"VmHWM": 0, "Pss": 0, "USS": 0, "cmd": s["cmd"]})
            peak["VmHWM"] = max(peak["VmHWM"], s["VmHWM"])
            peak["Pss"] = max(peak["Pss"], s.get("Pss", 0))
            peak["USS"] = max(peak["USS"], s.get("Private_Clean", 0) + s.get("Private_Dirty", 0))
        time.sleep(0.2)
    for pid, p in sorted(peaks.items(), key=lambda kv: -kv[1]["VmHWM"]):
        print(f"pid {pid}: peak RSS {p['VmHWM'] / 1024:.0f} MB, Pss {p['Pss'] / 1024:.0f} MB, "
              f"USS {p['USS'] / 1024:.0f} MB  {p['cmd']}", file=sys.stderr)
    print(f"exit code {run.returncode}", file=sys.stderr)
    sys.exit(run.returncode)


if __name__ == "__main__":
    main()
