#!/usr/bin/env python3
"""Writes the pyuff-made universal-file fixtures of identify/tests/io/uff.rs.

Run once (the generated files are checked in; the Rust tests need no Python):

    python3 -m venv /tmp/uffvenv
    /tmp/uffvenv/bin/pip install pyuff==2.5.8 numpy==2.4.6
    /tmp/uffvenv/bin/python scripts/make_uff_fixture.py identify/tests/data

Writes, into the given directory:

* ``uff_pyuff_ascii.uff`` -- datasets 164 (units) and 15 (nodes), which the reader must
  skip, then these datasets 58 (ASCII):
    1. FRF node 7 +X / node 7 +X, receptance (ordinate 8 displacement over 13 force),
       complex double, even spacing 0...1000 Hz step 2.5 Hz (401 lines): an analytic
       two-mode receptance (120 Hz 3 %, 310 Hz 2 %).
    2. FRF node 7 +Y / node 7 +X, accelerance (ordinate 12 acceleration), complex
       double, even spacing: -w^2 times the analytic cross receptance.
    3. Coherence node 7 +X / node 7 +X (function type 6), real double, even spacing.
    4. FRF node 8 +X / node 8 -Y, receptance, complex double, UNEVEN spacing (120
       frequencies with at most 4 significant digits, pyuff writes the abscissa in
       %13.5e); the stored values are -H_xy because the reference direction is -Y.
    5. FRF node 9 +Z / node 9 +Z, receptance, complex SINGLE precision (type 5, 6E13.5),
       even spacing.
* ``uff_pyuff_binary.uff`` -- functions 1-4 again as binary dataset 58b (pyuff writes
  little-endian doubles; its byte count in the header is wrong for complex data).
* ``uff_pyuff_values.json`` -- for each dataset 58, in file order: nodes, directions,
  function type, ordinate type, abscissa and the exact (double) values pyuff was given.
  For function 5 the values are rounded by pyuff to single precision and %13.5e.

Verified the other way once: the Rust test ``uff::writer_output_for_pyuff`` writes
``$TMPDIR/mtwin_uff_check/{ascii,binary}.uff`` plus ``values.json`` with our writer, and
``scripts/check_uff_with_pyuff.py`` reads them with pyuff 2.5.8 and compares: all fields
match, values max relative difference 1.7e-13 ASCII and 0 binary, uneven abscissa 3.4e-7
(7 significant digits in the 13-column field), even abscissa exact.
"""

import json
import os
import sys

import numpy as np
import pyuff

F = np.arange(401) * 2.5  # Hz, 0 ... 1000
MODES = [(120.0, 0.03, 2.0), (310.0, 0.02, 5.0)]  # f_n [Hz], zeta, modal mass [kg]
# modal participation of X and Y in each mode (mode shapes at the TCP)
PHI = {"x": [1.0, 0.6], "y": [0.5, -0.8]}


