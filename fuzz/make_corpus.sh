#!/usr/bin/env bash
# Regenerates the seed corpus (fuzz/corpus/<harness>/) from the phantom: one small valid
# input per reader and variant. Usage: fuzz/make_corpus.sh [path/to/vellum]
set -euo pipefail
vellum=$(realpath "${1:-$(dirname "$0")/../build/ui/vellum}")  # resolved before the cd below
cd "$(dirname "$0")"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
c=corpus
rm -rf "$c"; mkdir -p $c/{nrrd,nhdr,metaimage,nifti,vti,raw_sidecar,labels,dicom,control_points,keyframes,style,curve,scene,script}

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
# Hand-made JSON seeds: a style with every kind of field, every 8th point of the demo's calf curve,
# the scene of docs/studio.md (v3, and a v2 one) naming the harness's neighbour files, the
# script of docs/studio.md.
cat > "$c/style/seed.json" <<'JSON'
{
 "version": 1,
 "name": "seed",
 "description": "fuzz seed",
 "light": [
  0.3,
  0.5,
  1.0
 ],
 "background": [
  1,
  1,
  1
 ],
 "ct_preset": "bone",
 "unclassified": {
  "visible": false
 },
 "default": {
  "opacity": 0.5,
  "colour": [
   0.8,
   0.8,
   0.8
  ],
  "tone_amount": 0.5,
  "illum": "phong",
  "depth_units": "fraction",
  "depth_start": 0.2,
  "depth_end": 0.8
 },
 "segments": [
  {
   "match": "bone",
   "lambda_illum": 1.0,
   "lambda_colouring": 0.5,
   "lambda_texture": 0.2,
   "texture": "stipple",
   "texture_scale_mm": 2.0,
   "boundary_measure": "distance",
   "boundary_width_mm": 1.5,
   "boundary_kc": 0.5,
   "silhouette_kc": 0.4,
   "silhouette_ke": 2.0,
   "tone_warm": [
    1,
    0.9,
    0.6
   ],
   "tone_cool": [
    0.2,
    0.3,
    0.6
   ]
  },
  {
   "match": "skin",
   "visible": true,
   "opacity": 0.05,
   "ambient": 0.3,
   "diffuse": 0.7,
   "specular": 0.2,
   "shininess": 24
  }
 ]
}
JSON
cat > "$c/curve/calf.json" <<'JSON'
{"points": [[174.37, 88.12], [170.12, 123.05], [172.12, 163.2], [173.16, 203.55], [166.69, 243.7], [151.62, 284.37], [156.64, 324.99], [167.72, 365.39], [169.79, 406.26], [193.19, 422.88], [234.17, 422.88], [275.16, 422.88], [316.14, 422.88], [341.12, 407.71], [340.88, 366.84], [339.38, 326.49], [337.88, 286.13], [337.12, 245.46], [337.12, 204.9], [338.12, 164.34], [339.55, 123.95], [338.18, 88.38], [297.31, 88.12], [256.33, 88.12], [215.35, 88.12]]}
JSON
cat > "$c/scene/v3.json" <<'JSON'
{
 "format": "vellum-studio-scene",
 "version": 3,
 "volume": "ct.nrrd",
 "labels": "labels.nrrd",
 "shapes": "shape",
 "series": "1.2.3",
 "view": {
  "layout": "2x2",
  "slice_window_center": 40.0,
  "slice_window_width": 400.0,
  "label_opacity": 0.4,
  "meshes_3d": false,
  "deformed_upsampling": "trilinear",
  "deformed_slices": true
 },
 "render": {
  "preset": "bone",
  "azimuth": 30.0,
  "elevation": 15.0,
  "zoom": 1.0,
  "fov": 30.0,
  "window_center": 400.0,
  "window_width": 2000.0,
  "shading": true,
  "step": 0.5,
  "jitter": true
 },
 "pan": [
  0,
  0,
  0
 ],
 "camera_bookmarks": [
  {
   "name": "lateral",
   "azimuth": 90.0,
   "elevation": 0.0,
   "zoom": 1.2,
   "fov": 30.0,
   "pan": [
    0,
    0,
    0
   ]
  }
 ],
 "illustration": {
  "enabled": true,
  "style": {
   "segments": [
    {
     "match": "bone",
     "opacity": 0.5
    }
   ]
  }
 },
 "crosshair": [
  0,
  0,
  0
 ],
 "hidden_labels": [
  3
 ],
 "locked_labels": [
  1
 ],
 "deformation": {
  "keyframes": "k.json",
  "keyframe": 1,
  "rigid_labels": [
   4,
   5
  ],
  "rigid_falloff_mm": 10.0
 }
}
JSON
cat > "$c/scene/v2.json" <<'JSON'
{
 "format": "vellum-studio-scene",
 "version": 2,
 "volume": "ct.nrrd",
 "layout": "3d",
 "preset": "bone",
 "window_center": 40,
 "window_width": 400,
 "label_opacity": 0.5,
 "camera": {
  "azimuth": 10,
  "elevation": 5,
  "zoom": 1.5
 }
}
JSON
cat > "$c/script/doc-example.json" <<'JSON'
{"actions": [{"open": "knee.nrrd"}, {"layout": "2x2"}, {"preset": "bone"}, {"click": [500, 170]}, {"drag": {"from": [850, 500], "to": [900, 520], "button": "left", "mods": ["shift"]}}, {"threshold": {"preset": "bone", "label": 1}}, {"key": "ctrl+z"}, {"frames": 5}, {"screenshot": {"path": "a.png", "view": "3d", "size": [64, 64]}}, {"save_scene": "s.json"}, {"set": {"shading": false, "step": 0.25}}, {"style_set": {"segment": "bone", "opacity": 0.5}}, {"keyframe": {"select": 0, "duration": 1.5}}, {"quit": 0}]}
JSON
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
