//! The streamed Welch estimate (`estimate_frf_streamed`, two passes over the file,
//! memory `O(nfft)`) against the in-memory one (`read_timeseries` + `estimate_frf`) on
//! generated records: same numbers, same warnings, same errors with the same lines.

use crate::common::systems::*;

use identify::axis::Axis;
use identify::read::{
    read_timeseries, scan_timeseries, subsample_stride, write_timeseries, SUBSAMPLE_CAP,
};
use identify::spectra::{
    estimate_frf, estimate_frf_streamed, excitation_of_scan, Estimator, Excitation, FrfEstimate,
    FrfOptions,
};
use identify::timeseries::{ResponseKind, TimeSeries};
use std::path::{Path, PathBuf};

/// Three responses to one random force, each with its own modes and 2 % noise on force
/// and responses (so H1 and H2 differ).
fn siso_record(n: usize, kind: ResponseKind, seed: u64) -> TimeSeries {
    let dt = 1.0 / 2560.0;
    let mut noise = Noise::new(seed);
    let f: Vec<f64> = (0..n).map(|_| 10.0 * noise.gauss()).collect();
    let systems = [
        vec![Sdof::new(120.0, 0.02, 2e7), Sdof::new(410.0, 0.03, 5e7)],
        vec![Sdof::new(95.0, 0.015, 3e7)],
        vec![Sdof::new(250.0, 0.04, 8e7), Sdof::new(700.0, 0.02, 1e8)],
    ];
    let mut ts = TimeSeries {
        source: String::new(),
        t0: 0.125,
        dt,
        response_kind: Some(kind),
        ..TimeSeries::default()
    };
    for (a, modes) in Axis::ALL.into_iter().zip(&systems) {
        let (d, acc) = simulate(modes, &f, dt);
        let mut y = match kind {
            ResponseKind::Displacement => d,
            ResponseKind::Acceleration => acc,
        };
        add_noise(&mut y, 0.02, &mut noise);
        ts.response[a.index()] = Some(y);
    }
    let mut fm = f;
    add_noise(&mut fm, 0.02, &mut noise);
    ts.force[0] = Some(fm);
    ts
}

/// Two independent random forces (x, y) and two responses: MIMO H1.
fn mimo_record(n: usize, seed: u64) -> TimeSeries {
    let dt = 1.0 / 5000.0;
    let mut noise = Noise::new(seed);
    let fx: Vec<f64> = (0..n).map(|_| noise.gauss()).collect();
    let fy: Vec<f64> = (0..n).map(|_| 0.7 * noise.gauss()).collect();
    let a = [Sdof::new(300.0, 0.02, 1e7)];
    let b = [Sdof::new(520.0, 0.03, 2e7)];
    let (_, axx) = simulate(&a, &fx, dt);
    let (_, axy) = simulate(&b, &fy, dt);
    let (_, ayx) = simulate(&b, &fx, dt);
    let (_, ayy) = simulate(&a, &fy, dt);
    let mut ax: Vec<f64> = axx.iter().zip(&axy).map(|(p, q)| p + 0.3 * q).collect();
    let mut ay: Vec<f64> = ayx.iter().zip(&ayy).map(|(p, q)| 0.2 * p + q).collect();
    add_noise(&mut ax, 0.01, &mut noise);
    add_noise(&mut ay, 0.01, &mut noise);
    let mut ts = TimeSeries {
        source: String::new(),
        t0: 0.0,
        dt,
        response_kind: Some(ResponseKind::Acceleration),
        ..TimeSeries::default()
    };
    ts.force = [Some(fx), Some(fy), None];
    ts.response = [Some(ax), Some(ay), None];
    ts
}

fn write(dir: &Path, name: &str, ts: &TimeSeries) -> PathBuf {
    let p = dir.join(name);
    write_timeseries(&p, ts).unwrap();
    p
}

fn opts(estimator: Estimator) -> FrfOptions {
    FrfOptions {
        estimator,
        ..FrfOptions::default()
    }
}

