#!/usr/bin/env python3
"""Responsiveness of a scripted real-size session (`vellum-studio --log-frames`, e.g.
ui/studio/bench/realsize.json.in): per BEGIN/END section the wall time, the longest frame and
the frames over 250 ms, from the first picture on (the first frame that drew slices: the frame
that adopted the load, included); the first drag
response (from the press of the `drag` section to the first frame whose deformation map
changed). A frame's time here is the wall time since the previous frame's line (`wall_ms`,
added by ui/studio/bench/timestamp.py): it includes what ran between frames (a script's
step runs a panel command there, as an event handler would), which the frame's own `ms`
does not. With `cpu_ms` in the log (the UI thread's CPU time in the frame), long frames that
drew nothing and used under a quarter of their time on a core are counted apart: the window
was waiting for the machine (the other programs' load, the X server), not working."""
import sys

BUDGET_MS = 250.0


def main(path):
    sections, current, after_first, long_frames, worst = [], None, False, 0, (0.0, "")
    starved = 0  # long frames that drew nothing while the UI thread ran < 25 % of them
    drag_start, drag_response, clock = None, None, 0.0
    for line in open(path):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "BEGIN":
            current = {"name": parts[1], "frames": [], "start": None}
        elif parts[0] == "END" and current:
            sections.append(current)
            current = None
        elif parts[0] == "frame":
            f = dict(zip(parts[2::2], parts[3::2]))
            if "wall_ms" in f:
                t = float(f["wall_ms"])
                ms = t - clock if clock else float(f["ms"])
                clock = t
            else:  # no timestamps: the frames' own times (what ran between frames is missed)
                ms = float(f["ms"])
                clock += ms
                t = clock
            if float(f.get("slices_ms", 0)) > 0:
                after_first = True
            if current is not None:
                current["frames"].append((ms, t, f))
                if current["name"] == "drag":
                    if drag_start is None:
                        drag_start = t - ms
                    elif drag_response is None and float(f.get("map_ms", 0)) > 0:
                        drag_response = t - drag_start
            if after_first:
                long_frames += ms > BUDGET_MS
                drew = float(f.get("render3d_ms", 0)) > 0 or float(f.get("slices_ms", 0)) > 0
                if ms > BUDGET_MS and "cpu_ms" in f and not drew and float(f["cpu_ms"]) < 0.25 * ms:
                    starved += 1
                if ms > worst[0]:
                    worst = (ms, current["name"] if current else "-")
    print(f"{'section':<14}{'wall s':>8}{'frames':>8}{'max ms':>9}{'>250 ms':>9}")
    for s in sections:
        fr = s["frames"]
        if not fr:
            continue
        wall = (fr[-1][1] - (fr[0][1] - fr[0][0])) / 1000
        print(f"{s['name']:<14}{wall:>8.1f}{len(fr):>8}{max(m for m, _, _ in fr):>9.1f}"
              f"{sum(m > BUDGET_MS for m, _, _ in fr):>9}")
    print(f"after the first picture: max frame {worst[0]:.1f} ms ({worst[1]}), frames over {BUDGET_MS:.0f} ms: {long_frames}")
    print(f"  of which waiting (drew nothing, UI thread on a core < 25 % of the frame: cpu_ms): {starved}")
    if drag_response is not None:
        print(f"first drag response: {drag_response:.0f} ms (press to the first frame with a new map)")


if __name__ == "__main__":
    main(sys.argv[1])
