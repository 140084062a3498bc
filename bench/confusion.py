#!/usr/bin/env python3
"""Confusion tables of `mtwin diagnose`, defaults only, on every generator we have:

- `vmachine` (our first generator): `cargo run --release --example diagnose_confusion`,
  impact and milling tables;
- `lumped` (the second, structurally different generator), see below;
- the independent tryout generator's four cases (`../shared/data/tryout_gantry/diagnose`),
  diagnosed against the twin identified from its campaign.

    python3 bench/confusion.py [SEEDS] [vmachine|lumped|tryout|all] [--random-machine] [-v]
        [--rows=healthy,cross_coupling,...]   (lumped: only these hidden effects)
        [--keep=DIR]   (lumped: keep each seed's generated data in DIR/seedN and reuse it
                        when it is there; the twin is identified again every run)
        [--twin-noise=S]   (lumped: the twin's centre impact test made again with its
                        accelerometer's noise scaled by S, `cases --centre-only
                        --centre-noise S`; the cases keep theirs: S = 0.1 gives a sound
                        twin down to the band's lower edge)

(default 5 seeds, all). `lumped`: for each seed: `lumped`'s `cases` example writes a healthy impact test at the centre and
one folder per hidden effect (parameters drawn from the seed) with the SPEC section 4
answer, and two healthy rows: milling (`healthy`) and impact hits at three force levels
on the machine without the nonlinearity case's spring (`healthy_impact`); mode change, new
mode, delay and cross coupling are also recorded in milling (rows `*_milling`: the same
drawn effect, two cuts instead of the impact tests); `mtwin identify` makes a one-pose twin from the healthy impacts with default
options; `mtwin diagnose` runs on every folder with default options. Rows = the effect
hidden, columns = the cause found; "numbers right" as in the vmachine table
(`examples/diagnose_confusion.rs`): frequencies within 1 % (2 % for the nonlinear mode),
delay within 10 %, the pose-dependence rate within 20 % or 5 %/m, the right
channel/axis of variation/kind; every true disturbance frequency found within 1 %.
For the milled effects the answers also say how much the effect changes the noise-free
cuts (`milling_response_change`); each such row is split by it (below / at least 10 %).

Builds what it needs (`cargo build --release`), works in a temporary folder, prints a
Markdown table; `-v` prints every miss.
"""
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGET = os.environ.get("CARGO_TARGET_DIR") or os.path.join(ROOT, "target")
MTWIN = os.path.join(TARGET, "release", "mtwin")
CASES = os.path.join(TARGET, "release", "examples", "cases")
CAUSES = ["none", "mode_change", "unmodeled_mode", "time_delay", "disturbance",
          "cross_coupling", "pose_dependence", "nonlinearity", "unexplained"]
ROWS = ["healthy", "healthy_impact", "mode_change", "unmodeled_mode", "time_delay", "disturbance",
        "cross_coupling", "pose_dependence", "nonlinearity", "mode_change_milling",
        "unmodeled_mode_milling", "time_delay_milling", "cross_coupling_milling"]


def close(a, b, rel):
    return a is not None and b is not None and abs(a / b - 1.0) <= rel


def numbers_right(truth, got):
    cause = truth["cause"]
    t, g = truth["details"], got.get("details", {})
    if cause == "none":
        return True
    if cause == "disturbance":
        found = g.get("freq_hz") or []
        return all(any(close(f, w, 0.01) for f in found) for w in t["freq_hz"])
    if cause == "time_delay":
        return close(g.get("delay_s"), t["delay_s"], 0.1)
    if cause == "pose_dependence":
        want, rate = t["freq_shift_pct_per_m"], g.get("freq_shift_pct_per_m")
        return (g.get("axis_of_variation") == t["axis_of_variation"] and rate is not None
                and (abs(rate - want) <= 0.2 * abs(want) or abs(rate - want) <= 5.0))
    if cause == "cross_coupling":
        # a mode turned into another axis shows in both cross channels (reciprocity)
        channels = {t["channel"], t.get("reciprocal_channel", t["channel"])}
        return g.get("channel") in channels and close(g.get("freq_hz"), t["freq_hz"], 0.01)
    if cause == "nonlinearity":
        return g.get("kind") == t.get("kind", g.get("kind")) and close(
            g.get("freq_hz"), t["freq_hz"], 0.02)
    return close(g.get("freq_hz"), t["freq_hz"], 0.01)


