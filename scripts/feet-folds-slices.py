#!/usr/bin/env python3
"""Sagittal slices of volumes side by side (before | after), one row per plane, 2x.

The figure docs/images/feet-pose-folds-slices.png (docs/benchmarks-deformation.md):
    python3 scripts/feet-folds-slices.py out.png 240,247 140 380 before.nrrd after.nrrd
Planes x = X mm, y from Y0 to Y1 mm, window -300..900 HU, superior up, 0.5 mm pixels. All of
it is `vellum slice` (one contact sheet: a row per plane, a column per volume, each resampled on
the first volume's planes, so a padded output lines up with its input in mm). VELLUM names the
binary (default: build/ui/vellum beside this script's checkout, else `vellum` on the PATH).
"""
import os, shutil, subprocess, sys

LO, HI, SCALE = -300.0, 900.0, 2


def vellum():
    if os.environ.get('VELLUM'):
        return os.environ['VELLUM']
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'build', 'ui', 'vellum')
    return here if os.path.exists(here) else shutil.which('vellum') or 'vellum'


def main():
    if len(sys.argv) < 6:
        sys.exit(__doc__)
    out, xs, y0, y1, vols = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5:]
    cmd = [vellum(), 'slice', vols[0], '--out', out, '--plate', '--axis', 'sagittal', '--mm', xs,
           # The box's y covers the voxels y0 .. y1-1 whole (edges half a voxel out); x and z: all.
           '--box-mm', '-1e6', '1e6', str(y0 - 0.5), str(y1 - 0.5), '-1e6', '1e6',
           '--window-center', str((LO + HI) / 2), '--window-width', str(HI - LO), '--zoom', str(SCALE),
           '--orientation=false']
    for v in vols[1:]:
        cmd += ['--beside', v]
    subprocess.run(cmd, check=True)


if __name__ == '__main__':
    main()
