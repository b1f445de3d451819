"""Writes the ajar room's two textures (no dependencies but the standard library):
`landscape.png`, the painting (a sky, hills, a sun), and `planks.png`, the floor's
boards. Run from this folder: python3 make_textures.py"""

import math
import struct
import zlib


def png(path, w, h, texel):
    """An 8-bit RGB PNG of `w` x `h` texels, `texel(x, y)` each (row 0 at the top)."""
    raw = b"".join(b"\x00" + bytes(c for x in range(w) for c in texel(x, y)) for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def landscape(x, y):
    hill = 40 + 12 * math.sin(x / 14.0) + 6 * math.sin(x / 5.0)
    if y > hill:
        return (40 + y // 2, 110 + y // 3, 40)
    if (x - 90) ** 2 + (y - 18) ** 2 < 64:
        return (250, 220, 120)
    return (90 + y, 140 + y, 220)


def planks(x, y):
    row = y // 16
    offset = (row * 37) % 64
    if y % 16 == 0 or (x + offset) % 64 == 0:
        return (60, 40, 25)
    g = int(12 * math.sin((x + 7 * row) / 3.0 + row))
    return (150 + g, 100 + g // 2, 60)


if __name__ == "__main__":
    png("landscape.png", 128, 72, landscape)
    png("planks.png", 128, 128, planks)