def run(args):
    return subprocess.run(args, capture_output=True, text=True)


def lumped(seeds, random_machine, verbose, rows=ROWS, keep=None, twin_noise=None):
    table = {r: {c: 0 for c in CAUSES} for r in rows}
    right = {r: 0 for r in rows}
    # milled effects: (cause right, how much the effect changes the noise-free cuts)
    shown = {r: [] for r in rows}
    t0 = time.time()
    for seed in range(1, seeds + 1):
        with tempfile.TemporaryDirectory() as tmp:
            d = os.path.join(keep, f"seed{seed}") if keep else tmp
            extra = ["--random-machine"] if random_machine else []
            kept = os.path.join(d, "diagnose", "answers.json")
            if not os.path.exists(kept) or any(r not in json.load(open(kept)) for r in rows):
                o = run([CASES, "--out", d, "--seed", str(seed)] + extra)
                if o.returncode:
                    sys.exit(o.stderr)
            # the centre impact test as `cases` writes it, at the noise asked for
            if twin_noise is not None or keep:
                o = run([CASES, "--out", d, "--seed", str(seed), "--centre-only",
                         "--centre-noise", str(1.0 if twin_noise is None else twin_noise)]
                        + extra)
                if o.returncode:
                    sys.exit(o.stderr)
            imp = [os.path.join(d, "centre_impact", f)
                   for f in sorted(os.listdir(os.path.join(d, "centre_impact")))]
            twin = os.path.join(d, "twin.json")
            o = run([MTWIN, "identify", "-q"] + imp + ["--out", twin])
            if o.returncode:
                print(f"seed {seed}: identify failed: {o.stderr.strip()}", file=sys.stderr)
                continue
            answers = json.load(open(os.path.join(d, "diagnose", "answers.json")))
            for row in rows:
                cause, ok, got = diagnose_case(twin, os.path.join(d, "diagnose", row),
                                               answers[row], d, f"seed {seed}")
                table[row][cause] += 1
                change = answers[row]["details"].get("milling_response_change")
                if change is not None:
                    shown[row].append((cause == answers_cause(row), change))
                if ok:
                    right[row] += 1
                elif verbose and got is not None:
                    print(f"seed {seed} {row}: found {cause} {json.dumps(got.get('details'))[:300]}"
                          f" | truth {json.dumps(answers[row]['details'])[:200]}", file=sys.stderr)
    kind = "random machine per seed" if random_machine else "nominal machine"
    print(f"## diagnose confusion table, second generator `lumped` ({seeds} seeds per hidden"
          f" effect, {kind}, one-pose twin from a healthy centre impact test, defaults only)\n")
    print("| hidden \\ found | " + " | ".join(CAUSES) + " | numbers right |")
    print("|---|" + "---:|" * len(CAUSES) + "---:|")
    for r in rows:
        print(f"| {r} | " + " | ".join(str(table[r][c]) for c in CAUSES)
              + f" | {right[r]}/{seeds} |")
    correct = sum(table[r][answers_cause(r)] for r in rows)
    for kind, pick in (("impact-effect", lambda r: not r.startswith("healthy")
                        and not r.endswith("_milling") and r != "disturbance"),
                       ("milling-effect", lambda r: r.endswith("_milling") or r == "disturbance"),
                       ("healthy", lambda r: r.startswith("healthy"))):
        sel = [r for r in rows if pick(r)]
        if sel:
            ok = sum(table[r][answers_cause(r)] for r in sel)
            print(f"\n{kind} rows ({', '.join(sel)}): cause right in {ok}/{seeds * len(sel)}")
    # the answers say how much a milled effect changes the noise-free cuts (RMS of the
    # response without its mean, held-out part): an effect smaller than the twin's own
    # misfit of healthy cuts cannot be told from it
    for r in rows:
        if shown[r]:
            small = [ok for ok, c in shown[r] if c < 0.1]
            large = [ok for ok, c in shown[r] if c >= 0.1]
            print(f"\n{r}: cause right in {sum(small)}/{len(small)} where the effect changes the "
                  f"cuts by < 10 %, {sum(large)}/{len(large)} where by >= 10 %")
    print(f"\ncause right in {correct}/{seeds * len(rows)} cases, numbers right in "
          f"{sum(right.values())}; {time.time() - t0:.0f} s\n")


