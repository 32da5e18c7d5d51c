#!/bin/bash
# Runs on the GPU machine (from the repository root, with .dev/ and .gl/ from bundle.sh):
# Vellum's headless GL path on the EGL device platform (no X, no Mesa), whole commands timed.
# Output: $OUT/log.txt, the figures and $OUT/reports.tar (every command's --report).
# PARTS (default all): any of phantom tests nested scan movie, to fit a short device lease.
exec > >(tee "$OUT/log.txt") 2>&1
R=$PWD
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
J=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f $J ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$J
mkdir -p /tmp/v /tmp/w; tar -xJf .dev/bundle.tar.xz -C /tmp/v
# Modules (and the tests' data) are found at the paths compiled in: make them point here.
B=$(cat /tmp/v/build-path); S=$(dirname "$B")
if [ ! -e "$S" ]; then mkdir -p "$(dirname "$S")"; ln -s "$R" "$S"; fi
mkdir -p "$B/io" "$B/illustration"
cp /tmp/v/mod/libvellum_opencv_codecs.so "$B/io/"; cp /tmp/v/mod/libvellum_illustration_vdb.so "$B/illustration/"
mkdir -p "$B/ui"; cp /tmp/v/bin/vellum "$B/ui/"  # the CLI tests call it there
export LD_LIBRARY_PATH=/tmp/v/lib VELLUM_EGL_PLATFORM=device
V=/tmp/v/bin/vellum; TM=$R/.dev/time
nvidia-smi -L; nproc; grep PRETTY /etc/os-release; ldd $V | grep "not found"
T() { $TM -f "TIME %e s wall | %U user %S sys | %M KB | $*" "$@" 2>&1 | grep -v '^\(writing\|reading\|loading\|rendering\|sampling\|distance\|denoise\|segmentation\|Generating\|frames\)' | tail -6; }
PARTS=" ${PARTS:-phantom tests nested scan movie} "
has() { [[ $PARTS == *" $1 "* ]]; }
cd /tmp/w
if has phantom; then
T $V phantom --dims 512 512 350 --out p512.nrrd --labels p512-labels.nrrd
T $V shape p512.nrrd --labels p512-labels.nrrd --segment skin=1,2,3,4,5,6,7,8,9,10,11 --segment muscle=3 --segment bone=4,5,6,7,8,9,11 --out shape-p512
T $V illustrate p512.nrrd --shape shape-p512 --preset textbook --size 2048x2048 --out "$OUT/p512-textbook2048.png" --report r-illus2048.json
T $V illustrate p512.nrrd --shape shape-p512 --preset textbook --size 2048x2048 --out i2.png --report r-illus2048-warm.json
T $V render p512.nrrd --preset bone --size 1024x1024 --quality cinematic --trace-scale 0.5 --volume-shadows --samples 4096 --time-limit 30 --out "$OUT/p512-cine1024.png" --report r-cine.json
T $V render p512.nrrd --preset bone --size 1024x1024 --quality cinematic --volume-shadows --samples 4096 --time-limit 30 --out cine-full.png --report r-cine-full.json
fi
if has tests; then
for t in /tmp/v/bin/*_test /tmp/v/bin/*_tests; do
  (cd "$S" && $TM -f "TIME %e s wall | $(basename $t)" $t --gtest_brief=1 2>&1 | tail -25)
done
fi
# The nested-bone defect (eight-mode fields, bone inside an invisible skin: a flat grey disc on
# NVIDIA until s25): its GL figures plain and under each diagnosis switch
# (VELLUM_GL_DIAG, illustration_renderer_shader.cpp: normals as colour, magenta = NaN gradient,
# black = zero; gradients everywhere; no skipping; the style model's terms). Found and fixed in
# s25 (docs/benchmarks-gpu.md); kept as the GL-vs-CPU check of a segment inside an invisible one.
# Look at $OUT/nested-*/gl-nested-bone-eight.png.
if has nested; then
for diag in ${DIAGS:-none normals nowindow noskip terms}; do
  mkdir -p "$OUT/nested-$diag"
  (cd "$S" && VELLUM_GL_DIAG=$diag VELLUM_ILLUSTRATION_PNG_DIR="$OUT/nested-$diag" /tmp/v/bin/illustration_render_test \
    --gtest_filter='IllustrationNested.*' --gtest_brief=1 2>&1 | grep -E "diff|FAILED|PASSED" | sed "s/^/[$diag] /")
done
fi
if has scan && [ -f "$R/.dev/scan.nrrd.xz" ]; then
  xz -dc "$R/.dev/scan.nrrd.xz" >scan.nrrd
  T $V render scan.nrrd --preset bone --size 512x512 --out "$OUT/scan-bone512.png" --report r-scan-bone512.json
  T $V segment scan.nrrd --preset skin-air --fill-holes-slices --label-id 1 --label-name skin --out skin.nrrd
  T $V segment scan.nrrd --lower 200 --upper 3071 --fill-holes-slices --min-island 100 --into skin.nrrd --label-id 2 --label-name bone --out labels.nrrd
  T $V shape scan.nrrd --labels labels.nrrd --segment skin=1,2 --segment bone=2 --remove-table --out shape-scan
  T $V illustrate scan.nrrd --shape shape-scan --preset textbook --remove-table --size 1024x1024 --out "$OUT/scan-textbook1024.png" --report r-scan-illus.json
  T $V illustrate scan.nrrd --shape shape-scan --preset pen --remove-table --size 1024x1024 --out "$OUT/scan-pen1024.png"
fi
if has movie && [ -f "$R/.dev/keyframes.json" ]; then
  timeout 240 $TM -f "TIME %e s wall | %U user %S sys | %M KB | animate 512² movie" $V animate p512.nrrd --keyframes "$R/.dev/keyframes.json" --labels p512-labels.nrrd --rigid-labels 4+5,6+7,8+11 --size 512x512 --fps 30 -o /tmp/w/frames/ --report r-anim.json 2>&1 | tail -4
  f=$(ls /tmp/w/frames 2>/dev/null | sort | sed -n 45p); [ -n "$f" ] && cp "/tmp/w/frames/$f" "$OUT/movie-frame45.png"
fi
tar -cf "$OUT/reports.tar" r-*.json 2>/dev/null || true
