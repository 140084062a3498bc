//! Numerical faults: FRFs the rational fit cannot or can hardly identify, and impact
//! records with clipped force. Each case either fails with a clear error that says what
//! is wrong, or gives a model whose poles are finite and stable and whose FRF is finite
//! (never NaN).

use identify::axis::{Axis, Channel};
use identify::frf::{Frf, FrfChannel};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
use identify::rational_fit::{fit_frf, FitOptions, FitResult};
use identify::simulate::{Hold, Simulator};
use identify::spectra::{estimate_frf, FrfOptions};
use identify::timeseries::{ResponseKind, TimeSeries};
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const XX: Channel = Channel {
    output: Axis::X,
    input: Axis::X,
};

fn sdof(f_hz: f64, zeta: f64, k: f64) -> ModalModel {
    let m = Mode::from_hz(f_hz, zeta);
    ModalModel {
        modes: vec![m],
        channels: vec![ChannelModel {
            channel: XX,
            num: vec![ModeNum {
                b0: m.wn * m.wn / k,
                b1: 0.0,
            }],
            d: 0.0,
        }],
    }
}

fn grid(f0: f64, f1: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| f0 + (f1 - f0) * i as f64 / (n - 1) as f64)
        .collect()
}

fn frf_of(freqs: &[f64], h: Vec<Complex64>) -> Frf {
    Frf {
        freqs_hz: freqs.to_vec(),
        channels: vec![FrfChannel {
            channel: XX,
            h,
            coherence: None,
        }],
    }
}

/// The fit's model is usable: modes finite and stable, numerators finite, FRF finite on
/// the grid and beyond, fit figures not NaN.
fn assert_sane(what: &str, r: &FitResult, freqs: &[f64]) {
    let m = &r.model;
    assert!(m.is_valid(), "{what}: invalid model {m:?}");
    for mode in &m.modes {
        assert!(mode.is_stable(), "{what}: unstable mode {mode:?}");
        let p = mode.pole();
        assert!(p.re.is_finite() && p.im.is_finite(), "{what}: pole {p}");
        assert!(p.re < 0.0, "{what}: pole {p} not in the left half plane");
    }
    let hi = freqs.last().copied().unwrap_or(1.0);
    let mut check: Vec<f64> = freqs.to_vec();
    check.extend([0.0, 0.5 * hi, 2.0 * hi, 10.0 * hi]);
    let h = m.frf(&check);
    for c in &h.channels {
        for (f, v) in check.iter().zip(&c.h) {
            assert!(
                v.re.is_finite() && v.im.is_finite(),
                "{what}: model FRF {v} at {f} Hz"
            );
        }
    }
    for (c, f) in &r.fit_pct {
        assert!(!f.is_nan(), "{what}: fit of {c} is NaN");
    }
}

/// Either a clear error (its message contains one of `words`) or a sane model.
fn err_or_sane(what: &str, frf: &Frf, opts: &FitOptions, words: &[&str]) -> Option<FitResult> {
    match fit_frf(frf, opts) {
        Ok(r) => {
            assert_sane(what, &r, &frf.freqs_hz);
            println!(
                "{what}: model with {} mode(s), fit {:?}",
                r.model.modes.len(),
                r.fit_pct
            );
            Some(r)
        }
        Err(e) => {
            let m = e.to_string();
            println!("{what}: error: {m}");
            assert!(
                words.iter().any(|w| m.to_lowercase().contains(w)),
                "{what}: the message should say what is wrong ({words:?}): {m}"
            );
            assert!(!m.contains("NaN"), "{what}: {m}");
            None
        }
    }
}

fn both_orders() -> [FitOptions; 2] {
    [
        FitOptions::default(),
        FitOptions {
            n_modes: Some(2),
            ..FitOptions::default()
        },
    ]
}

// ---------------------------------------------------------------------------------------
// Rank-deficient and ill-conditioned data
// ---------------------------------------------------------------------------------------

#[test]
fn all_zero_frf_is_refused() {
    let f = grid(10.0, 500.0, 200);
    let frf = frf_of(&f, vec![Complex64::new(0.0, 0.0); f.len()]);
    for opts in both_orders() {
        assert!(
            err_or_sane("all zero", &frf, &opts, &["zero"]).is_none(),
            "a model from an all-zero FRF"
        );
    }
}

