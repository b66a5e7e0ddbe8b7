#!/usr/bin/env python3
"""crop-png.py - cut the centre of a binary PPM (P6) into a PNG, standard
library only (pdla render draws an event file's whole box; the cluster of a
large dilute box is a few pixels in it). Usage: crop-png.py IN.ppm SIZE OUT.png
(make IN.ppm with `convert IN.png ppm:-`)."""
import struct
import sys
import zlib


def main():
    src, size, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    data = open(src, "rb").read()
    fields, pos = [], 0
    while len(fields) < 4:  # magic, width, height, maxval (no comments)
        while data[pos:pos + 1].isspace():
            pos += 1
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    pos += 1
    w, h = int(fields[1]), int(fields[2])
    if fields[0] != b"P6" or size > min(w, h):
        sys.exit("crop-png.py: need a P6 image at least SIZE on a side")
    x0, y0 = (w - size) // 2, (h - size) // 2
    raw = b"".join(b"\0" + data[pos + 3 * ((y0 + y) * w + x0):pos + 3 * ((y0 + y) * w + x0 + size)]
                   for y in range(size))

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    open(out, "wb").write(png)


main()
