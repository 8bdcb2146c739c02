# SPDX-License-Identifier: MIT OR Apache-2.0
"""Check make_test_groom.py's outputs without Blender: read each .hair file with an
independent reader and compare it with strands.json (0.1 mm), and check the curves groom
(moved under its own transform, resampled) still starts and ends where the particle hair does.

    python3 tools/blender/check_outputs.py assets/blender
"""
import json
import os
import struct
import sys


def read_hair(path):
    data = open(path, "rb").read()
    magic, n_strands, n_points, flags, _default_segments = struct.unpack_from("<4sIIII", data, 0)
    assert magic == b"HAIR" and flags & 3 == 3, (path, magic, flags)
    segs = struct.unpack_from(f"<{n_strands}H", data, 128)
    assert sum(s + 1 for s in segs) == n_points
    at = 128 + 2 * n_strands
    flat = struct.unpack_from(f"<{3 * n_points}f", data, at)
    at += 12 * n_points
    thick = struct.unpack_from(f"<{n_points}f", data, at) if flags & 4 else None
    at += 4 * n_points if thick else 0
    assert at == len(data), (path, at, len(data))
    strands, tstrands, i = [], [], 0
    for s in segs:
        strands.append([flat[3 * j:3 * j + 3] for j in range(i, i + s + 1)])
        if thick:
            tstrands.append(list(thick[i:i + s + 1]))
        i += s + 1
    return strands, (tstrands if thick else None)


def worst(a, b):
    assert len(a) == len(b) and all(len(s) == len(t) for s, t in zip(a, b))
    return max(max(abs(x - y) for x, y in zip(p, q)) for s, t in zip(a, b) for p, q in zip(s, t))


def main(out):
    ref = json.load(open(os.path.join(out, "strands.json")))
    ok = True
    for kind in ("particles", "curves"):
        strands, thick = read_hair(os.path.join(out, f"groom_{kind}.hair"))
        err = worst(strands, ref[kind]["strands"])
        print(f"{kind}: {len(strands)} strands, {sum(map(len, strands))} points, max |hair - blender| = {err:.2e} m")
        ok &= err < 1e-4
        if kind == "curves":
            terr = max(abs(x - y) for s, t in zip(thick, ref[kind]["thickness"]) for x, y in zip(s, t))
            print(f"curves: thickness {min(min(s) for s in thick):.6f}..{max(max(s) for s in thick):.6f} m, max err {terr:.2e}")
            ok &= terr < 1e-7
    # Same hair, two routes: roots and tips agree, so the curves' space conversion is right.
    p, c = ref["particles"]["strands"], ref["curves"]["strands"]
    ends = max(worst([[s[0], s[-1]] for s in p], [[s[0], s[-1]] for s in c]), 0)
    print(f"particles vs curves roots and tips: max diff {ends:.2e} m")
    ok &= ends < 1e-5
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


sys.exit(main(sys.argv[1]))
