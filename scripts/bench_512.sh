#!/usr/bin/env bash
# The 512³ scale run of docs/benchmarks.md: wall time and peak resident memory of every command
# (`/usr/bin/time -v`) on a 512³ phantom and its DICOM series.
#   scripts/bench_512.sh [WORK_DIR] [STEP...]     e.g. scripts/bench_512.sh /tmp/s512 shape illustrate
# Writes WORK_DIR/results.tsv (name, exit code, wall, peak RSS, user CPU, load average).
set -uo pipefail
V=$(realpath "$(dirname "$0")/../build/ui/vellum")
dir=${1:-/tmp/s512}
shift || true
steps=("$@")
mkdir -p "$dir" && cd "$dir" || exit 1
want() { ((${#steps[@]} == 0)) || [[ " ${steps[*]} " == *" $1 "* ]]; }
t() {  # NAME COMMAND...
  local name=$1; shift
  /usr/bin/time -v "$@" > "log-$name.txt" 2> "time-$name.txt"
  local rc=$?
  local wall rss user
  wall=$(grep "Elapsed (wall" "time-$name.txt" | awk '{print $NF}')
  rss=$(grep "Maximum resident" "time-$name.txt" | awk '{print $NF}')
  user=$(grep "User time" "time-$name.txt" | awk '{print $NF}')
  echo -e "$name\t$rc\t$wall\t$((rss / 1024)) MiB\tuser $user s\tload $(cut -d' ' -f1 /proc/loadavg)" | tee -a results.tsv
}
rigid=4,5,6,7,8,9,11
[ -f knee.nrrd ] || want phantom || { echo "knee.nrrd missing: run the phantom step first" >&2; exit 1; }
want phantom && t phantom "$V" phantom --size 512 --out knee.nrrd --labels labels.nrrd
want info && t info "$V" info knee.nrrd
want dicom && { t convert-dicom "$V" convert knee.nrrd series512; t info-dicom "$V" info series512;
                t convert-nrrd-from-dicom "$V" convert series512 fromdicom.nrrd; }
want render && t render-all-1024 "$V" render knee.nrrd --preset all --size 1024x1024 --out r.png
want segment && { t segment-threshold "$V" segment knee.nrrd --method threshold --preset bone --out seg.nrrd;
                  t segment-snake "$V" segment knee.nrrd --method snake --seed 0,35,60 --radius 10 --out snake.nrrd; }
if want deform; then
  t controls "$V" controls knee.nrrd --out cp.json
  t deform-s4-rigid "$V" deform knee.nrrd --points cp.json --control-scale 4 --labels labels.nrrd --rigid-labels $rigid --out bent.nrrd
fi
if want animate; then
  python3 - <<'PY'
import json
pts = json.load(open('cp.json'))
moved = json.loads(json.dumps(pts['points']))
for p in moved[:4]: p['target'][0] += 10.0
json.dump({'fps': 10, 'loop': True, 'keyframes': [{'duration': 0.5, 'points': pts['points']}, {'duration': 0.5, 'points': moved}]}, open('kf.json', 'w'))
PY
  t animate-10 "$V" animate knee.nrrd --keyframes kf.json --fps 10 --loop --labels labels.nrrd --rigid-labels $rigid --control-scale 4 --out frames/
fi
want downsample && t downsample2-render "$V" render knee.nrrd --downsample 2 --preset bone --out rd.png
want shape && t shape "$V" shape knee.nrrd --labels labels.nrrd --segment body=1,2,3,4,5,6,7,8,9,10,11 \
  --segment muscle=3 --segment femur=4,5 --segment tibia=6,7 --out shape512
if want illustrate; then
  for p in textbook dvr-colour; do
    t "illustrate-$p" "$V" illustrate knee.nrrd --shape shape512 --preset "$p" --size 1024x1024 --out "ill-$p.png"
  done
fi
