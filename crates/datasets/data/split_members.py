#!/usr/bin/env python3
"""Rewrites a gzip file as N gzip members (RFC 1952 §2.2: a gzip file is a series of
members), cut at line ends, each carrying its own compressed length in an extra field
(subfield 'G','C', 4 bytes little-endian: the member's total size in bytes, header and
trailer included) so a reader can inflate the members on several cores at once. Any gzip
reader (zcat, Python's gzip module) reads the result as the same text.

Usage: python3 split_members.py fl_thermal.csv.gz [members=4]   (rewrites the file in place)
"""
import gzip
import struct
import sys
import zlib

path = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 4
with gzip.open(path, "rb") as f:
    raw = f.read()
cuts = [0]
for k in range(1, n):
    cuts.append(raw.index(b"\n", len(raw) * k // n) + 1)
cuts.append(len(raw))
out = b""
for a, b in zip(cuts, cuts[1:]):
    part = raw[a:b]
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    body = c.compress(part) + c.flush()
    trailer = struct.pack("<II", zlib.crc32(part), len(part) & 0xFFFFFFFF)
    # ID1 ID2 CM FLG(FEXTRA) MTIME(0) XFL(2: max compression) OS(255: unknown), XLEN, subfield.
    size = 10 + 2 + 8 + len(body) + 8
    head = bytes([0x1F, 0x8B, 8, 4, 0, 0, 0, 0, 2, 255]) + struct.pack("<H", 8)
    head += b"GC" + struct.pack("<HI", 4, size)
    out += head + body + trailer
with open(path, "wb") as f:
    f.write(out)
assert gzip.decompress(out) == raw
print(f"{path}: {len(raw)} bytes in {n} members, {len(out)} bytes compressed")
