#!/usr/bin/env python3
"""Adds outliers to a point set, as a scan's stray points (issue 27; docs/ALGORITHM.md §9.7).

    python3 scripts/add-outliers.py IN.ply OUT.ply --share 0.01 [--seed 27]

Appends round(share * n) points drawn uniformly in the bounding box of the input's n positions,
each with a uniformly random unit normal (nx ny nz, when the file has them; other properties: 0,
colours grey). The input's points come first, unchanged, so the outliers are the file's last
points. The same seed gives the same file. Reads and writes binary little-endian PLY files with
one element, vertex, of scalar properties (the sparse inputs of ../shared/data). Python 3 only, no
packages.
"""

import argparse
import math
import random
import struct
import sys

TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
         "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
         "float": "f", "float32": "f", "double": "d", "float64": "d"}


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    if header[0] != "ply" or header[1] != "format binary_little_endian 1.0":
        sys.exit(f"{path}: not a binary little-endian PLY file")
    count, names, fmt = None, [], "<"
    for line in header[2:]:
        words = line.split()
        if words[0] == "element":
            if count is not None or words[1] != "vertex":
                sys.exit(f"{path}: only one element, vertex, is supported")
            count = int(words[2])
        elif words[0] == "property":
            if words[1] == "list" or words[1] not in TYPES:
                sys.exit(f"{path}: property {' '.join(words[1:])} is not supported")
            names.append(words[2])
            fmt += TYPES[words[1]]
    rows = list(struct.iter_unpack(fmt, data[end:end + count * struct.calcsize(fmt)]))
    return header, names, fmt, rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("--share", type=float, default=0.01, help="outliers per input point (0.01: 1 %%)")
    parser.add_argument("--seed", type=int, default=27)
    args = parser.parse_args()
    header, names, fmt, rows = read_ply(args.input)
    xyz = [names.index(c) for c in "xyz"]
    lo = [min(r[i] for r in rows) for i in xyz]
    hi = [max(r[i] for r in rows) for i in xyz]
    rng = random.Random(args.seed)
    added = round(args.share * len(rows))
    for _ in range(added):
        values = {name: 0 for name in names}
        for axis, name in enumerate("xyz"):
            values[name] = lo[axis] + (hi[axis] - lo[axis]) * rng.random()
        n = [rng.gauss(0.0, 1.0) for _ in range(3)]
        length = math.sqrt(sum(c * c for c in n)) or 1.0
        for c, name in zip(n, ("nx", "ny", "nz")):
            values[name] = c / length
        for name in ("red", "green", "blue"):
            values[name] = 128
        rows.append(tuple(values[name] for name in names))
    out = []
    for line in header:
        if line.startswith("element vertex"):
            out.append(f"comment {added} outliers added by add-outliers.py --share {args.share} "
                       f"--seed {args.seed}: the last points")
            line = f"element vertex {len(rows)}"
        out.append(line)
    with open(args.output, "wb") as f:
        f.write(("\n".join(out) + "\n").encode("ascii"))
        f.write(b"".join(struct.pack(fmt, *r) for r in rows))
    print(f"{args.output}: {len(rows) - added} points and {added} outliers", file=sys.stderr)


if __name__ == "__main__":
    main()
