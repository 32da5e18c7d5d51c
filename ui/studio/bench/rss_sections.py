#!/usr/bin/env python3
"""Resident memory of a studio run per script section: runs the command given (a
`vellum-studio ... --script S --log-frames` line, possibly under xvfb-run), passes its stdout
through unchanged, samples the vellum-studio process's VmRSS every 50 ms and prints, per
BEGIN/END section of the log, the RSS at its end and its maximum, and the process's peak
(VmHWM) last seen. Used for the issue #22 memory figure (docs/benchmarks-studio.md):
  rss_sections.py xvfb-run -a -s "-screen 0 1280x800x24" build/ui/studio/vellum-studio \\
    --size 1280x800 --script /tmp/mem.json --log-frames > /tmp/mem.log"""
import os
import subprocess
import sys
import threading
import time


def studio_pid(root):
    """The vellum-studio process among root's descendants (xvfb-run starts it)."""
    children = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                children.setdefault(int(fields[1]), []).append(int(d))
            except OSError:
                pass
    todo = [root]
    while todo:
        p = todo.pop()
        try:
            if open(f"/proc/{p}/comm").read().strip() == "vellum-studio":
                return p
        except OSError:
            pass
        todo += children.get(p, [])
    return None


def status(pid, key):
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0  # MiB
    except OSError:
        pass
    return None


def main(argv):
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
    state = {"pid": None, "rss": 0.0, "hwm": 0.0, "section": None, "max": {}}
    lock = threading.Lock()

    def sample():
        while proc.poll() is None:
            if state["pid"] is None:
                state["pid"] = studio_pid(proc.pid)
            if state["pid"] is not None:
                rss, hwm = status(state["pid"], "VmRSS"), status(state["pid"], "VmHWM")
                with lock:
                    if rss is not None:
                        state["rss"] = rss
                        s = state["section"]
                        if s is not None:
                            state["max"][s] = max(state["max"].get(s, 0.0), rss)
                    if hwm is not None:
                        state["hwm"] = hwm
            time.sleep(0.05)

    t = threading.Thread(target=sample, daemon=True)
    t.start()
    rows = []
    for line in proc.stdout:
        sys.stdout.write(line)
        parts = line.split()
        if len(parts) >= 2 and parts[0] in ("BEGIN", "END"):
            with lock:
                if parts[0] == "BEGIN":
                    state["section"] = parts[1]
                    state["max"][parts[1]] = state["rss"]
                else:
                    rows.append((parts[1], state["rss"], state["max"].get(parts[1], state["rss"])))
                    state["section"] = None
    proc.wait()
    t.join()
    sys.stderr.write(f"{'section':<14}{'RSS at end MiB':>16}{'max RSS MiB':>14}\n")
    for name, end, peak in rows:
        sys.stderr.write(f"{name:<14}{end:>16.0f}{peak:>14.0f}\n")
    sys.stderr.write(f"peak (VmHWM, last sample): {state['hwm']:.0f} MiB\n")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
