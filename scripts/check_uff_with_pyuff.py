#!/usr/bin/env python3
"""Checks that pyuff reads the universal files written by mtwin (identify::uff).

    cargo test -p identify --test identify io::uff::writer_output_for_pyuff   # writes the files
    /tmp/uffvenv/bin/python scripts/check_uff_with_pyuff.py [DIR]

DIR defaults to $TMPDIR/mtwin_uff_check (``ascii.uff``, ``binary.uff``, ``values.json``,
written by that test). Reads both files with pyuff, compares nodes, directions, function
types, abscissa and values against the JSON, prints the max relative differences and exits
non-zero on a mismatch.

Result with pyuff 2.5.8 / numpy 2.4.6 (4 functions: complex even, complex uneven, real
uneven, real even), run once when the writer was added: all fields match; ASCII values
max relative difference 1.7e-13 (13-14 significant digits written), abscissa 3.4e-7 (an
uneven abscissa has 7 significant digits in its 13-column field); binary values and
abscissa exact.
"""

import json
import os
import sys
import tempfile

import numpy as np
import pyuff


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.join(tempfile.gettempdir(),
                                                           "mtwin_uff_check")
    want = json.load(open(os.path.join(d, "values.json")))
    ok = True
    for name, tol_v, tol_x in (("ascii.uff", 1e-12, 1e-6), ("binary.uff", 0.0, 0.0)):
        sets = [s for s in pyuff.UFF(os.path.join(d, name)).read_sets() if s["type"] == 58]
        if len(sets) != len(want):
            print(f"{name}: {len(sets)} datasets 58, expected {len(want)}")
            ok = False
            continue
        worst_v = worst_x = 0.0
        for s, w in zip(sets, want):
            for k_py, k_w in (("func_type", "func_type"), ("rsp_node", "rsp_node"),
                              ("rsp_dir", "rsp_dir"), ("ref_node", "ref_node"),
                              ("ref_dir", "ref_dir")):
                if int(s[k_py]) != int(w[k_w]):
                    print(f"{name} {w['id1']}: {k_py} {s[k_py]} != {w[k_w]}")
                    ok = False
            if s["id1"].strip() != w["id1"]:
                print(f"{name}: id1 {s['id1']!r} != {w['id1']!r}")
                ok = False
            x = np.asarray(s["x"], dtype=float)
            wx = np.asarray(w["x"])
            z = np.asarray(s["data"])
            wz = np.asarray(w["re"]) + 1j * np.asarray(w["im"])
            if x.shape != wx.shape or z.shape != wz.shape:
                print(f"{name} {w['id1']}: shape {x.shape}/{z.shape} vs {wx.shape}/{wz.shape}")
                ok = False
                continue
            rx = np.max(np.abs(x - wx) / np.maximum(np.abs(wx), 1e-300))
            rv = np.max(np.abs(z - wz) / np.maximum(np.abs(wz), 1e-300))
            worst_v, worst_x = max(worst_v, rv), max(worst_x, rx)
        print(f"{name}: max relative difference values {worst_v:.2e}, abscissa {worst_x:.2e}")
        if worst_v > tol_v or worst_x > tol_x:
            ok = False
    print("OK" if ok else "MISMATCH")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
