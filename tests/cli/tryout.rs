//! Defaults only (files and `--out`), on data mtwin did not generate: the tryout gantry
//! campaign and log sweep from an independent generator (`../shared/data/tryout_gantry`,
//! judged against its analytic truth) and the real impact-hammer file (judged against a
//! plain per-hit H1 of its raw samples).

use crate::common::{f64_list, mtwin, pose_of, s, shared_data, stderr, tmp};
use identify::axis::{Axis, Channel};
use identify::frf::{fit_percent, Frf};
use identify::interpolate::TwinEvaluator;
use identify::read::read_frf_csv;
use identify::twin::Twin;
use num_complex::Complex64;
use std::path::{Path, PathBuf};

fn tryout(rel: &str) -> PathBuf {
    shared_data().join("tryout_gantry").join(rel)
}

fn channel(frf: &Frf, ch: Channel) -> &[Complex64] {
    &frf.channels
        .iter()
        .find(|c| c.channel == ch)
        .unwrap_or_else(|| panic!("channel {ch} missing"))
        .h
}

/// `h` on `freqs` linearly interpolated (real and imaginary parts) at `at`.
fn interp(freqs: &[f64], h: &[Complex64], at: f64) -> Complex64 {
    let k = freqs.partition_point(|f| *f < at).clamp(1, freqs.len() - 1);
    let t = (at - freqs[k - 1]) / (freqs[k] - freqs[k - 1]);
    h[k - 1] * (1.0 - t) + h[k] * t
}

/// Fit [%] of the twin at `pose` against `truth` for channel `ch` in `band`.
fn twin_vs_truth(twin: &Twin, truth: &Frf, pose: [f64; 3], ch: Channel, band: (f64, f64)) -> f64 {
    let m = twin.model_at(pose).expect("model at pose");
    let ci = m.channel_index(ch).expect("channel in the twin");
    let (mut t, mut e) = (Vec::new(), Vec::new());
    for (k, &f) in truth.freqs_hz.iter().enumerate() {
        if f >= band.0 && f <= band.1 {
            t.push(channel(truth, ch)[k]);
            e.push(m.eval_hz(ci, f));
        }
    }
    fit_percent(&t, &e)
}

/// The tryout campaign's record files, sorted.
fn campaign_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(tryout("campaign"))
        .expect("campaign folder")
        .map(|e| e.expect("entry").path())
        .collect();
    files.sort();
    files
}

/// The campaign's record files whose names start with `prefix` (`g01_`: a pose's two).
fn pose_files(prefix: &str) -> Vec<PathBuf> {
    (campaign_files().into_iter())
        .filter(|f| {
            f.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(prefix))
        })
        .collect()
}