#[test]
fn constant_frf() {
    let f = grid(10.0, 500.0, 200);
    for v in [
        Complex64::new(1e-7, 0.0),
        Complex64::new(0.0, -3e-8),
        Complex64::new(2e-6, 1e-6),
    ] {
        let frf = frf_of(&f, vec![v; f.len()]);
        for opts in both_orders() {
            let what = format!("constant {v}");
            let words = ["constant", "resonance", "no mode", "lines", "singular"];
            if let Some(r) = err_or_sane(&what, &frf, &opts, &words) {
                // the fit figure is undefined (-inf) for a constant reference, but the
                // model must still be close to the constant
                let h = r.model.frf(&f);
                let rel = (h.channels[0]
                    .h
                    .iter()
                    .map(|x| (x - v).norm_sqr())
                    .sum::<f64>()
                    / f.len() as f64)
                    .sqrt()
                    / v.norm();
                println!("{what}: relative RMS error {rel:.3e}");
                // a real constant is a spring (the feedthrough d); a constant imaginary
                // part (hysteretic damping without stiffness) has no low-order rational
                // model, but the fit must still beat the zero model
                let tol = if v.im == 0.0 { 1e-3 } else { 0.5 };
                assert!(
                    rel < tol,
                    "{what}: model differs by {rel} from the constant"
                );
            }
        }
    }
}

#[test]
fn very_few_lines() {
    let truth = sdof(100.0, 0.03, 1e7);
    for n in 1..=4 {
        let f = grid(80.0, 120.0, n.max(2));
        let f = &f[..n];
        let frf = truth.frf(f);
        for opts in both_orders() {
            err_or_sane(
                &format!("{n} lines"),
                &frf,
                &opts,
                &["lines", "too few", "at least"],
            );
        }
    }
}

#[test]
fn duplicate_and_unsorted_frequencies() {
    let truth = sdof(100.0, 0.03, 1e7);
    let mut f = grid(10.0, 300.0, 100);
    f.insert(50, f[50]);
    let frf = truth.frf(&f);
    for opts in both_orders() {
        err_or_sane(
            "duplicate line",
            &frf,
            &opts,
            &["increasing", "duplicate", "sorted"],
        );
    }
    let mut f = grid(10.0, 300.0, 100);
    f.swap(10, 11);
    let frf = truth.frf(&f);
    err_or_sane(
        "unsorted",
        &frf,
        &FitOptions::default(),
        &["increasing", "duplicate", "sorted"],
    );
}

#[test]
fn non_finite_values_and_frequencies_are_refused() {
    let truth = sdof(100.0, 0.03, 1e7);
    let f = grid(10.0, 300.0, 100);
    let mut frf = truth.frf(&f);
    frf.channels[0].h[40] = Complex64::new(f64::NAN, 0.0);
    assert!(err_or_sane(
        "NaN value",
        &frf,
        &FitOptions::default(),
        &["finite", "nan"]
    )
    .is_none());
    let mut frf = truth.frf(&f);
    frf.channels[0].h[40] = Complex64::new(0.0, f64::INFINITY);
    assert!(err_or_sane(
        "Inf value",
        &frf,
        &FitOptions::default(),
        &["finite", "inf"]
    )
    .is_none());
    let mut frf = truth.frf(&f);
    frf.freqs_hz[99] = f64::INFINITY;
    assert!(err_or_sane(
        "Inf frequency",
        &frf,
        &FitOptions::default(),
        &["finite", "frequenc"]
    )
    .is_none());
    let mut frf = truth.frf(&f);
    frf.channels[0].coherence = Some(vec![f64::NAN; f.len()]);
    err_or_sane(
        "NaN coherence",
        &frf,
        &FitOptions::default(),
        &["coherence", "finite"],
    );
}

#[test]
fn mismatched_channel_length_is_refused() {
    let truth = sdof(100.0, 0.03, 1e7);
    let f = grid(10.0, 300.0, 100);
    let mut frf = truth.frf(&f);
    frf.channels[0].h.pop();
    assert!(err_or_sane(
        "short channel",
        &frf,
        &FitOptions::default(),
        &["length", "values", "lines", "per frequency"]
    )
    .is_none());
}