/// Both estimates of the file, the streamed one second.
fn both(path: &Path, o: &FrfOptions) -> (FrfEstimate, FrfEstimate) {
    let mem = estimate_frf(&[read_timeseries(path).unwrap()], o).unwrap();
    let scan = scan_timeseries(path).unwrap();
    assert_eq!(
        excitation_of_scan(&scan, o).unwrap(),
        Excitation::Continuous
    );
    let streamed = estimate_frf_streamed(&scan, o).unwrap();
    (mem, streamed)
}

/// Same grid, channels and messages; every value within `rel` (relative to the
/// channel's largest magnitude).
fn assert_same(mem: &FrfEstimate, st: &FrfEstimate, rel: f64) {
    assert_eq!(mem.frf.freqs_hz, st.frf.freqs_hz);
    assert_eq!(mem.method, st.method);
    assert_eq!(mem.df_hz, st.df_hz);
    assert_eq!(mem.hits_used, st.hits_used);
    assert_eq!(mem.warnings, st.warnings);
    assert_eq!(mem.excitation_band_hz, st.excitation_band_hz);
    assert_eq!(mem.frf.channels.len(), st.frf.channels.len());
    assert!(mem.hits_used >= 2, "too few averages: {}", mem.hits_used);
    for (a, b) in mem.frf.channels.iter().zip(&st.frf.channels) {
        assert_eq!(a.channel, b.channel);
        let scale = a.h.iter().map(|z| z.norm()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        for (k, (x, y)) in a.h.iter().zip(&b.h).enumerate() {
            assert!(
                (x - y).norm() <= rel * scale,
                "{} line {k}: {x} vs {y}",
                a.channel
            );
        }
        let (ga, gb) = (a.coherence.as_ref().unwrap(), b.coherence.as_ref().unwrap());
        for (x, y) in ga.iter().zip(gb) {
            assert!((x - y).abs() <= rel, "{} coherence {x} vs {y}", a.channel);
        }
    }
}

#[test]
fn streamed_equals_in_memory_h1_h2_hv_three_channels() {
    let dir = tempfile::tempdir().unwrap();
    // longer than the classification subsample, not a whole number of hops
    let n = SUBSAMPLE_CAP + 4321;
    let p = write(
        dir.path(),
        "siso.csv",
        &siso_record(n, ResponseKind::Acceleration, 7),
    );
    for est in [Estimator::H1, Estimator::H2, Estimator::Hv] {
        let (mem, st) = both(&p, &opts(est));
        assert_eq!(mem.frf.channels.len(), 3);
        assert!(mem.hits_used >= 8);
        assert_same(&mem, &st, 1e-12);
        // same segments accumulated in the same order: bit for bit
        assert_eq!(mem.frf, st.frf);
    }
    // H1 and H2 really differ here (noise on the force), so the test tells them apart
    let (h1, _) = both(&p, &opts(Estimator::H1));
    let (h2, _) = both(&p, &opts(Estimator::H2));
    let d = h1.frf.channels[0]
        .h
        .iter()
        .zip(&h2.frf.channels[0].h)
        .map(|(a, b)| (a - b).norm() / b.norm())
        .fold(0.0, f64::max);
    assert!(d > 1e-3, "H1 and H2 identical: {d}");
}

#[test]
fn streamed_equals_in_memory_displacement_explicit_nfft_and_fmax() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "disp.csv",
        &siso_record(30_011, ResponseKind::Displacement, 11),
    );
    let o = FrfOptions {
        estimator: Estimator::H2,
        excitation: Excitation::Continuous,
        nfft: Some(3000),
        fmax_hz: Some(900.0),
        overlap: 0.6,
        ..FrfOptions::default()
    };
    let (mem, st) = both(&p, &o);
    assert_same(&mem, &st, 1e-12);
    // few averages: the same warning from both
    let o = FrfOptions {
        nfft: Some(8192),
        ..o
    };
    let (mem, st) = both(&p, &o);
    assert!(mem.warnings.iter().any(|w| w.contains("Welch averages")));
    assert_same(&mem, &st, 1e-12);
}

