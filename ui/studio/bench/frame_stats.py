#!/usr/bin/env python3
"""Frame-time summary of a `vellum-studio --log-frames` log, per BEGIN/END section that a
script printed with {"log": "BEGIN name"} / {"log": "END name"} (see docs/benchmarks-studio.md)."""
import statistics
import sys


def main(path):
    sections, name, frames = [], None, []
    for line in open(path):
        parts = line.split()
        if parts[:1] == ["BEGIN"]:
            name, frames = parts[1], []
        elif parts[:1] == ["END"] and name:
            sections.append((name, frames))
            name = None
        elif name and parts[:1] == ["frame"]:
            fields = dict(zip(parts[2::2], parts[3::2]))
            frames.append(fields)
    print(f"{'section':<12}{'frames':>7}{'mean ms':>9}{'median':>8}{'p90':>8}{'max':>8}  3D renders (scale: count)")
    for name, fr in sections:
        ms = sorted(float(f["ms"]) for f in fr)
        if not ms:
            continue
        p90 = ms[min(len(ms) - 1, int(round(0.9 * (len(ms) - 1))))]
        scales = {}
        for f in fr:
            if f["render3d"] == "1":
                scales[f["scale"]] = scales.get(f["scale"], 0) + 1
        sc = ", ".join(f"1/{k}: {v}" for k, v in sorted(scales.items()))
        print(f"{name:<12}{len(ms):>7}{statistics.mean(ms):>9.1f}{statistics.median(ms):>8.1f}{p90:>8.1f}{ms[-1]:>8.1f}  {sc}")
        maps = sorted(float(f["map_ms"]) for f in fr if float(f.get("map_ms", 0)) > 0)
        if maps:  # deformation re-solves (control-point drags)
            coarse = sorted(float(f["render3d_ms"]) for f in fr if f["render3d"] == "1" and f["scale"] != "1")
            line = f"{'':<12}map updates {len(maps)}: median {statistics.median(maps):.1f} ms, max {maps[-1]:.1f} ms"
            if coarse:
                line += f"; reduced-resolution 3D frames: median {statistics.median(coarse):.1f} ms, max {coarse[-1]:.1f} ms"
            print(line)
        slices = sorted(float(f["slices_ms"]) for f in fr if float(f.get("slices_ms", 0)) > 0)
        if slices:  # slice views re-rendered (all slice panes of the frame)
            deformed = sum(1 for f in fr if float(f.get("slices_ms", 0)) > 0 and f.get("deformed_slices") == "1")
            print(f"{'':<12}slice re-renders {len(slices)} ({deformed} deformed): median "
                  f"{statistics.median(slices):.1f} ms, max {slices[-1]:.1f} ms")
    full = [float(line.split()[7]) for line in open(path)
            if line.startswith("frame") and " render3d 1 " in line and " scale 1 " in line]
    if full:
        print(f"full-resolution 3D renders: {len(full)}, median {statistics.median(full):.1f} ms, max {max(full):.1f} ms")


if __name__ == "__main__":
    main(sys.argv[1])
