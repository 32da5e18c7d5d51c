#!/bin/sh
# The scripted real-size session (realsize.json.in) with --log-frames, timed (docs/benchmarks-studio.md).
# Usage: ui/studio/bench/run_real.sh BUILD_DIR VOLUME TAG [OUT_DIR]   (OUT_DIR defaults to /tmp)
set -e
here=$(dirname "$0")
out=${4:-/tmp}
mkdir -p "$out"
sed "s|@VOLUME@|$2|; s|@SHOT@|$out/$3.png|" "$here/realsize.json.in" > "$out/real-$3.json"
uptime > "$out/real-$3.uptime"
/usr/bin/time -v -o "$out/real-$3.time" xvfb-run -a -s "-screen 0 1280x800x24" "$1/ui/studio/vellum-studio" \
  --size 1280x800 --script "$out/real-$3.json" --log-frames | python3 "$here/timestamp.py" > "$out/real-$3.log"
uptime >> "$out/real-$3.uptime"
python3 "$here/responsiveness.py" "$out/real-$3.log"
grep -a "Maximum resident\|Elapsed" "$out/real-$3.time"
cat "$out/real-$3.uptime"