def diagnose_case(twin, folder, truth, work, tag):
    """(cause found, cause and numbers right, the diagnosis JSON or None)."""
    files = [os.path.join(folder, f) for f in sorted(os.listdir(folder))]
    out = os.path.join(work, "out_" + os.path.basename(folder))
    o = run([MTWIN, "diagnose", "-q", "--twin", twin] + files + ["--out", out])
    if o.returncode:
        print(f"{tag} {os.path.basename(folder)}: diagnose failed: {o.stderr.strip()}",
              file=sys.stderr)
        return "unexplained", False, None
    got = json.load(open(os.path.join(out, "diagnosis.json")))
    cause = got.get("cause", "unexplained")
    cause = cause if cause in CAUSES else "unexplained"
    return cause, cause == truth["cause"] and numbers_right(truth, got), got


def tryout():
    root = os.path.join(ROOT, "..", "shared", "data", "tryout_gantry")
    if not os.path.isdir(root):
        print("## tryout cases: ../shared/data/tryout_gantry not found\n")
        return
    t0 = time.time()
    with tempfile.TemporaryDirectory() as d:
        camp = os.path.join(root, "campaign")
        twin = os.path.join(d, "twin.json")
        o = run([MTWIN, "identify", "-q"]
                + [os.path.join(camp, f) for f in sorted(os.listdir(camp))] + ["--out", twin])
        if o.returncode:
            sys.exit(o.stderr)
        answers = json.load(open(os.path.join(root, "diagnose", "answers.json")))
        print("## tryout cases (independent generator; twin from its campaign, defaults only)\n")
        print("| case | truth | found | numbers right | held-out fit before → after [%] |")
        print("|---|---|---|---|---|")
        right = 0
        for case, truth in answers.items():
            cause, ok, got = diagnose_case(twin, os.path.join(root, "diagnose", case), truth, d,
                                           "tryout")
            right += ok
            fits = (f"{got['fit_before_pct']:.2f} → {got['fit_after_pct']:.2f}"
                    if got else "—")
            print(f"| {case} | {truth['cause']} | {cause} | {'yes' if ok else 'no'} | {fits} |")
        print(f"\n{right}/{len(answers)} right; {time.time() - t0:.0f} s\n")


def main():
    argv = [a for a in sys.argv[1:] if not a.startswith("-")]
    seeds = int(argv[0]) if argv else 5
    which = argv[1] if len(argv) > 1 else "all"
    random_machine = "--random-machine" in sys.argv
    verbose = "-v" in sys.argv
    rows = next((a.split("=", 1)[1].split(",") for a in sys.argv if a.startswith("--rows=")), ROWS)
    if any(r not in ROWS for r in rows):
        sys.exit(f"--rows: one of {', '.join(ROWS)}")
    keep = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--keep=")), None)
    twin_noise = next((float(a.split("=", 1)[1]) for a in sys.argv
                       if a.startswith("--twin-noise=")), None)
    b = run(["cargo", "build", "--release", "-q", "--bin", "mtwin"])
    c = run(["cargo", "build", "--release", "-q", "-p", "lumped", "--example", "cases"])
    if b.returncode or c.returncode:
        sys.exit(b.stderr + c.stderr)
    if which in ("vmachine", "all"):
        sys.stdout.flush()
        subprocess.run(["cargo", "run", "--release", "-q", "--example", "diagnose_confusion",
                        "--", str(seeds), "both"], cwd=ROOT)
    if which in ("lumped", "all"):
        lumped(seeds, random_machine, verbose, rows, keep, twin_noise)
    if which in ("tryout", "all"):
        tryout()


def answers_cause(row):
    return "none" if row.startswith("healthy") else row.removesuffix("_milling")


if __name__ == "__main__":
    main()
