#!/usr/bin/env python3
"""Writes the two textures of uplit-room.xml with the standard library alone:
tiles.png (256 x 256 sRGB: 4 x 4 tiles of two browns with light grout lines) and
ridges.png (128 x 128 grey, read raw: six sine ridges across the tile, periodic).
Run from this folder: python3 make_textures.py"""
import math
import struct
import zlib


def write_png(path, width, height, rows, channels):
    """An 8-bit PNG (grey or RGB) from rows of byte values."""
    kind = {1: 0, 3: 2}[channels]
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, kind, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


def tiles():
    n = 256
    rows = []
    for y in range(n):
        row = []
        for x in range(n):
            u, v = (x + 0.5) / n * 4, (y + 0.5) / n * 4
            if u % 1 < 0.04 or v % 1 < 0.04:
                c = (217, 217, 204)
            elif (math.floor(u) + math.floor(v)) % 2:
                c = (140, 107, 77)
            else:
                c = (89, 71, 51)
            row.extend(c)
        rows.append(row)
    write_png("tiles.png", n, n, rows, 3)


def ridges():
    n = 128
    row = [round(255 * (0.5 + 0.5 * math.sin(2 * math.pi * 6 * (x + 0.5) / n))) for x in range(n)]
    write_png("ridges.png", n, n, [row] * n, 1)


tiles()
ridges()
