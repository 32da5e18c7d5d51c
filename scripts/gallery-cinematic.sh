#!/usr/bin/env bash
# Remakes the cinematic figures of docs/lighting.md and docs/gallery.md (docs/images/cinematic-*):
# the phantom and a real CT series plain next to cinematic, and the phantom's knee bend as a
# short cinematic movie. Prints each command (vellum as "vellum") as it runs it.
#
#   scripts/gallery-cinematic.sh [CT_SERIES_DIR] [VELLUM_BINARY]
#
# CT_SERIES_DIR defaults to ../shared/data/ct-feet-vhf (the Visible Human Female feet, NLM);
# without it the feet figure is skipped. Needs ffmpeg (the panels are put side by side with it).
# Scratch files go to a temporary folder removed at the end. About 10-15 minutes on 2 cores.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
feet=${1:-$here/../shared/data/ct-feet-vhf}
vellum=${2:-$here/build/ui/vellum}
out=$here/docs/images
work=$(mktemp -d /tmp/vellum-cinematic.XXXXXX)
trap 'rm -rf "$work"' EXIT
[ -x "$vellum" ] || { echo "gallery-cinematic.sh: $vellum: not built (cmake --build build)" >&2; exit 2; }
command -v ffmpeg >/dev/null || { echo "gallery-cinematic.sh: needs ffmpeg" >&2; exit 2; }

run() {
  local shown="${*//$vellum/vellum}"
  shown="${shown//$work\//}"
  shown="${shown//$feet/ct-feet-vhf}"
  echo "+ ${shown//$out\//}" >&2
  "$@" >/dev/null
}
# panels OUT SIZE ROW... : each ROW "left.png right.png", scaled to SIZE² and stacked.
panels() {
  local dest=$1 size=$2
  shift 2
  local inputs=() filter="" rows=0 i=0
  for row in "$@"; do
    read -r left right <<<"$row"
    inputs+=(-i "$left" -i "$right")
    filter+="[$i]scale=${size}:${size}[a$rows];[$((i + 1))]scale=${size}:${size}[b$rows];[a$rows][b$rows]hstack[r$rows];"
    i=$((i + 2))
    rows=$((rows + 1))
  done
  local stack=""
  for ((r = 0; r < rows; ++r)); do stack+="[r$r]"; done
  filter+="${stack}vstack=$rows,format=rgb24"
  ffmpeg -loglevel error -y "${inputs[@]}" -filter_complex "$filter" -frames:v 1 "$dest"
}

# The cinematic settings: paths at half size under the full-size denoise guide, shadows and sky
# occlusion from the light volume; for the phantom's smooth shapes a darker sky and -0.5 stop
# for modelling (the defaults are close to white there), for the real CT the default lights
# (the darker set made the feet's bones milky and grey).
fast=(--quality cinematic --trace-scale 0.5 --volume-shadows --samples 256)
cine=("${fast[@]}" --exposure -0.5 --sky-light 0.35)

run "$vellum" phantom --size 256 --out "$work/p256.nrrd" --labels "$work/p256-labels.nrrd"
rows=()
for p in bone skin soft-tissue; do
  run "$vellum" render "$work/p256.nrrd" --preset $p --zoom 1.4 --size 512x512 --out "$work/phantom-$p.png"
  run "$vellum" render "$work/p256.nrrd" --preset $p --zoom 1.4 --size 512x512 "${cine[@]}" --time-limit 30 \
    --out "$work/phantom-$p-cinematic.png"
  rows+=("$work/phantom-$p.png $work/phantom-$p-cinematic.png")
done
panels "$out/cinematic-phantom.png" 384 "${rows[@]}"

if [ -d "$feet" ]; then
  # The feet with traced shadows at full resolution: the light volume is too coarse for the
  # gaps between the foot bones and flattens them (judged side by side in docs/lighting.md);
  # fewer samples, but the joint spaces keep their depth.
  traced=(--quality cinematic --samples 1000)
  view=(--zoom 3.2 --elevation 50 --azimuth 20)
  rows=()
  for p in bone skin; do
    run "$vellum" render "$feet" --preset $p "${view[@]}" --size 640x640 --out "$work/feet-$p.png"
    run "$vellum" render "$feet" --preset $p "${view[@]}" --size 640x640 "${traced[@]}" --time-limit 60 \
      --out "$work/feet-$p-cinematic.png"
    rows+=("$work/feet-$p.png $work/feet-$p-cinematic.png")
  done
  panels "$out/cinematic-feet.png" 448 "${rows[@]}"
fi

# The knee bend of `vellum demo` (its deform-keyframes.json: three keyframes of 0.67 s), the
# bones rigid, 30 frames at 15 fps, 4 samples per frame.
run "$vellum" demo --size 64 --image-size 64 --no-dicom --out "$work/demo"
run "$vellum" animate "$work/p256.nrrd" --keyframes "$work/demo/deform-keyframes.json" --labels "$work/p256-labels.nrrd" \
  --rigid-labels 4+5,6+7,8+11,9+11 --fps 15 --size 512x512 --preset bone --azimuth 70 --elevation 10 --zoom 1.3 \
  "${cine[@]/256/4}" --out "$out/cinematic-knee.mp4"
echo "gallery-cinematic.sh: wrote $out/cinematic-{phantom,feet}.png and cinematic-knee.mp4" >&2
