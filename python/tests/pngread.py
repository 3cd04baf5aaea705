"""A minimal PNG reader for the CLI's 16-bit greyscale frames (numpy and
zlib only), so the bit-identity test needs no imaging package.

gloam stores b-bit counts scaled to 16 bits (left-bit replication) with an
sBIT chunk declaring b, as the PNG specification asks; the counts are
sample >> (16 - b). A PNG without sBIT holds its counts as they are."""

import struct
import zlib

import numpy as np


def read_png_u16(path) -> np.ndarray:
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    pos, idat, ihdr, sbit = 8, b"", None, 16
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + n]
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"sBIT":
            sbit = body[0]
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    w, h, depth, colour, _, _, interlace = ihdr
    assert (depth, colour, interlace) == (16, 0, 0), f"{path}: not 16-bit grey"
    raw = zlib.decompress(idat)
    bpp, stride = 2, 2 * w
    out = np.zeros((h, stride), dtype=np.int64)
    prev = np.zeros(stride, dtype=np.int64)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=y * (stride + 1) + 1).astype(np.int64)
        cur = np.zeros(stride, dtype=np.int64)
        if f == 0:
            cur = line
        elif f == 2:
            cur = (line + prev) & 0xFF
        else:
            for i in range(stride):
                a = cur[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                if f == 1:
                    p = a
                elif f == 3:
                    p = (a + b) // 2
                else:  # Paeth
                    pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                    p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[i] = (line[i] + p) & 0xFF
        out[y] = cur
        prev = cur
    assert 1 <= sbit <= 16, f"{path}: sBIT {sbit}"
    return ((out[:, 0::2] * 256 + out[:, 1::2]) >> (16 - sbit)).astype(np.uint16)