#[test]
fn extreme_scales() {
    let f = grid(10.0, 500.0, 300);
    for k in [1e-250, 1e250] {
        let frf = sdof(200.0, 0.02, k).frf(&f);
        for opts in both_orders() {
            err_or_sane(&format!("k = {k:e}"), &frf, &opts, &["scale", "range"]);
        }
    }
    // a grid in MHz and one in mHz
    for s in [1e-3, 1e6] {
        let fs: Vec<f64> = f.iter().map(|v| v * s).collect();
        let frf = frf_of(
            &fs,
            sdof(200.0 * s, 0.02, 1e7).frf(&fs).channels[0].h.clone(),
        );
        let r = err_or_sane(&format!("grid x{s:e}"), &frf, &FitOptions::default(), &[]);
        let r = r.expect("a scaled grid is an ordinary fit");
        assert!(r.fit_pct[0].1 > 99.0, "{:?}", r.fit_pct);
    }
}

// ---------------------------------------------------------------------------------------
// Physics at the limits
// ---------------------------------------------------------------------------------------

#[test]
fn no_resonance_in_band_pure_stiffness() {
    let f = grid(5.0, 200.0, 200);
    // static stiffness line: the only mode at 20 kHz, far above the band
    let frf = sdof(20_000.0, 0.05, 2e8).frf(&f);
    for opts in both_orders() {
        if let Some(r) = err_or_sane("stiffness line", &frf, &opts, &["resonance", "no mode"]) {
            assert!(r.fit_pct[0].1 > 95.0, "{:?}", r.fit_pct);
        }
    }
    // exactly real and constant: a spring
    let frf = frf_of(&f, vec![Complex64::new(5e-9, 0.0); f.len()]);
    for opts in both_orders() {
        err_or_sane("spring", &frf, &opts, &["resonance", "no mode", "constant"]);
    }
}

#[test]
fn mode_at_the_band_edge() {
    for (lo, hi, fr) in [
        (10.0, 500.0, 500.0),
        (10.0, 500.0, 505.0),
        (100.0, 600.0, 100.0),
        (100.0, 600.0, 97.0),
    ] {
        let f = grid(lo, hi, 400);
        let truth = sdof(fr, 0.02, 1e7);
        let frf = truth.frf(&f);
        let r = err_or_sane(
            &format!("mode {fr} Hz, band {lo}..{hi}"),
            &frf,
            &FitOptions::default(),
            &[],
        )
        .expect("a clean single mode at the band edge is fitted");
        assert!(r.fit_pct[0].1 > 95.0, "{:?}", r.fit_pct);
    }
}

#[test]
fn extremely_light_damping() {
    for zeta in [1e-3, 1e-4] {
        // 1 Hz lines: the half-power band (2ζf = 0.4 Hz at 1e-3) falls between lines
        let f = grid(20.0, 500.0, 481);
        let truth = sdof(200.3, zeta, 1e7);
        let frf = truth.frf(&f);
        let r = err_or_sane(&format!("zeta {zeta}"), &frf, &FitOptions::default(), &[])
            .expect("a clean lightly damped mode is fitted");
        let m = r
            .model
            .modes
            .iter()
            .min_by(|a, b| {
                (a.freq_hz() - 200.3)
                    .abs()
                    .total_cmp(&(b.freq_hz() - 200.3).abs())
            })
            .expect("a mode");
        println!(
            "zeta {zeta}: found {:.4} Hz, zeta {:.5}",
            m.freq_hz(),
            m.zeta
        );
        assert!((m.freq_hz() - 200.3).abs() < 0.5, "{m:?}");
    }
}

