#!/usr/bin/env python3
"""mtwin side by side with the Python tools a user would otherwise pick, on the same data.

Run through scripts/bench_peers.sh (it sets up .venv-bench and one thread everywhere).
Builds and runs `cargo run --release --example bench_peers -- DIR` (which writes the
cases and mtwin's own results to DIR/cases.json), runs each peer on the same files and
prints one Markdown table: case | tool | fit % vs truth | time ms | speed-up of mtwin.

Fit = paper eq. 5 (identify::frf::fit_percent), worst channel, against the analytic
FRF on the case's band. Time = median wall time of several runs (data already in
memory; reading files is not timed), one thread.

Peers, used as their docs show:
* scipy: H1 = csd(f, y) / welch(f), same nfft, Hann window and overlap as mtwin (scipy's
  default constant detrend).
* sdypy-EMA: Model(frf, freq, lower, upper, pol_order_high=60, frf_form='receptance'),
  get_poles() (pLSCF), select_closest_poles(true natural frequencies: sdypy-EMA has no
  automatic pole choice, the alternative is its interactive stability chart; search
  window min(50 Hz default, band / 20)), then
  get_constants() (LSFD with lower and upper residuals). The identified model (poles,
  modal constants, residuals) is evaluated on the truth's lines.
* scikit-rf: VectorFitting on a Network whose S[:, i, 0] are the FRF channels (input x;
  the other column zero), scaled to max |H| = 1 (the tool fits S-parameters of order 1;
  its auto_fit error target is absolute); vector_fit(n_poles_real=0, n_poles_cmplx=true
  number of modes) and auto_fit() with its defaults.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.fft
import scipy.signal
import skrf
from skrf.vectorFitting import VectorFitting
from sdypy import EMA

ROOT = Path(__file__).resolve().parent.parent


def fit_percent(truth, model):
    truth = np.asarray(truth)
    model = np.asarray(model)
    den = np.linalg.norm(truth - truth.mean())
    return (1.0 - np.linalg.norm(truth - model) / den) * 100.0


def read_frf(path):
    df = pd.read_csv(path, comment="#")
    f = df["f_hz"].to_numpy()
    chans = [c[:-3] for c in df.columns if c.endswith("_re")]
    h = np.array([df[c + "_re"].to_numpy() + 1j * df[c + "_im"].to_numpy() for c in chans])
    return f, chans, h


def read_ts(path):
    df = pd.read_csv(path, comment="#")
    t = df["t"].to_numpy()
    fs = 1.0 / np.mean(np.diff(t))
    f = df["fx"].to_numpy()
    ys = np.array([df[c].to_numpy() for c in ("dx", "dy")])
    return fs, f, ys


def read_milling(path):
    df = pd.read_csv(path, comment="#")
    t = df["t"].to_numpy()
    fs = 1.0 / np.mean(np.diff(t))
    f = np.array([df["fx"].to_numpy(), df["fy"].to_numpy()])
    y = np.array([df["ax"].to_numpy(), df["ay"].to_numpy()])
    return fs, f, y


def mimo_h1(recs, nfft):
    """Two-input H1 (H = Gyf Gff^-1 per line, Welch, Hann, 50 %) over records, as
    receptance (accelerance / -w^2); channels xx, xy, yx, yy (output, input)."""
    gff = gyf = None
    for fs, f, y in recs:
        kw = dict(fs=fs, window="hann", nperseg=nfft, noverlap=nfft // 2)
        freq, _ = scipy.signal.welch(f[0], **kw)
        a = np.array([[scipy.signal.csd(f[i], f[j], **kw)[1] for j in range(2)]
                      for i in range(2)])
        b = np.array([[scipy.signal.csd(f[j], y[i], **kw)[1] for j in range(2)]
                      for i in range(2)])
        gff = a if gff is None else gff + a
        gyf = b if gyf is None else gyf + b
    sl = slice(1, nfft // 2)
    freq = freq[sl]
    G = np.moveaxis(gff[:, :, sl], 2, 0)  # (lines, in, in): G[l, i, j] = E[conj(Fi) Fj]
    Y = np.moveaxis(gyf[:, :, sl], 2, 0)  # (lines, out, in): Y[l, o, j] = E[conj(Fj) Yo]
    # H G^T = Y  ->  H = Y (G^T)^-1
    H = np.einsum("loj,lji->loi", Y, np.linalg.inv(np.transpose(G, (0, 2, 1))))
    w2 = (2 * np.pi * freq) ** 2
    h = np.array([H[:, o, i] for o in range(2) for i in range(2)]) / -w2[None, :]
    return freq, h


def timed(runs, fn):
    """(result of a first call, median ms of `runs` further calls)."""
    res = fn()
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        ts.append((time.perf_counter() - t0) * 1e3)
    return res, float(np.median(ts))


def worst_fit(freq_truth, h_truth, band, evaluate):
    """Worst channel fit of `evaluate(freqs) -> (n_ch, n_f)` vs the truth inside band."""
    m = (freq_truth >= band[0]) & (freq_truth <= band[1])
    est = evaluate(freq_truth[m])
    return min(fit_percent(h_truth[c, m], est[c]) for c in range(h_truth.shape[0]))


# ---------------------------------------------------------------- peers


def scipy_h1(fs, f, ys, nfft, overlap):
    """H1 = Gfy / Gff on lines 1 .. nfft/2 - 1 (as mtwin: no 0 Hz, no Nyquist)."""
    kw = dict(fs=fs, window="hann", nperseg=nfft, noverlap=int(round(nfft * overlap)))
    freq, pff = scipy.signal.welch(f, **kw)
    _, pfy = scipy.signal.csd(f[None, :], ys, **kw)
    h = pfy / pff[None, :]
    sl = slice(1, nfft // 2)
    return freq[sl], h[:, sl]


def fft_floor(f, ys, nfft, overlap):
    """The Hann-windowed real FFTs of every Welch segment of every column, nothing else
    (one batched scipy.fft call): the floor under any H1 estimate with these settings."""
    hop = nfft - int(round(nfft * overlap))
    x = np.vstack([f[None, :], ys])
    segs = np.lib.stride_tricks.sliding_window_view(x, nfft, axis=1)[:, ::hop]
    return scipy.fft.rfft(segs * scipy.signal.get_window("hann", nfft), axis=-1)


def sdypy_fit(freq, h, band, nat_freqs):
    # select_closest_poles' default window (50 Hz) suits kHz bands: scaled to the band
    f_window = min(50.0, (band[1] - band[0]) / 20.0)
    with warnings.catch_warnings():  # "upper outside the range, clamping" when band = data
        warnings.simplefilter("ignore", UserWarning)
        m = EMA.Model(frf=h, freq=freq, lower=band[0], upper=band[1], pol_order_high=60,
                      frf_form="receptance")
        m.get_poles(show_progress=False)
        m.select_closest_poles(list(nat_freqs), f_window=f_window)
        m.get_constants(whose_poles="own", FRF_ind="all")
    poles = np.array([m.all_poles[i][j] for i, j in m.pole_ind])
    A, LR, UR = m.A, m.LR, m.UR

    def evaluate(fr):
        jw = 2j * np.pi * fr[None, :]
        out = np.zeros((A.shape[0], len(fr)), complex)
        for k, p in enumerate(poles):
            out += A[:, k:k + 1] / (jw - p) + np.conj(A[:, k:k + 1]) / (jw - np.conj(p))
        out += -LR[:, None] / (2 * np.pi * fr[None, :]) ** 2 + UR[:, None]
        return out

    return evaluate


def skrf_fit(freq, h, band, n_modes, auto):
    m = (freq >= band[0]) & (freq <= band[1])
    fr, hb = freq[m], h[:, m]
    scale = np.abs(hb).max()
    nch = hb.shape[0]
    s = np.zeros((len(fr), nch, nch), complex)
    s[:, :, 0] = (hb / scale).T
    nw = skrf.Network(frequency=skrf.Frequency.from_f(fr, unit="hz"), s=s)
    vf = VectorFitting(nw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if auto:
            vf.auto_fit()
        else:
            vf.vector_fit(n_poles_real=0, n_poles_cmplx=n_modes)

    def evaluate(f_eval):
        return np.array([vf.get_model_response(c, 0, f_eval) for c in range(nch)]) * scale

    return evaluate, len(vf.poles)


FITTERS = {
    "sdypy-EMA pLSCF (true frequencies given)": lambda fr, h, band, nat: (
        sdypy_fit(fr, h, band, nat), None),
    "scikit-rf vector_fit (true order)": lambda fr, h, band, nat: skrf_fit(
        fr, h, band, len(nat), auto=False),
    "scikit-rf auto_fit": lambda fr, h, band, nat: skrf_fit(fr, h, band, len(nat), auto=True),
}


# ---------------------------------------------------------------- table


class Table:
    def __init__(self):
        self.rows = []

    def mtwin(self, case, tool, fit, ms):
        self.base = ms
        self.rows.append((case, tool, f"{fit:.3f}", f"{ms:.1f}", "(base)"))

    def peer(self, case, tool, fn):
        try:
            fit, ms, extra = fn()
            label = tool + (f" [{extra}]" if extra else "")
            self.rows.append((case, label, f"{fit:.3f}", f"{ms:.1f}",
                              f"{ms / self.base:.1f}x"))
        except Exception as e:  # a peer failing is a result too
            msg = f"{type(e).__name__}: {e}".replace("|", "/").replace("\n", " ")[:160]
            self.rows.append((case, tool, f"failed: {msg}", "-", "-"))
        print(" | ".join(self.rows[-1]), file=sys.stderr, flush=True)

    def markdown(self):
        out = ["| case | tool | fit % vs truth | time ms | speed-up of mtwin |",
               "| --- | --- | ---: | ---: | ---: |"]
        out += ["| " + " | ".join(r) + " |" for r in self.rows]
        return "\n".join(out)


def fit_case(tab, case, data_frf, truth, band, nat, runs):
    """Every fitter on one FRF: (freq, h) measured, (freq, h) truth."""
    fr, h = data_frf
    ft, ht = truth
    for name, fitter in FITTERS.items():
        def one(fitter=fitter):
            (ev, npoles), ms = timed(runs, lambda: fitter(fr, h, band, nat))
            extra = f"{npoles} poles" if npoles is not None and "auto" in name else ""
            return worst_fit(ft, ht, band, ev), ms, extra
        tab.peer(case, name, one)



def all_cores_row(tab, case, c, what, how):
    """The row of mtwin's all-cores time of a case (if measured), its speed-up against the
    case's peers (all single-threaded) as the most accurate and the fastest one."""
    par = c.get("mtwin_all_cores")
    if not par:
        return
    peers = [(float(r[2]), float(r[3])) for r in tab.rows
             if r[0] == case and r[1].startswith("scipy") and r[2] != "-" and r[3] != "-"]
    if peers:
        acc = max(peers)
        fast = min(peers, key=lambda p: p[1])
        ratio = f"{acc[1] / par['ms']:.1f}x vs the most accurate peer"
        if fast != acc:
            ratio += f", {fast[1] / par['ms']:.1f}x vs the fastest"
    else:
        ratio = "-"
    tab.rows.append((case, f"{what} on all {par['threads']} cores ({how}; every peer runs "
                     "on one)", f"{c['mtwin']['fit']:.3f}", f"{par['ms']:.1f}", ratio))

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dir", help="case directory (default: a temporary one)")
    ap.add_argument("--out", help="also write the Markdown report here")
    ap.add_argument("--no-build", action="store_true", help="reuse DIR/cases.json")
    args = ap.parse_args()
    tmp = None
    if args.dir:
        d = Path(args.dir)
    else:
        tmp = tempfile.TemporaryDirectory(prefix="mtwin-bench-")
        d = Path(tmp.name)
    if not args.no_build:
        subprocess.run(["cargo", "run", "--release", "-q", "--example", "bench_peers", "--",
                        str(d)], cwd=ROOT, check=True, stdout=sys.stderr)
    cases = json.loads((d / "cases.json").read_text())
    tab = Table()

    # a. FRF estimation
    c = cases["a_frf"]
    band = tuple(c["band"])
    fs, f, ys = read_ts(c["timeseries"])
    ft, _, ht = read_frf(c["truth"])
    tab.mtwin("a. FRF estimation, 60 s noise, 2 ch", "mtwin estimate_frf (H1, Welch)",
              c["mtwin"]["fit"], c["mtwin"]["ms"])

    def a_scipy():
        (fr, h), ms = timed(5, lambda: scipy_h1(fs, f, ys, c["nfft"], c["overlap"]))
        assert np.allclose(fr, ft), "scipy lines differ from mtwin's"
        m = (ft >= band[0]) & (ft <= band[1])
        return min(fit_percent(ht[k, m], h[k, m]) for k in range(2)), ms, ""
    tab.peer("a. FRF estimation, 60 s noise, 2 ch",
             f"scipy csd/welch H1 (nfft {c['nfft']}, Hann, 50 %)", a_scipy)
    all_cores_row(tab, "a. FRF estimation, 60 s noise, 2 ch", c, "mtwin estimate_frf",
                  "rayon across segments")
    fl = c["fft_floor"]
    _, floor_ms = timed(9, lambda: fft_floor(f, ys, c["nfft"], c["overlap"]))
    tab.rows.append(("a. floor: the windowed FFTs alone",
                     f"{fl['ffts']} Hann-windowed real FFTs of {c['nfft']}: rustfft (as in mtwin) "
                     f"{fl['ms']:.1f} ms, scipy.fft {floor_ms:.1f} ms", "-", f"{fl['ms']:.1f}",
                     "-"))

    # b. one pose, 8 modes
    c = cases["b_fit"]
    case = "b. 8 modes, 2 ch, 2000 lines, 1 % noise"
    fr, _, h = read_frf(c["frf"])
    ft, _, ht = read_frf(c["truth"])
    tab.mtwin(case, f"mtwin fit_frf (automatic order: {c['mtwin']['modes']} modes)",
              c["mtwin"]["fit"], c["mtwin"]["ms"])
    fit_case(tab, case, (fr, h), (ft, ht), tuple(c["band"]), c["natural_freqs_hz"], 5)

    # c. paper chain
    c = cases["c_chain"]
    case = "c. paper 3-DoF chain, chirp, 0.1 % noise"
    fr, _, h = read_frf(c["frf"])
    ft, _, ht = read_frf(c["truth"])
    tab.mtwin(case, f"mtwin fit_frf (automatic order: {c['mtwin']['modes']} modes)",
              c["mtwin"]["fit"], c["mtwin"]["ms"])
    fit_case(tab, case, (fr, h), (ft, ht), tuple(c["band"]), c["natural_freqs_hz"], 5)

    # d. campaign
    c = cases["d_campaign"]
    n = len(c["poses"])
    case = f"d. campaign, {n} poses, 10 s noise each (worst pose)"
    band = tuple(c["band"])
    poses = []
    for p in c["poses"]:
        ft, _, ht = read_frf(p["truth"])
        poses.append((read_ts(p["timeseries"]), (ft, ht), p["natural_freqs_hz"]))
    tab.mtwin(case, "mtwin identify_campaign", c["mtwin"]["fit"], c["mtwin"]["ms"])
    for name, fitter in FITTERS.items():
        def one(fitter=fitter):
            t0 = time.perf_counter()
            models = []
            for (fs, f, ys), _, nat in poses:
                fr, h = scipy_h1(fs, f, ys, c["nfft"], c["overlap"])
                models.append(fitter(fr, h, band, nat)[0])
            ms = (time.perf_counter() - t0) * 1e3
            worst = min(worst_fit(tr[0], tr[1], band, ev) for ev, (_, tr, _) in
                        zip(models, poses))
            return worst, ms, ""
        tab.peer(case, "scipy H1 + " + name, one)
    all_cores_row(tab, case, c, "mtwin identify_campaign", "rayon across poses")

    # e. FMU
    c = cases["e_fmu"]["mtwin"]
    tab.rows.append(("e. FMU doStep (9 modes, 2 axes, moving pose)",
                     f"mtwin slave core, set_real + get_real + do_step "
                     f"({c['us_per_step']:.2f} µs per step)", "-",
                     f"{c['us_per_step'] / 1e3:.5f}", "-"))
    tab.rows.append(("e. FMU doStep", "no Python peer; through the C API see "
                     "`cargo bench -p mtwin-fmu --bench do_step`, scripts/bench_fmu_share.py",
                     "-", "-", "-"))

    # f. refit from milling data
    c = cases["f_refit"]
    case = "f. refit from milling, mode 2 -15 %, 3 speeds x 15 s (worst of xx, yy)"
    band = tuple(c["band"])
    ft, chans, ht = read_frf(c["truth"])
    direct = [i for i, ch in enumerate(chans) if ch[0] == ch[1]]
    ht = ht[direct]
    recs = [read_milling(p) for p in c["records"]]
    first = True
    for name in ("time", "modal", "paper"):
        m = c["mtwin"][name]
        label = {"time": "mtwin refit --method time (default)",
                 "modal": "mtwin refit --method modal",
                 "paper": "mtwin refit --method paper (the paper's intermediate FRF)"}[name]
        if first:
            tab.mtwin(case, label, m["fit"], m["ms"])
            first = False
        else:
            tab.rows.append((case, label, f"{m['fit']:.3f}", f"{m['ms']:.1f}",
                             f"{m['ms'] / tab.base:.1f}x"))

    def f_peer(auto):
        def one():
            t0 = time.perf_counter()
            fr, h = mimo_h1(recs, c["nfft"])
            ev, npoles = skrf_fit(fr, h, band, len(c["natural_freqs_hz"]), auto=auto)
            ms = (time.perf_counter() - t0) * 1e3
            worst = worst_fit(ft, ht, band, lambda f: ev(f)[[0, 3]])
            return worst, ms, f"{npoles} poles" if auto else ""
        return one
    tab.peer(case, "scipy 2-input H1 of the milling data + scikit-rf auto_fit (re-identify)",
             f_peer(True))
    tab.peer(case, "scipy 2-input H1 + scikit-rf vector_fit (true order)", f_peer(False))

    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo")
                if ln.startswith("model name")), platform.processor())
    rustc = subprocess.run(["rustc", "--version"], capture_output=True, text=True).stdout.strip()
    pk = ", ".join(f"{p} {version(p)}" for p in ("numpy", "scipy", "sdypy-EMA", "scikit-rf"))
    head = [
        "# mtwin and its Python peers, side by side",
        "",
        f"Date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. Machine: {os.cpu_count()} "
        f"cores (`nproc`), {cpu}. One thread everywhere (RAYON_NUM_THREADS=1, "
        "OPENBLAS/OMP/MKL_NUM_THREADS=1).",
        f"{rustc}; Python {platform.python_version()}: {pk}.",
        "",
        "Command: `scripts/bench_peers.sh` (data and mtwin's numbers from "
        "`cargo run --release --example bench_peers -- DIR`, the peers from "
        "`scripts/bench_peers.py`).",
        "",
        "Fit % = paper eq. 5 (`identify::frf::fit_percent`) against the analytic FRF, worst "
        "channel, on the case's band (a, d: 20-2000 Hz; b: 20-2019 Hz; c: 0.2-40 Hz). "
        "Time = median wall time of several runs, data in memory (d: one pass over "
        "all poses for the peers, median of 3 for mtwin). "
        "Speed-up = peer time / mtwin time.",
        "",
    ]
    notes = [
        "",
        "Notes:",
        "* sdypy-EMA is given the TRUE natural frequencies to pick its poles "
        "(`select_closest_poles`): it has no automatic choice (its alternative is the "
        "interactive stability chart). pLSCF with `pol_order_high=60`, LSFD with residuals; "
        "the pole search window `f_window` is its default 50 Hz capped at band / 20 (c: 2 Hz; "
        "with the default 50 Hz it picks no pole on the 0.2-40 Hz chain, fit 0.2 %). "
        "In b it takes the 410 Hz pole twice (425 Hz missed) and two poles near 1550 Hz "
        "(1900 Hz missed); d was not investigated.",
        "* scikit-rf `vector_fit` is given the true number of modes as complex poles; "
        "`auto_fit` chooses the order itself (poles kept in brackets). The FRF is scaled to "
        "max |H| = 1 before fitting (the tool expects S-parameters).",
        "* mtwin chooses the order itself in every case (b, d: default options; c: the options "
        "of `examples/paper_3dof.rs`, uniform weight). In b it keeps 6 of the 8 modes (the "
        "two weak high modes stay below the noise of the largest peak under its default "
        "coherence weighting, see identify/benches/identify.rs). Case d for mtwin fits each pose with coherence and with "
        "inverse-variance weighting and keeps the better fit to the measured FRF, tracks modes "
        "across poses and checks the pose interpolation (leave one out); the peers only do H1 "
        "and one fit per pose.",
        "* f: mtwin starts from the twin before the wear (exact) and updates it; the speed-up "
        "column of its own `modal` and `paper` rows is relative to `time` (below 1 = faster than "
        "`time`). The Python peers have no refit from a previous model: they re-identify the "
        "2-input H1 of the same milling records (same nfft, Hann, 50 %) in 30-1500 Hz.",
        "* a: the mtwin and scipy H1 use the same nfft, periodic Hann window and 50 % "
        "overlap; scipy removes each segment's mean (its default), mtwin does not.",
        "* a, floor: only the Hann-windowed real FFTs every Welch H1 with these settings needs "
        "(each segment of the force and both responses), nothing else; rustfft in mtwin's "
        "loop, scipy.fft in one batched call. Any H1 at 10x scipy's speed would have to fit "
        "in about the time of these FFTs alone.",
        "* a, d, all cores: the same call inside a rayon pool of `available_parallelism()` "
        "threads (a: one Welch segment per thread windowed and transformed at a time, the "
        "spectra added in chunks of lines, each line in segment order, so the FRF is the same "
        "bit for bit; d: poses' FRFs and fits in parallel, the mode tracking across poses in "
        "sequence). Every other row, mtwin's included, is one thread. scipy's csd/welch has "
        "no option to use more cores.",
        "* The machine is shared (other checkouts may build at the same time): times vary by "
        "up to about 30 % between runs of the script; the fits do not change.",
    ]
    text = "\n".join(head) + "\n" + tab.markdown() + "\n" + "\n".join(notes) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