/// `mtwin frf -q FILES --out OUT`, which must succeed.
fn frf(files: &[PathBuf], out: &Path) {
    let mut args = vec!["frf", "-q"];
    args.extend(files.iter().map(|f| s(f)));
    args.extend(["--out", s(out)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
}

fn identify(files: &[PathBuf], out: &Path) -> Twin {
    let mut args: Vec<&str> = vec!["identify", "-q"];
    args.extend(files.iter().map(|f| s(f)));
    args.extend(["--out", s(out)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    Twin::load(out).expect("the written twin loads")
}

#[test]
fn tryout_campaign_twin_fits_the_truth_better_than_its_own_h1() {
    let dir = tmp();
    let files = campaign_files();
    let twin = identify(&files, &dir.path().join("twin.json"));
    assert_eq!(twin.poses.len(), 12);
    let xx = Channel::new(Axis::X, Axis::X);
    let yy = Channel::new(Axis::Y, Axis::Y);
    let band = (30.0, 2500.0);
    // z responses to x/y hammers carry only noise here (the truth's zx, zy are zero):
    // the plan leaves them out and says so
    for p in &twin.poses {
        let plan = p.plan.as_ref().expect("plan stored with every pose");
        for out in [Axis::X, Axis::Y] {
            let d = plan
                .channels
                .iter()
                .find(|c| c.channel == Channel::new(Axis::Z, out))
                .expect("z channel judged");
            assert!(!d.used && d.reason.contains("not identified"), "{d:?}");
        }
        assert!(p
            .model
            .channel_index(Channel::new(Axis::Z, Axis::X))
            .is_none());
    }
    let mut worst_measured = f64::INFINITY;
    for i in 0..12 {
        let truth_path = tryout(&format!("truth/g{i:02}.csv"));
        let truth = read_frf_csv(&truth_path).expect("truth");
        let pose = pose_of(&truth_path);
        for (ch, axis) in [(xx, "x"), (yy, "y")] {
            // mtwin's own H1 of that pose's file, onto the truth's lines
            let h1_path = dir.path().join(format!("h1_{i}_{axis}.csv"));
            let src = tryout(&format!("campaign/g{i:02}_{axis}.csv"));
            let o = mtwin(&["frf", "-q", s(&src), "--out", s(&h1_path)]);
            assert!(o.status.success(), "{}", stderr(&o));
            let h1 = read_frf_csv(&h1_path).expect("h1");
            let (mut t, mut e) = (Vec::new(), Vec::new());
            for (k, &f) in truth.freqs_hz.iter().enumerate() {
                if f >= band.0 && f <= band.1 {
                    t.push(channel(&truth, ch)[k]);
                    e.push(interp(&h1.freqs_hz, channel(&h1, ch), f));
                }
            }
            let h1_fit = fit_percent(&t, &e);
            let twin_fit = twin_vs_truth(&twin, &truth, pose, ch, band);
            eprintln!("g{i:02} {ch}: twin {twin_fit:.2} %, own H1 {h1_fit:.2} %");
            assert!(
                twin_fit >= h1_fit,
                "pose g{i:02} {ch}: the twin fits the truth at {twin_fit:.2} %, worse than the H1 it came from ({h1_fit:.2} %)"
            );
            worst_measured = worst_measured.min(twin_fit);
        }
        // modal consistency: the tryout's 88 Hz mode moves only along x (machine.json), so
        // yy holds nothing of it; a free fit per channel left a stray residue there, a dip
        // of 1.1-4.3 % against the truth at 70-100 Hz at every pose. Rank-one residues
        // between the hammered directions remove it.
        let m = twin.model_at(pose).expect("model at pose");
        let ci = m.channel_index(yy).expect("yy");
        let worst_dip = truth
            .freqs_hz
            .iter()
            .enumerate()
            .filter(|(_, f)| **f >= 70.0 && **f <= 100.0)
            .map(|(k, f)| {
                let t = channel(&truth, yy)[k];
                (m.eval_hz(ci, *f) - t).norm() / t.norm()
            })
            .fold(0.0, f64::max);
        eprintln!(
            "g{i:02} yy 70-100 Hz: largest error {:.2} %",
            100.0 * worst_dip
        );
        assert!(
            worst_dip < 0.01,
            "pose g{i:02} yy 70-100 Hz: {:.2} % off the truth (a trace of the x mode)",
            100.0 * worst_dip
        );
    }
    // unmeasured poses: no worse than the worst measured pose minus 2 points (two modes
    // cross near (0.6, 0.15, 0.25): their split there comes from the other poses)
    for u in 0..3 {
        let truth_path = tryout(&format!("truth/u{u}.csv"));
        let truth = read_frf_csv(&truth_path).expect("truth");
        let pose = pose_of(&truth_path);
        for ch in [xx, yy] {
            let f = twin_vs_truth(&twin, &truth, pose, ch, band);
            eprintln!("u{u} {ch}: {f:.2} % (worst measured {worst_measured:.2} %)");
            assert!(
                f >= worst_measured - 2.0,
                "unmeasured pose u{u} {ch}: {f:.2} % < worst measured {worst_measured:.2} % - 2"
            );
        }
    }
}

/// A pose hammered along x and along y (5 hits each) is 10 averages, but each channel's
/// H1 rests on its own direction's 5: its noise limit is computed with those. Before, a
/// cross channel the model fits as closely as the truth does was called a POOR FIT
/// (pose g02 alone: yx 84.9 % of its measured accelerance, "noise alone allows 90.4 %"
/// from 10 averages; 85.6 % from 5).
#[test]
fn tryout_pose_cross_channels_are_judged_with_their_own_averages() {
    let dir = tmp();
    let files = pose_files("g02_");
    assert_eq!(files.len(), 2);
    let twin = identify(&files, &dir.path().join("twin.json"));
    let p = &twin.poses[0];
    let plan = p.plan.as_ref().expect("plan");
    let (all, each) = (
        plan.averages.expect("averages"),
        plan.averages_per_channel
            .expect("averages per channel stated"),
    );
    assert_eq!(
        all,
        2 * each,
        "{all} averages over two directions, {each} per channel"
    );
    let truth_path = tryout("truth/g02.csv");
    let truth = read_frf_csv(&truth_path).expect("truth");
    for ch in [
        Channel::new(Axis::Y, Axis::X),
        Channel::new(Axis::X, Axis::Y),
    ] {
        // the model is as close to the truth as a cross channel gets here
        let vs_truth = twin_vs_truth(&twin, &truth, pose_of(&truth_path), ch, (30.0, 2500.0));
        assert!(vs_truth > 97.0, "{ch}: {vs_truth:.2} % vs the truth");
        let fit = p.fit.iter().find(|f| f.channel == ch).expect("channel fit");
        let limit = fit.noise_limit_pct.expect("noise limit");
        // so it fits its measured FRF about as well as the noise allows
        assert!(fit.fit_pct > limit - 5.0, "{ch}: {fit:?}");
    }
    assert!(
        plan.quality_warnings.is_empty(),
        "{:?}",
        plan.quality_warnings
    );
}

#[test]
fn tryout_log_sweep_twin_beats_the_raw_ratio_of_its_record() {
    let dir = tmp();
    let sweep = tryout("sweep_centre_x.csv");
    let twin = identify(std::slice::from_ref(&sweep), &dir.path().join("twin.json"));
    let truth_path = tryout("truth/centre.csv");
    let truth = read_frf_csv(&truth_path).expect("truth");
    let xx = Channel::new(Axis::X, Axis::X);
    let band = (30.0, 2400.0);
    let twin_fit = twin_vs_truth(&twin, &truth, pose_of(&truth_path), xx, band);
    // the raw full-record ratio FFT(dx)/FFT(fx), onto the truth's lines
    let ts = identify::read::read_timeseries(&sweep).expect("sweep");
    let fx = ts.force(Axis::X).expect("fx");
    let dx = ts.response(Axis::X).expect("dx");
    let n = fx.len();
    let mut planner = realfft::RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(n);
    let (mut a, mut b) = (fx.to_vec(), dx.to_vec());
    let (mut fa, mut fb) = (r2c.make_output_vec(), r2c.make_output_vec());
    r2c.process(&mut a, &mut fa).expect("fft");
    r2c.process(&mut b, &mut fb).expect("fft");
    let df = ts.fs() / n as f64;
    let freqs: Vec<f64> = (0..fa.len()).map(|k| k as f64 * df).collect();
    let ratio: Vec<Complex64> = fa.iter().zip(&fb).map(|(f, d)| d / f).collect();
    let (mut t, mut e) = (Vec::new(), Vec::new());
    for (k, &f) in truth.freqs_hz.iter().enumerate() {
        if f >= band.0 && f <= band.1 {
            t.push(channel(&truth, xx)[k]);
            e.push(interp(&freqs, &ratio, f));
        }
    }
    let raw = fit_percent(&t, &e);
    // the same record through `mtwin frf` and an FRF CSV: a 10.6 MB file that frf
    // streams unless it is a sweep (it was Welch-averaged: 99.41 %)
    let frf_csv = dir.path().join("sweep_frf.csv");
    let o = mtwin(&["frf", "-q", s(&sweep), "--out", s(&frf_csv)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let via_csv = identify(std::slice::from_ref(&frf_csv), &dir.path().join("t2.json"));
    let p0 = via_csv.poses[0].pose;
    let csv_fit = twin_vs_truth(&via_csv, &truth, p0, xx, band);
    eprintln!(
        "sweep xx: twin {twin_fit:.2} %, from frf's FRF CSV {csv_fit:.2} %, raw ratio {raw:.2} %"
    );
    assert!(
        twin_fit >= raw,
        "twin {twin_fit:.2} % < raw ratio {raw:.2} %"
    );
    assert!(
        csv_fit >= raw,
        "twin from the FRF CSV {csv_fit:.2} % < raw ratio {raw:.2} %"
    );
}

/// The FRF CSVs `mtwin frf` writes, one per pose, identify as the campaign their records
/// make: each states its pose (the records' axis positions), so two poses' files are
/// two poses (before, both sat at the origin and identify refused them), with the same
/// twin as from the records; records of two poses in one `frf` call are warned about.
#[test]
fn tryout_frf_csvs_of_two_poses_identify_as_their_records_do() {
    let dir = tmp();
    let of = pose_files;
    let mut csvs = Vec::new();
    for p in ["g00_", "g05_"] {
        let out = dir.path().join(format!("{p}frf.csv"));
        frf(&of(p), &out);
        csvs.push(out);
    }
    let via_csv = identify(&csvs, &dir.path().join("csv.json"));
    let mut recs = of("g00_");
    recs.extend(of("g05_"));
    let from_records = identify(&recs, &dir.path().join("rec.json"));
    assert_eq!(via_csv.poses.len(), 2);
    for (a, b) in via_csv.poses.iter().zip(&from_records.poses) {
        assert!(
            (0..3).all(|k| (a.pose[k] - b.pose[k]).abs() < 1e-6),
            "{:?} vs {:?}",
            a.pose,
            b.pose
        );
    }
    for name in ["g00", "g05"] {
        let truth_path = tryout(&format!("truth/{name}.csv"));
        let truth = read_frf_csv(&truth_path).expect("truth");
        let pose = pose_of(&truth_path);
        for ch in [
            Channel::new(Axis::X, Axis::X),
            Channel::new(Axis::Y, Axis::Y),
        ] {
            let a = twin_vs_truth(&via_csv, &truth, pose, ch, (30.0, 2500.0));
            let b = twin_vs_truth(&from_records, &truth, pose, ch, (30.0, 2500.0));
            eprintln!("{name} {ch}: via FRF CSVs {a:.2} %, from records {b:.2} %");
            assert!(
                (a - b).abs() < 0.1 && a > 99.0,
                "{name} {ch}: {a:.2} vs {b:.2} %"
            );
        }
    }
    let mixed = [of("g00_x")[0].clone(), of("g05_x")[0].clone()];
    let out = dir.path().join("mixed.csv");
    let o = mtwin(&["frf", s(&mixed[0]), s(&mixed[1]), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("measured at 2 poses"), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).expect("frf");
    assert!(!text.contains("# pose="), "{:.300}", text);
}

/// `mtwin frf` then `mtwin identify frf.csv` gives the twin the records give: the CSV
/// states the window, the force's band and the averages, so the plan leaves the
/// noise-only z channels out and takes the window out of the model (g01: σ 10.9 1/s;
/// before the averages were written, xx fitted its own FRF at 28.6 % and the truth at
/// 24 %; with the `# averages` line removed, as from another tool, they are estimated
/// from the least coherent channel and the twin is the same; the same again through a
/// universal file).
#[test]
fn tryout_twin_from_frf_csv_matches_the_twin_from_records() {
    let dir = tmp();
    let files = pose_files("g01_");
    assert_eq!(files.len(), 2);
    let from_records = identify(&files, &dir.path().join("rec.json"));
    let frf_csv = dir.path().join("g01_frf.csv");
    frf(&files, &frf_csv);
    let text = std::fs::read_to_string(&frf_csv).expect("frf csv");
    assert!(text.contains("# averages=5 "), "{:.400}", text);
    let stripped = dir.path().join("g01_no_averages.csv");
    let other: String = (text.lines())
        .filter(|l| !l.starts_with("# averages="))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&stripped, other).expect("write");
    let truth_path = tryout("truth/g01.csv");
    let truth = read_frf_csv(&truth_path).expect("truth");
    let pose = pose_of(&truth_path);
    // and through a universal file, whose FRF functions state the notes in ID lines 4-5
    let uff = dir.path().join("g01_frf.uff");
    frf(&files, &uff);
    for (name, csv) in [
        ("stated", &frf_csv),
        ("estimated", &stripped),
        ("uff", &uff),
    ] {
        let twin = identify(
            std::slice::from_ref(csv),
            &dir.path().join(format!("{name}.json")),
        );
        let plan = twin.poses[0].plan.as_ref().expect("plan");
        for c in &plan.channels {
            let noise_only = c.channel.output == Axis::Z;
            assert_eq!(c.used, !noise_only, "{name}: {c:?}");
        }
        for ch in [
            Channel::new(Axis::X, Axis::X),
            Channel::new(Axis::Y, Axis::Y),
        ] {
            let rec = twin_vs_truth(&from_records, &truth, pose, ch, (30.0, 2500.0));
            let csv_fit = twin_vs_truth(&twin, &truth, twin.poses[0].pose, ch, (30.0, 2500.0));
            eprintln!("g01 {ch}: from records {rec:.2} %, from the FRF CSV ({name} averages) {csv_fit:.2} %");
            assert!(
                csv_fit > 99.0 && csv_fit > rec - 0.5,
                "{name} {ch}: {csv_fit:.2} vs {rec:.2} %"
            );
        }
    }
}

#[test]
fn real_impact_defaults_choose_a_trusted_band_and_many_modes() {
    let dir = tmp();
    let file = shared_data().join("pyfrf_impact_hammer/impact_5hits.csv");
    let twin = identify(std::slice::from_ref(&file), &dir.path().join("twin.json"));
    let p = &twin.poses[0];
    let plan = p.plan.as_ref().expect("plan");
    // the force is 20 dB down above ~7 kHz: the band must stop there, not at Nyquist
    assert!(p.band_hz[1] < 8000.0, "band {:?}", p.band_hz);
    assert!(plan.band_evidence.iter().any(|e| e.contains("20 dB")));
    // five resonances are known near 810, 900, 2640, 3669, 4128 Hz (data README)
    for f0 in [810.0, 900.0, 2640.0, 3669.0, 4128.0] {
        assert!(
            p.model
                .modes
                .iter()
                .any(|m| (m.freq_hz() / f0 - 1.0).abs() < 0.01),
            "no mode near {f0} Hz: {:?}",
            p.model
                .modes
                .iter()
                .map(|m| m.freq_hz())
                .collect::<Vec<_>>()
        );
    }
    // against a plain per-hit H1 of the raw samples (1 s per hit, no window, 5 hits
    // averaged) at 200-4500 Hz where its coherence exceeds 0.95, as accelerance (what
    // was measured) and as receptance
    let ts = identify::read::read_timeseries(&file).expect("impact csv");
    let n = 25_600;
    let hits = ts.len() / n;
    assert_eq!(hits, 5);
    let mut planner = realfft::RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let spectrum = |x: &[f64]| {
        let mut input = x.to_vec();
        let mut out = fft.make_output_vec();
        fft.process(&mut input, &mut out).expect("fft");
        out
    };
    let fx = ts.force(Axis::X).expect("fx");
    let ax = ts.response(Axis::X).expect("ax");
    let lines = n / 2 + 1;
    let (mut sxy, mut sxx, mut syy) = (
        vec![Complex64::new(0.0, 0.0); lines],
        vec![0.0; lines],
        vec![0.0; lines],
    );
    for h in 0..hits {
        let x = spectrum(&fx[h * n..(h + 1) * n]);
        let y = spectrum(&ax[h * n..(h + 1) * n]);
        for k in 0..lines {
            sxy[k] += x[k].conj() * y[k];
            sxx[k] += x[k].norm_sqr();
            syy[k] += y[k].norm_sqr();
        }
    }
    let fs = ts.fs();
    let mut ev = TwinEvaluator::new(&twin).expect("evaluator");
    let m = ev.model_at([0.0; 3]).clone();
    let ci = m.channel_index(Channel::new(Axis::X, Axis::X)).expect("xx");
    let (mut acc_h1, mut acc_m, mut rec_h1, mut rec_m) = (vec![], vec![], vec![], vec![]);
    for k in 0..lines {
        let f = k as f64 * fs / n as f64;
        let coh = sxy[k].norm_sqr() / (sxx[k] * syy[k]);
        if (200.0..=4500.0).contains(&f) && coh > 0.95 {
            let w2 = -(2.0 * std::f64::consts::PI * f).powi(2);
            let h1 = sxy[k] / sxx[k];
            let r = m.eval_hz(ci, f);
            acc_h1.push(h1);
            acc_m.push(r * w2);
            rec_h1.push(h1 / w2);
            rec_m.push(r);
        }
    }
    let (acc, rec) = (fit_percent(&acc_h1, &acc_m), fit_percent(&rec_h1, &rec_m));
    eprintln!("real impact vs per-hit H1: accelerance {acc:.2} %, receptance {rec:.2} %");
    assert!(
        acc >= 97.0 && rec >= 97.0,
        "accelerance {acc:.2} %, receptance {rec:.2} %"
    );
}

/// The four hidden-effect cases of the tryout set, diagnosed against the twin the
/// defaults make from its campaign: cause and numbers as in `diagnose/answers.json`
/// (frequencies within 2 %, the axis and kind named there).
#[test]
fn tryout_diagnosis_names_all_four_cases() {
    let dir = tmp();
    let files = campaign_files();
    let twin_path = dir.path().join("twin.json");
    identify(&files, &twin_path);
    let answers: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tryout("diagnose/answers.json")).expect("answers"),
    )
    .expect("answers json");
    let cases = answers.as_object().expect("answers object");
    assert_eq!(cases.len(), 4);
    let close = |a: f64, b: f64| (a / b - 1.0).abs() <= 0.02;
    let mut wrong = Vec::new();
    for (case, truth) in cases {
        let mut data: Vec<PathBuf> = std::fs::read_dir(tryout(&format!("diagnose/{case}")))
            .expect("case folder")
            .map(|e| e.expect("entry").path())
            .collect();
        data.sort();
        let out = dir.path().join(case);
        let mut args = vec!["diagnose", "-q", "--twin", s(&twin_path)];
        args.extend(data.iter().map(|p| s(p)));
        args.extend(["--out", s(&out)]);
        let o = mtwin(&args);
        assert!(o.status.success(), "{case}: {}", stderr(&o));
        let d: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("diagnosis.json")).expect("diagnosis.json"),
        )
        .expect("diagnosis json");
        let (cause, want) = (
            d["cause"].as_str().unwrap_or(""),
            truth["cause"].as_str().unwrap_or("?"),
        );
        let det = &d["details"];
        let tdet = &truth["details"];
        let numbers_right = match want {
            "none" => true,
            "disturbance" => {
                let found = f64_list(&det["freq_hz"]);
                let t = f64_list(&tdet["freq_hz"]);
                found.len() == t.len() && t.iter().all(|f| found.iter().any(|g| close(*g, *f)))
            }
            _ => {
                let f = det["freq_hz"].as_f64().unwrap_or(f64::NAN);
                let tf = tdet["freq_hz"].as_f64().unwrap_or(f64::NAN);
                close(f, tf)
                    && tdet.get("axis").is_none_or(|a| det["axis"] == *a)
                    && tdet.get("kind").is_none_or(|k| det["kind"] == *k)
            }
        };
        let (before, after) = (
            d["fit_before_pct"].as_f64().unwrap_or(f64::NAN),
            d["fit_after_pct"].as_f64().unwrap_or(f64::NAN),
        );
        eprintln!("{case}: {cause} (want {want}), held-out fit {before:.2} -> {after:.2} %, details {det}");
        if cause != want || !numbers_right {
            wrong.push(format!("{case}: {cause} {det} (want {want} {tdet})"));
        }
        // the extension must pay off on held-out data (where the effect acts: a cause at
        // one mode is scored on the responses band-passed around it)
        if want != "none" && after - before <= 1.0 {
            wrong.push(format!(
                "{case}: held-out gain {:.2} points",
                after - before
            ));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
