#!/usr/bin/env bash
# Regenerates the seed corpus (fuzz/corpus/<harness>/) from the phantom: one small valid
# input per reader and variant. Usage: fuzz/make_corpus.sh [path/to/vellum]
set -euo pipefail
vellum=$(realpath "${1:-$(dirname "$0")/../build/ui/vellum}")  # resolved before the cd below
cd "$(dirname "$0")"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
c=corpus
rm -rf "$c"; mkdir -p $c/{nrrd,nhdr,metaimage,nifti,vti,raw_sidecar,labels,dicom,control_points,keyframes}

"$vellum" phantom --size 16 --out "$tmp/ph.nrrd" --labels "$tmp/lab.nrrd" >/dev/null
"$vellum" convert "$tmp/ph.nrrd" "$c/nrrd/phantom16-gzip.nrrd" >/dev/null
"$vellum" convert "$tmp/ph.nrrd" "$c/nrrd/phantom16-raw.nrrd" --no-gzip >/dev/null
cp "$tmp/lab.nrrd" "$c/labels/labels16-gzip.nrrd"
"$vellum" convert "$tmp/ph.nrrd" "$c/metaimage/phantom16.mha" >/dev/null
"$vellum" convert "$tmp/ph.nrrd" "$c/vti/phantom16.vti" >/dev/null
# VTK's writer in each of its modes (ascii, base64, raw, zlib, both header types and byte orders).
vti_tests="$(dirname "$vellum")/../tests/io/vellum_vti_reader_tests"
VELLUM_VTI_SEED_DIR="$(realpath $c/vti)" "$vti_tests" --gtest_filter='*EveryMode*' >/dev/null
"$vellum" convert "$tmp/ph.nrrd" "$tmp/ph.raw" >/dev/null
cp "$tmp/ph.raw.json" "$c/raw_sidecar/phantom16.raw.json"
"$vellum" convert "$tmp/ph.nrrd" "$tmp/series" >/dev/null
cp "$(ls "$tmp"/series/* | head -1)" "$c/dicom/slice.dcm"
# A detached header naming the harness's fixed 16^3 int16 data file.
cat > "$c/nhdr/detached.nhdr" <<'NHDR'
NRRD0004
type: short
dimension: 3
space: left-posterior-superior
sizes: 16 16 16
space directions: (1,0,0) (0,1,0) (0,0,1)
space origin: (0,0,0)
endian: little
encoding: raw
data file: data.raw
NHDR
"$vellum" controls "$tmp/ph.nrrd" --out "$c/control_points/bbox16.json" >/dev/null
python3 - "$c" <<'PY'
import json, struct, sys
c = sys.argv[1]
pts = json.load(open(f"{c}/control_points/bbox16.json"))
moved = json.loads(json.dumps(pts["points"]))
moved[0]["target"][0] += 2.0
json.dump({"fps": 24, "interpolation": "smooth",
           "keyframes": [{"duration": 1.0, "points": pts["points"]}, {"duration": 1.0, "points": moved}]},
          open(f"{c}/keyframes/two.json", "w"))
# NIfTI-1, 16^3 int16, 1 mm, sform = identity (348-byte header + 4-byte extension flag).
hdr = bytearray(348)
struct.pack_into("<i", hdr, 0, 348)
struct.pack_into("<8h", hdr, 40, 3, 16, 16, 16, 1, 1, 1, 1)
struct.pack_into("<hh", hdr, 70, 4, 16)          # datatype int16, bitpix
struct.pack_into("<8f", hdr, 76, 1, 1, 1, 1, 1, 1, 1, 1)
struct.pack_into("<f", hdr, 108, 352.0)          # vox_offset
struct.pack_into("<hh", hdr, 252, 0, 1)          # qform_code, sform_code
struct.pack_into("<4f", hdr, 280, 1, 0, 0, 0)
struct.pack_into("<4f", hdr, 296, 0, 1, 0, 0)
struct.pack_into("<4f", hdr, 312, 0, 0, 1, 0)
hdr[344:348] = b"n+1\0"
data = b"".join(struct.pack("<h", (i % 300) - 1000) for i in range(16 ** 3))
open(f"{c}/nifti/ramp16.nii", "wb").write(bytes(hdr) + b"\0\0\0\0" + data)
PY
find "$c" -type f | sort | xargs ls -l | awk '{print $5, $9}'