#[test]
fn streamed_equals_in_memory_mimo() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "mimo.csv", &mimo_record(40_000, 3));
    let (mem, st) = both(&p, &opts(Estimator::H1));
    assert_eq!(mem.frf.channels.len(), 4);
    assert_same(&mem, &st, 1e-12);
    // MIMO has no H2: the same error
    let scan = scan_timeseries(&p).unwrap();
    let e1 = estimate_frf(&[read_timeseries(&p).unwrap()], &opts(Estimator::H2)).unwrap_err();
    let e2 = estimate_frf_streamed(&scan, &opts(Estimator::H2)).unwrap_err();
    assert_eq!(e1.to_string(), e2.to_string());
}

#[test]
fn impact_records_are_not_streamed() {
    let dir = tempfile::tempdir().unwrap();
    let dt = 1.0 / 10_000.0;
    let n = 100_000;
    let f = pulses(
        n,
        dt,
        &[0.5, 3.0, 6.0, 8.5],
        &[100.0, 90.0, 110.0, 95.0],
        4e-4,
    );
    let (_, a) = simulate(&[Sdof::new(200.0, 0.02, 1e7)], &f, dt);
    let p = write(
        dir.path(),
        "impact.csv",
        &record(dt, f, a, ResponseKind::Acceleration),
    );
    let scan = scan_timeseries(&p).unwrap();
    assert!(scan.force[0].as_ref().unwrap().subsample_stride > 1);
    assert_eq!(
        excitation_of_scan(&scan, &FrfOptions::default()).unwrap(),
        Excitation::Impact
    );
    let e = estimate_frf_streamed(&scan, &FrfOptions::default()).unwrap_err();
    assert!(e.to_string().contains("only continuous"), "{e}");
    // forced continuous, it streams (and equals the in-memory Welch estimate)
    let o = FrfOptions {
        excitation: Excitation::Continuous,
        ..FrfOptions::default()
    };
    let (mem, st) = both(&p, &o);
    assert_same(&mem, &st, 1e-12);
}

#[test]
fn bad_row_mid_file_names_line_and_column_like_the_in_memory_reader() {
    let dir = tempfile::tempdir().unwrap();
    let good = write(
        dir.path(),
        "good.csv",
        &siso_record(20_000, ResponseKind::Acceleration, 5),
    );
    let text = std::fs::read_to_string(&good).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "t,fx,ax,ay,az");
    let bad_line = 12_345; // 1-based
    for (what, column) in [
        ("nan", Some("fx")),
        ("empty", Some("ay")),
        ("text", Some("az")),
        ("short", None),
        ("time", Some("t")),
    ] {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        let cells: Vec<&str> = lines[bad_line - 1].split(',').collect();
        l[bad_line - 1] = match what {
            "nan" => format!("{},NaN,{},{},{}", cells[0], cells[2], cells[3], cells[4]),
            "empty" => format!("{},{},{},,{}", cells[0], cells[1], cells[2], cells[4]),
            "text" => format!("{},{},{},{},1.0x", cells[0], cells[1], cells[2], cells[3]),
            "short" => cells[..4].join(","),
            _ => lines[bad_line - 3].to_string(), // time goes back
        };
        let p = dir.path().join(format!("bad_{what}.csv"));
        std::fs::write(&p, l.join("\n") + "\n").unwrap();
        let streamed = scan_timeseries(&p).unwrap_err();
        let mem = read_timeseries(&p).unwrap_err();
        match &streamed {
            identify::Error::BadFile {
                line, column: c, ..
            } => {
                assert_eq!(*line, bad_line, "{what}: {streamed}");
                assert_eq!(c.as_deref(), column, "{what}: {streamed}");
            }
            e => panic!("{what}: expected BadFile, got {e:?}"),
        }
        assert_eq!(streamed.to_string(), mem.to_string(), "{what}");
        assert!(streamed.to_string().contains(&format!(":{bad_line}")));
    }
}

