#!/usr/bin/env python3
"""Sagittal slices of int16 NRRD volumes side by side (before | after), one row per plane, 2x.

The figure docs/images/feet-pose-folds-slices.png (docs/benchmarks-deformation.md):
    python3 scripts/feet-folds-slices.py out.png 240,247 140 380 before.nrrd after.nrrd
Planes x = X (voxel index), y from Y0 to Y1, window -300..900 HU, z up; padded volumes (origin
z < 0) are aligned on the input's z = 0. Plain Python (no numpy): gzip or raw NRRD.
"""
import array, gzip, re, struct, sys, zlib

LO, HI, SCALE = -300.0, 900.0, 2


def load(path):
    raw = open(path, 'rb').read()
    i = raw.index(b'\n\n')
    hdr, data = raw[:i].decode(), raw[i + 2:]
    if 'gz' in re.search(r'encoding: (\w+)', hdr).group(1):
        data = gzip.decompress(data)
    dims = [int(v) for v in re.search(r'sizes: ([\d ]+)', hdr).group(1).split()]
    org = re.search(r'space origin: \(([^)]*)\)', hdr)
    a = array.array('h')
    a.frombytes(data)
    return a, dims, [float(v) for v in org.group(1).split(',')] if org else [0.0, 0.0, 0.0]


def panel(vol, x, y0, y1, z_lo, z_hi):
    a, (nx, ny, nz), org = vol
    z0 = int(round(-org[2]))  # index of the input's z = 0
    rows = []
    for z in range(z_hi, z_lo - 1, -1):
        k = z + z0
        row = bytearray()
        for j in range(y0, y1):
            v = a[(k * ny + j) * nx + x] if 0 <= k < nz else -1000
            row.append(max(0, min(255, int((v - LO) / (HI - LO) * 255))))
        rows.append(row)
    return rows


def main():
    out, xs, y0, y1 = sys.argv[1], [int(v) for v in sys.argv[2].split(',')], int(sys.argv[3]), int(sys.argv[4])
    vols = [load(p) for p in sys.argv[5:]]
    z_lo = min(-int(round(-v[2][2])) for v in vols)
    z_hi = max(v[1][2] - int(round(-v[2][2])) - 1 for v in vols)
    img = []
    for n, x in enumerate(xs):
        if n:
            img += [bytearray([255]) * len(img[0])]
        panels = [panel(v, x, y0, y1, z_lo, z_hi) for v in vols]
        for r in range(len(panels[0])):
            line = bytearray()
            for m, p in enumerate(panels):
                if m:
                    line += bytes([255] * 2)
                line += p[r]
            img.append(line)
    big = []
    for r in img:
        line = bytearray(b for b in r for _ in range(SCALE))
        big += [line] * SCALE
    w, h = len(big[0]), len(big)
    raw = b''.join(b'\x00' + bytes(r) for r in big)
    chunk = lambda t, d: struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    open(out, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 0, 0, 0, 0)) +
                          chunk(b'IDAT', zlib.compress(raw, 9)) + chunk(b'IEND', b''))


if __name__ == '__main__':
    main()
