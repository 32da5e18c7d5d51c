#!/usr/bin/env python3
"""Appends `wall_ms T` (ms since this filter started) to every `frame` line of a studio
`--log-frames` log read from stdin: the wall time between two frames' lines is what the user
waits, including work done between frames (a script's step, an event handler). Used the
same way for any studio build: `vellum-studio ... --log-frames | timestamp.py > log`."""
import sys
import time

start = time.monotonic()
for line in sys.stdin:
    if line.startswith("frame "):
        line = f"{line.rstrip()} wall_ms {1000 * (time.monotonic() - start):.1f}\n"
    sys.stdout.write(line)
    sys.stdout.flush()