def receptance(f, out, inp):
    """Analytic receptance H_out,inp(f) in m/N."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    h = np.zeros(w.shape, dtype=complex)
    for k, (fn, z, m) in enumerate(MODES):
        wn = 2 * np.pi * fn
        h += PHI[out][k] * PHI[inp][k] / m / (wn**2 - w**2 + 2j * z * wn * w)
    return h


def d58(func_type, node, rsp_dir, ref_dir, x, data, ordinate, even, id1, binary=0,
        ord_data_type=None):
    complex_ = np.iscomplexobj(data)
    if ord_data_type is None:
        ord_data_type = 6 if complex_ else 4
    return pyuff.prepare_58(
        binary=binary,
        id1=id1,
        id2="analytic two-mode TCP receptance, mtwin fixture",
        id3="01-Jan-25 00:00:00",
        id4="NONE",
        id5="NONE",
        func_type=func_type,
        ver_num=0,
        load_case_id=0,
        rsp_ent_name="tcp",
        rsp_node=node,
        rsp_dir=rsp_dir,
        ref_ent_name="tcp",
        ref_node=node,
        ref_dir=ref_dir,
        ord_data_type=ord_data_type,
        num_pts=len(data),
        abscissa_spacing=1 if even else 0,
        abscissa_min=float(x[0]),
        abscissa_inc=float(x[1] - x[0]),
        z_axis_value=0.0,
        abscissa_spec_data_type=18,
        abscissa_len_unit_exp=0,
        abscissa_force_unit_exp=0,
        abscissa_temp_unit_exp=0,
        abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=ordinate,
        ordinate_len_unit_exp=1 if ordinate in (8, 12) else 0,
        ordinate_force_unit_exp=0,
        ordinate_temp_unit_exp=0,
        ordinate_axis_units_lab={8: "m", 12: "m/s^2"}.get(ordinate, "NONE"),
        orddenom_spec_data_type=13 if func_type == 4 else 0,
        orddenom_len_unit_exp=0,
        orddenom_force_unit_exp=1 if func_type == 4 else 0,
        orddenom_temp_unit_exp=0,
        orddenom_axis_units_lab="N" if func_type == 4 else "NONE",
        z_axis_spec_data_type=0,
        z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0,
        z_axis_temp_unit_exp=0,
        z_axis_axis_units_lab="NONE",
        data=data,
        x=np.asarray(x, dtype=float),
        spec_data_type=0,
    )


def functions(binary):
    w = 2 * np.pi * F
    hxx = receptance(F, "x", "x")
    ayx = -(w**2) * receptance(F, "y", "x")
    coh = 1.0 - 0.5 * np.exp(-(((F - 310.0) / 40.0) ** 2))  # a dip near the 2nd mode
    # uneven: 120 log-spaced lines 20 ... 900 Hz, 4 significant digits
    fu = np.array(sorted({float(f"{v:.4g}") for v in np.geomspace(20.0, 900.0, 120)}))
    hxy_neg = -receptance(fu, "x", "y")
    out = [
        d58(4, 7, 1, 1, F, hxx, 8, True, "H xx receptance even double", binary),
        d58(4, 7, 2, 1, F, ayx, 12, True, "A yx accelerance even double", binary),
        d58(6, 7, 1, 1, F, coh, 0, True, "coherence xx real even double", binary),
        d58(4, 8, 1, -2, fu, hxy_neg, 8, False, "H xy receptance uneven, ref -Y", binary),
    ]
    return out


def jsonable(d):
    data = np.asarray(d["data"])
    return {
        "id1": d["id1"],
        "func_type": int(d["func_type"]),
        "response_node": int(d["rsp_node"]),
        "response_dir": int(d["rsp_dir"]),
        "reference_node": int(d["ref_node"]),
        "reference_dir": int(d["ref_dir"]),
        "ordinate": int(d["ordinate_spec_data_type"]),
        "ord_data_type": int(d["ord_data_type"]),
        "even": bool(d["abscissa_spacing"]),
        "x": [float(v) for v in d["x"]],
        "re": [float(v) for v in data.real],
        "im": [float(v) for v in np.imag(data)],
    }


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else "identify/tests/data"
    os.makedirs(out_dir, exist_ok=True)
    ascii_path = os.path.join(out_dir, "uff_pyuff_ascii.uff")
    bin_path = os.path.join(out_dir, "uff_pyuff_binary.uff")
    for p in (ascii_path, bin_path):
        if os.path.exists(p):
            os.remove(p)

    units = pyuff.prepare_164(units_code=1, units_description="SI units", temp_mode=1,
                              length=1.0, force=1.0, temp=1.0, temp_offset=273.15)
    nodes = pyuff.prepare_15(node_nums=[7, 8, 9], def_cs=[0, 0, 0], disp_cs=[0, 0, 0],
                             color=[8, 8, 8], x=[0.0, 0.1, 0.2], y=[0.0, 0.0, 0.0],
                             z=[0.5, 0.5, 0.5])
    single = d58(4, 9, 3, 3, F, receptance(F, "x", "x") * 0.7, 8, True,
                 "H zz receptance even SINGLE", 0, ord_data_type=5)

    u = pyuff.UFF(ascii_path)
    u.write_sets([units, nodes], mode="add")
    fa = functions(0)
    u.write_sets(fa, mode="add")
    u.write_sets([single], mode="add", force_double=False)

    ub = pyuff.UFF(bin_path)
    ub.write_sets(functions(1), mode="add")

    values = [jsonable(d) for d in fa + [single]]
    with open(os.path.join(out_dir, "uff_pyuff_values.json"), "w") as fh:
        json.dump({"pyuff": pyuff.__version__ if hasattr(pyuff, "__version__") else "2.5.8",
                   "functions": values}, fh, indent=None)
        fh.write("\n")

    # sanity: pyuff reads back what it wrote
    back = pyuff.UFF(ascii_path).read_sets()
    n58 = sum(1 for d in back if d["type"] == 58)
    assert n58 == 5, n58
    backb = pyuff.UFF(bin_path).read_sets()
    assert sum(1 for d in backb if d["type"] == 58) == 4
    print(f"wrote {ascii_path} ({n58} x 58), {bin_path} (4 x 58b), values json")


if __name__ == "__main__":
    main()