#[test]
fn heavy_noise_snr_one() {
    let f = grid(10.0, 500.0, 490);
    let truth = ModalModel {
        modes: vec![Mode::from_hz(120.0, 0.03), Mode::from_hz(330.0, 0.02)],
        channels: vec![ChannelModel {
            channel: XX,
            num: vec![
                ModeNum { b0: 30.0, b1: 0.0 },
                ModeNum { b0: 120.0, b1: 0.0 },
            ],
            d: 0.0,
        }],
    };
    let clean = truth.frf(&f);
    let rms = (clean.channels[0]
        .h
        .iter()
        .map(|v| v.norm_sqr())
        .sum::<f64>()
        / f.len() as f64)
        .sqrt();
    for (seed, coh) in [(1u64, None), (2, Some(0.5)), (3, Some(0.05))] {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut frf = clean.clone();
        for v in &mut frf.channels[0].h {
            let (a, b): (f64, f64) = (rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            *v += Complex64::new(a, b) * rms * 3f64.sqrt() / 2f64.sqrt();
        }
        frf.channels[0].coherence = coh.map(|g| vec![g; f.len()]);
        err_or_sane(
            &format!("SNR 1, coherence {coh:?}"),
            &frf,
            &FitOptions::default(),
            &["coherence", "noise", "lines"],
        );
        err_or_sane(
            &format!("SNR 1, coherence {coh:?}, 2 modes"),
            &frf,
            &FitOptions {
                n_modes: Some(2),
                ..FitOptions::default()
            },
            &["coherence", "noise", "lines"],
        );
    }
}

// ---------------------------------------------------------------------------------------
// Impact records with a clipped force
// ---------------------------------------------------------------------------------------

/// Half-sine hits every 0.25 s on an SDOF (displacement response), clipped at `clip`
/// (fraction of the largest hit) when given.
fn impact_record(clip: Option<f64>, peaks: &[f64]) -> TimeSeries {
    let fs = 8192.0;
    let dt = 1.0 / fs;
    let n = (peaks.len() as f64 * 0.25 * fs) as usize + 256;
    let mut f = vec![0.0; n];
    for (k, &p) in peaks.iter().enumerate() {
        let t0 = 0.01 + 0.25 * k as f64;
        let width = 1e-3;
        for (i, v) in f.iter_mut().enumerate() {
            let tau = i as f64 * dt - t0;
            if tau > 0.0 && tau < width {
                *v += p * (std::f64::consts::PI * tau / width).sin();
            }
        }
    }
    let model = sdof(300.0, 0.03, 1e7);
    let mut sim = Simulator::new(1, Hold::Foh);
    let mut y = vec![0.0; n];
    for i in 1..n {
        sim.step(&model, &[f[i - 1], 0.0, 0.0], &[f[i], 0.0, 0.0], dt);
        y[i] = sim.output(&model, &[f[i], 0.0, 0.0])[0];
    }
    if let Some(c) = clip {
        let top = peaks.iter().fold(0.0f64, |m, v| m.max(v.abs())) * c;
        f.iter_mut().for_each(|v| *v = v.clamp(-top, top));
    }
    let mut ts = TimeSeries {
        source: "clipped.csv".into(),
        dt,
        response_kind: Some(ResponseKind::Displacement),
        ..TimeSeries::default()
    };
    ts.force[0] = Some(f);
    ts.response[0] = Some(y);
    ts
}

#[test]
fn clipped_force_hits_are_dropped_and_named() {
    // the force sensor's range is 70 % of the largest hit: the two hard hits clip
    let rec = impact_record(Some(0.7), &[100.0, 50.0, 100.0, 55.0, 45.0]);
    let est = estimate_frf(&[rec], &FrfOptions::default()).expect("three clean hits remain");
    println!("{:#?}", est.hits_dropped);
    assert_eq!(est.hits_used, 3, "{:?}", est.hits_dropped);
    assert_eq!(est.hits_dropped.len(), 2);
    assert!(est
        .hits_dropped
        .iter()
        .all(|d| d.contains("overloaded") && d.contains("clipped")));
    for c in &est.frf.channels {
        assert!(c.h.iter().all(|v| v.re.is_finite() && v.im.is_finite()));
    }
}

#[test]
fn all_hits_clipped_is_a_clear_error() {
    let rec = impact_record(Some(0.3), &[100.0, 90.0, 110.0]);
    let e = estimate_frf(&[rec], &FrfOptions::default()).expect_err("every hit clipped");
    let m = e.to_string();
    assert!(e.is_bad_input(), "{m}");
    assert!(m.contains("overloaded") && m.contains("range"), "{m}");
}

// ---------------------------------------------------------------------------------------
// Degenerate time series through the spectra
// ---------------------------------------------------------------------------------------

#[test]
fn degenerate_records_give_clear_errors() {
    let good = impact_record(None, &[100.0, 90.0, 110.0]);
    // no force at all
    let mut r = good.clone();
    r.force[0] = Some(vec![0.0; good.len()]);
    let e = estimate_frf(&[r], &FrfOptions::default());
    match e {
        Err(e) => println!("zero force: {e}"),
        Ok(est) => {
            for c in &est.frf.channels {
                assert!(c.h.iter().all(|v| v.re.is_finite() && v.im.is_finite()));
            }
        }
    }
    // no response at all
    let mut r = good.clone();
    r.response[0] = Some(vec![0.0; good.len()]);
    if let Ok(est) = estimate_frf(&[r], &FrfOptions::default()) {
        for c in &est.frf.channels {
            assert!(c.h.iter().all(|v| v.re.is_finite() && v.im.is_finite()));
        }
        // and the fit refuses the zero FRF
        let e = fit_frf(&est.frf, &FitOptions::default());
        assert!(e.is_err(), "a model from a zero response");
    }
    // a constant (DC) force
    let mut r = good;
    r.force[0] = Some(vec![3.0; r.len()]);
    match estimate_frf(&[r], &FrfOptions::default()) {
        Err(e) => println!("DC force: {e}"),
        Ok(est) => {
            for c in &est.frf.channels {
                assert!(
                    c.h.iter().all(|v| v.re.is_finite() && v.im.is_finite()),
                    "DC force gives a non-finite FRF"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// An undefined fit figure does not make the twin file unreadable
// ---------------------------------------------------------------------------------------

#[test]
fn twin_with_undefined_fit_saves_and_loads() {
    use identify::twin::Twin;
    let mut twin = vmachine::structure::ModalMachine::default_machine()
        .exact_twin([2, 1, 1], &[Axis::X, Axis::Y]);
    // a constant measured channel: fit_percent is -inf, which JSON writes as null
    let h = vec![Complex64::new(1e-7, 0.0); 50];
    assert_eq!(identify::frf::fit_percent(&h, &h), f64::NEG_INFINITY);
    twin.poses[0].fit = vec![identify::twin::ChannelFit {
        channel: XX,
        fit_pct: identify::frf::fit_percent(&h, &h),
        noise_limit_pct: None,
        noise_free_fit_pct: None,
        band_hz: None,
    }];
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("t.json");
    twin.save(&p).unwrap();
    let back = Twin::load(&p).expect("a saved twin always loads");
    assert_eq!(back.poses[0].fit[0].fit_pct, f64::NEG_INFINITY);
}

#[test]
fn fit_percent_is_scale_free_and_never_nan() {
    use identify::frf::fit_percent;
    let base: Vec<Complex64> = (0..100)
        .map(|i| Complex64::new((i as f64 * 0.1).sin(), (i as f64 * 0.07).cos()))
        .collect();
    let model: Vec<Complex64> = base.iter().map(|v| v * 1.01).collect();
    let want = fit_percent(&base, &model);
    for s in [1e-300, 1e-200, 1e200, 1e300] {
        let a: Vec<Complex64> = base.iter().map(|v| v * s).collect();
        let b: Vec<Complex64> = model.iter().map(|v| v * s).collect();
        let got = fit_percent(&a, &b);
        assert!((got - want).abs() < 1e-9, "scale {s:e}: {got} vs {want}");
    }
    // constant to rounding: undefined, not -1e16 %
    for v in [Complex64::new(0.0, -3e-8), Complex64::new(2e-6, 1e-6)] {
        let a = vec![v; 490];
        let b: Vec<Complex64> = a.iter().map(|x| x * 1.001).collect();
        assert_eq!(fit_percent(&a, &b), f64::NEG_INFINITY);
    }
}

#[test]
fn twin_extensions_out_of_range_are_refused_with_the_field_named() {
    use identify::twin::CubicStiffness;
    let twin = vmachine::structure::ModalMachine::default_machine()
        .exact_twin([2, 1, 1], &[Axis::X, Axis::Y]);
    let n = twin.poses[0].model.modes.len();
    let p = std::path::Path::new("t.json");
    let mut bad_mode = twin.clone();
    bad_mode.extensions.cubic.push(CubicStiffness {
        mode: n,
        kappa: 1.0,
    });
    let mut bad_kappa = twin.clone();
    bad_kappa.extensions.cubic.push(CubicStiffness {
        mode: 0,
        kappa: f64::INFINITY,
    });
    let mut bad_delay = twin.clone();
    bad_delay.extensions.delay_s = Some(f64::NAN);
    for (t, word) in [
        (bad_mode, "extensions.cubic"),
        (bad_kappa, "extensions.cubic"),
        (bad_delay, "extensions.delay_s"),
    ] {
        let e = t.validate(p).expect_err(word).to_string();
        assert!(e.contains(word), "{e}");
    }
    let mut good = twin;
    good.extensions.cubic.push(CubicStiffness {
        mode: n - 1,
        kappa: -3.0e6,
    });
    good.validate(p).unwrap();
}
