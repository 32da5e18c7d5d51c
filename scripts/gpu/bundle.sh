#!/bin/bash
# Packs a built `vellum` with the shared libraries it loads into .dev/ (ignored by git) so that
# scripts/gpu/check.sh can run it on a bare machine with an NVIDIA GPU (no packages installed
# there, nothing fetched). Usage, from the repository root after a Release build:
#   bash scripts/gpu/bundle.sh [SCAN.nrrd [KEYFRAMES.json]]
# SCAN: a real scan (any input `vellum convert` reads: ct-feet-vhf); KEYFRAMES: a movie of
# the 512x512x350 phantom (docs/benchmarks-deformation.md), both optional.
# Size matters (the tree that travels is limited), so:
#  - glibc, libstdc++ and the GL vendor-neutral libraries are not packed (the target has its own;
#    the GL ones come from Debian's libglvnd packages, downloaded into .gl/);
#  - GDAL, which OpenCV's image codecs link but Vellum never calls, is replaced by a stub that
#    defines the 14 functions the codecs reference (bind-now needs them), dropping ~90 libraries.
set -euo pipefail
B=${BUILD:-build}
V=$B/ui/vellum
# GL test binaries run there too (they need no library beyond the bundle once GDAL is a stub).
TESTS=${TESTS:-"$B/tests/render/render_gl_test $B/tests/illustration_render/illustration_render_test $B/tests/illustration_render/illustration_styles_test $B/tests/wysiwyg/vellum_wysiwyg_gl_tests $B/tests/deformation/vellum_deformation_gl_tests"}
MODS="$B/io/libvellum_opencv_codecs.so $B/illustration/libvellum_illustration_vdb.so"
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
mkdir -p .dev "$T/bin" "$T/lib" "$T/mod" "$T/stub"
IC=$(ldd $B/io/libvellum_opencv_codecs.so | awk '/imgcodecs/{print $3}')
G=$(ldd $B/io/libvellum_opencv_codecs.so | awk '/libgdal/{print $3}')
nm -D --undefined-only "$IC" | awk '{print $2}' | sed 's/@.*//' | sort -u >"$T/undef"
nm -D --defined-only "$G" | awk '{print $3}' | sed 's/@.*//' | sort -u >"$T/def"
comm -12 "$T/undef" "$T/def" | awk '{print "void " $1 "(void) {}"}' >"$T/stub/gdal_stub.c"
gcc -shared -fPIC -o "$T/stub/$(basename "$G")" -Wl,-soname,"$(basename "$G")" "$T/stub/gdal_stub.c"
cp "$V" $TESTS "$T/bin/"; cp $MODS "$T/mod/"; cp "$T/stub/$(basename "$G")" "$T/lib/"
(ldd "$V"; LD_LIBRARY_PATH="$T/stub" ldd $MODS $TESTS) | awk '/=>/{print $3}' | sort -u |
  grep -vE 'libc\.so|libm\.so|libdl\.so|libpthread|libresolv|librt\.so|libEGL|libGLX|libGLdispatch|libOpenGL|libstdc\+\+|libgcc_s|ld-linux|/stub/' |
  xargs -I{} cp -L {} "$T/lib/"
strip "$T/bin/"* "$T/mod/"*; strip --strip-unneeded "$T/lib/"* 2>/dev/null || true
# The modules are opened at the absolute paths compiled into vellum: check.sh puts them back there.
(cd "$B" && pwd) >"$T/build-path"
tar -C "$T" -c bin lib mod build-path | xz -T0 -6 >.dev/bundle.tar.xz
cp /usr/bin/time .dev/time
# The scan travels as raw NRRD under xz: 13 MB for ct-feet-vhf against 18 MB as gzip NRRD.
if [ $# -ge 1 ]; then
  "$V" convert "$1" "$T/scan.nrrd" --no-gzip >/dev/null && xz -T0 -6 -c "$T/scan.nrrd" >.dev/scan.nrrd.xz
fi
if [ $# -ge 2 ]; then cp "$2" .dev/keyframes.json; fi
mkdir -p .gl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
apt-get $o update >/dev/null && (cd .gl && apt-get $o download libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
X=$(git rev-parse --git-path info/exclude); mkdir -p "$(dirname "$X")"  # a worktree's .git is a file
for p in /.dev/ /.gl/; do grep -qx "$p" "$X" 2>/dev/null || echo "$p" >>"$X"; done
du -sh .dev .gl