#[test]
fn slow_drift_of_the_rate_is_found_against_the_mean_step() {
    // every step within 1 % of the first ones, but far from the mean: 0.995 ms for the
    // first rows, then 0.985 ms, one step of 1.004 ms at the end (line 4003)
    let mut text = String::from("t,fx,ax\n");
    let mut t = 0.0;
    for i in 0..4003 {
        let step = if i < 4 {
            0.995e-3
        } else if i == 4002 {
            1.004e-3
        } else {
            0.986e-3
        };
        if i > 0 {
            t += step;
        }
        text.push_str(&format!("{t},{},{}\n", (i as f64).sin(), (i as f64).cos()));
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("drift.csv");
    std::fs::write(&p, text).unwrap();
    let e = scan_timeseries(&p).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains(":4004") && msg.contains("mean step"), "{msg}");
}

#[test]
fn scan_statistics_match_the_record() {
    let dir = tempfile::tempdir().unwrap();
    let ts = mimo_record(5000, 9);
    let p = write(dir.path(), "m.csv", &ts);
    let scan = scan_timeseries(&p).unwrap();
    let back = read_timeseries(&p).unwrap();
    assert_eq!(scan.rows, back.len());
    assert_eq!(scan.dt, back.dt);
    assert_eq!(scan.t0, back.t0);
    assert_eq!(scan.response_axes(), back.response_axes());
    let fx = back.force(Axis::X).unwrap();
    let s = scan.force[0].as_ref().unwrap();
    assert_eq!(s.subsample, fx, "short column: subsample is the column");
    let m = fx.iter().sum::<f64>() / fx.len() as f64;
    let r = (fx.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / fx.len() as f64).sqrt();
    assert!((s.mean - m).abs() < 1e-12 && (s.rms - r).abs() < 1e-12 * r);
    assert!(scan.force[2].is_none());
}

#[test]
fn long_column_subsample_is_every_stride_th_sample() {
    // the in-memory estimate judges impulsiveness on the same subsample (same stride rule)
    let dir = tempfile::tempdir().unwrap();
    let n = 2 * SUBSAMPLE_CAP + 3;
    let ts = siso_record(n, ResponseKind::Displacement, 4);
    let p = write(dir.path(), "long.csv", &ts);
    let scan = scan_timeseries(&p).unwrap();
    let back = read_timeseries(&p).unwrap();
    let fx = back.force(Axis::X).unwrap();
    let stride = subsample_stride(n);
    assert_eq!(stride, 4);
    let s = scan.force[0].as_ref().unwrap();
    assert_eq!(s.subsample_stride, stride);
    let expect: Vec<f64> = fx.iter().step_by(stride).copied().collect();
    assert_eq!(s.subsample, expect);
    assert!(s.subsample.len() <= SUBSAMPLE_CAP);
}

#[test]
fn in_memory_batches_equal_streamed_for_any_thread_count() {
    // In memory, 2 × threads segments are transformed at once (their FFTs in parallel)
    // and added line by line in segment order; streamed, one segment at a time. The sums
    // are the same whatever the batch and the number of threads.
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "mimo.csv", &mimo_record(41_017, 5));
    let o = FrfOptions {
        nfft: Some(2048),
        ..opts(Estimator::H1)
    };
    let scan = scan_timeseries(&p).unwrap();
    let streamed = estimate_frf_streamed(&scan, &o).unwrap();
    let rec = read_timeseries(&p).unwrap();
    // two records of the same group: a batch never spans records
    let short = identify::diagnose::slice(&rec, 0, 9_001);
    let mut two = Vec::new();
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mem = pool.install(|| estimate_frf(std::slice::from_ref(&rec), &o).unwrap());
        assert!(mem.hits_used >= 30, "{} averages", mem.hits_used);
        assert_eq!(mem.frf, streamed.frf, "{threads} threads");
        two.push(pool.install(|| estimate_frf(&[rec.clone(), short.clone()], &o).unwrap()));
    }
    assert_eq!(two[0].hits_used, streamed.hits_used + 7);
    for t in &two[1..] {
        assert_eq!(t.frf, two[0].frf);
    }
    assert_ne!(two[0].frf, streamed.frf);
}
