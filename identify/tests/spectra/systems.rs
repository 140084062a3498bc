//! Recover known systems from simulated tests: random noise (Welch), chirp (DFT ratio),
//! impacts (hit detection, windows), exponential window (H(s + σ)), bad hits dropped.

#![allow(clippy::needless_range_loop)] // naive reference code reads best with indices

use crate::common::systems::*;
use identify::spectra::{estimate_frf, Excitation, FrfEstimate, FrfOptions};
use identify::timeseries::ResponseKind;

/// Relative error against `truth(f)` over lines in [lo, hi] with coherence above
/// `min_coh`: (worst, RMS, fraction of the band's lines that pass the coherence limit).
fn errors(
    est: &FrfEstimate,
    lo: f64,
    hi: f64,
    min_coh: f64,
    truth: impl Fn(f64) -> num_complex::Complex64,
) -> (f64, f64, f64) {
    let ch = &est.frf.channels[0];
    let coh = ch.coherence.as_ref().unwrap();
    let (mut worst, mut sq, mut used, mut total) = (0.0f64, 0.0, 0, 0);
    for (k, &f) in est.frf.freqs_hz.iter().enumerate() {
        if f < lo || f > hi {
            continue;
        }
        total += 1;
        if coh[k] < min_coh {
            continue;
        }
        used += 1;
        let t = truth(f);
        let e = (ch.h[k] - t).norm() / t.norm();
        worst = worst.max(e);
        sq += e * e;
    }
    (
        worst,
        (sq / used.max(1) as f64).sqrt(),
        used as f64 / total.max(1) as f64,
    )
}

#[test]
fn random_noise_welch_recovers_sdof() {
    let fs = 16384.0;
    let dt = 1.0 / fs;
    let sys = [Sdof::new(200.0, 0.02, 1e7)];
    let n = 1 << 18;
    let mut noise = Noise::new(42);
    let f = noise.vec(n, 50.0);
    let (mut d, mut a) = simulate(&sys, &f, dt);
    add_noise(&mut d, 0.005, &mut noise);
    add_noise(&mut a, 0.005, &mut noise);
    for (y, kind) in [
        (d, ResponseKind::Displacement),
        (a, ResponseKind::Acceleration),
    ] {
        let est = estimate_frf(&[record(dt, f.clone(), y, kind)], &FrfOptions::default()).unwrap();
        assert!(est.method.contains("Welch"), "{}", est.method);
        assert!(est.hits_used >= 8);
        // vs the exact sampled system (estimator error only) and the analytic continuous
        // receptance (adds the FOH sampling effect, 0.8 % at 800 Hz)
        let (w_d, r_d, frac) = errors(&est, 20.0, 800.0, 0.99, |f| {
            discrete_receptance(&sys, f, dt)
        });
        let (w_a, r_a, _) = errors(&est, 20.0, 800.0, 0.99, |f| receptance(&sys, f, 0.0));
        println!("welch {kind:?}: df {} Hz, {} averages, {:.0} % lines coherent; error discrete rms {r_d:.4} max {w_d:.4}, analytic rms {r_a:.4} max {w_a:.4}", est.df_hz, est.hits_used, frac * 100.0);
        assert!(frac > 0.8, "coherent fraction {frac}");
        // random error of H1 at γ² = 0.99 with 15 averages is ~1.8 % (1 σ)
        assert!(
            r_d < 0.015 && w_d < 0.08,
            "{kind:?} vs discrete: {r_d} {w_d}"
        );
        assert!(
            r_a < 0.02 && w_a < 0.08,
            "{kind:?} vs analytic: {r_a} {w_a}"
        );
    }
}

#[test]
fn single_chirp_dft_ratio_is_unbiased() {
    let fs = 16384.0;
    let dt = 1.0 / fs;
    let sys = [Sdof::new(200.0, 0.02, 1e7), Sdof::new(650.0, 0.01, 4e7)];
    let n = 1 << 16;
    let (f0, f1, tsweep) = (5.0, 1200.0, 2.0);
    let f: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            if t < tsweep {
                let ph = 2.0 * std::f64::consts::PI * (f0 * t + 0.5 * (f1 - f0) / tsweep * t * t);
                100.0 * ph.sin()
            } else {
                0.0
            }
        })
        .collect();
    let (d, _) = simulate(&sys, &f, dt);
    let opts = FrfOptions {
        excitation: Excitation::Chirp,
        ..FrfOptions::default()
    };
    let est = estimate_frf(&[record(dt, f, d, ResponseKind::Displacement)], &opts).unwrap();
    assert!(est.method.contains("chirp"), "{}", est.method);
    // the sweep covers 5..1200 Hz: that is where the force is (within 40 dB of its
    // smoothed peak: the abrupt start and end spread its skirts a little further)
    let (lo, hi) = est.excitation_band_hz.unwrap();
    assert!(lo < 10.0 && hi > 1100.0 && hi < 1700.0, "{lo} {hi}");
    // one record: the coherence comes from the FRF's line-to-line scatter, near 1 for
    // this noise-free record inside the sweep, low where the force is only leakage
    assert!(
        est.method.contains("line-to-line scatter"),
        "{}",
        est.method
    );
    let g = est.frf.channels[0].coherence.as_ref().unwrap();
    let inside: Vec<f64> = est
        .frf
        .freqs_hz
        .iter()
        .zip(g)
        .filter(|(f, _)| **f >= 20.0 && **f <= 1000.0)
        .map(|(_, g)| *g)
        .collect();
    let min = inside.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(min > 0.99, "scatter coherence inside the sweep {min}");
    let (e_disc, _, _) = errors(&est, 20.0, 1000.0, 0.0, |f| {
        discrete_receptance(&sys, f, dt)
    });
    let (e_an, _, _) = errors(&est, 20.0, 1000.0, 0.0, |f| receptance(&sys, f, 0.0));
    println!("chirp: worst error {e_disc:.2e} (discrete), {e_an:.4} (analytic)");
    assert!(e_disc < 1e-4, "{e_disc}");
    assert!(e_an < 0.015, "{e_an}");
}

/// `hits` hit times about 0.3 s apart (jittered by up to 20 ms) and forces of 50-100 N.
fn draw_hits(noise: &mut Noise, hits: usize) -> (Vec<f64>, Vec<f64>) {
    let times: Vec<f64> = (0..hits)
        .map(|h| 0.01 + 0.3 * h as f64 + noise.uniform(0.0, 0.02))
        .collect();
    let amps: Vec<f64> = (0..hits).map(|_| noise.uniform(50.0, 100.0)).collect();
    (times, amps)
}

/// Impact test on a 2-DOF system: `hits` half-sine pulses 0.3 s apart.
fn impact_test(
    seed: u64,
    hits: usize,
    edit: impl Fn(&mut Vec<f64>, &mut Vec<f64>, &[usize]),
) -> (Vec<f64>, Vec<f64>, f64, [Sdof; 2]) {
    let fs = 32768.0;
    let dt = 1.0 / fs;
    let sys = [Sdof::new(300.0, 0.02, 2e7), Sdof::new(900.0, 0.015, 5e7)];
    let n = (0.3 * hits as f64 * fs) as usize;
    let mut noise = Noise::new(seed);
    let (times, amps) = draw_hits(&mut noise, hits);
    let f_true = pulses(n, dt, &times, &amps, 3e-4);
    let (_, mut a) = simulate(&sys, &f_true, dt);
    let mut f = f_true.clone();
    let starts: Vec<usize> = times.iter().map(|t| (t / dt).ceil() as usize).collect();
    for v in f.iter_mut() {
        *v += 0.05 * noise.gauss();
    }
    let amax = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for v in a.iter_mut() {
        *v += 1e-4 * amax * noise.gauss();
    }
    // edits after the noise: clipping happens in the ADC
    edit(&mut f, &mut a, &starts);
    (f, a, dt, sys)
}

#[test]
fn impacts_recover_two_dof() {
    let (f, a, dt, sys) = impact_test(7, 5, |_, _, _| {});
    let est = estimate_frf(
        &[record(dt, f.clone(), a.clone(), ResponseKind::Acceleration)],
        &FrfOptions::default(),
    )
    .unwrap();
    assert!(est.method.contains("impact"), "{}", est.method);
    assert_eq!(est.hits_used, 5, "{:?}", est.hits_dropped);
    assert!(est.hits_dropped.is_empty());
    assert!(
        est.exp_window_sigma.is_none(),
        "response decays within 0.3 s"
    );
    let (w_d, r_d, frac) = errors(&est, 50.0, 1500.0, 0.98, |f| {
        discrete_receptance(&sys, f, dt)
    });
    let (w_a, r_a, _) = errors(&est, 50.0, 1500.0, 0.98, |f| receptance(&sys, f, 0.0));
    println!("impact: df {:.3} Hz, {:.0} % lines coherent; error discrete rms {r_d:.4} max {w_d:.4}, analytic rms {r_a:.4} max {w_a:.4}", est.df_hz, frac * 100.0);
    assert!(frac > 0.9, "{frac}");
    assert!(r_d < 0.02 && w_d < 0.1, "{r_d} {w_d}");
    // an extra response axis that only carries noise does not call for an exponential
    // window (it is at its noise floor from the start)
    let mut rec = record(dt, f, a, ResponseKind::Acceleration);
    rec.response[2] = Some(Noise::new(99).vec(rec.len(), 0.01));
    let est2 = estimate_frf(&[rec], &FrfOptions::default()).unwrap();
    assert!(est2.exp_window_sigma.is_none());
    assert_eq!(est2.frf.channels.len(), 2);
    assert!(r_a < 0.02 && w_a < 0.1, "{r_a} {w_a}");
}

#[test]
fn double_and_clipped_hits_are_dropped() {
    let (f, a, dt, sys) = impact_test(9, 7, |f, a, starts| {
        let dt = 1.0 / 32768.0;
        // hit 2: a rebound 4 ms later at 40 % (force and the structure both see it)
        let s = starts[1];
        let peak = f[s..s + 12].iter().cloned().fold(0.0, f64::max);
        let extra = pulses(f.len(), dt, &[s as f64 * dt + 4e-3], &[0.4 * peak], 3e-4);
        let (_, ea) = simulate(&sys_for_edit(), &extra, dt);
        for i in 0..f.len() {
            f[i] += extra[i];
            a[i] += ea[i];
        }
        // hit 4: force sensor clipped at 60 % of the pulse
        let s = starts[3];
        let peak = f[s..s + 12].iter().cloned().fold(0.0, f64::max);
        for v in f[s..s + 12].iter_mut() {
            *v = v.min(0.6 * peak);
        }
        // hit 6: accelerometer clipped at 50 % of its extreme
        let s = starts[5];
        let seg = &mut a[s..s + 3000];
        let m = seg.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for v in seg.iter_mut() {
            *v = v.clamp(-0.5 * m, 0.5 * m);
        }
    });
    let est = estimate_frf(
        &[record(dt, f, a, ResponseKind::Acceleration)],
        &FrfOptions::default(),
    )
    .unwrap();
    println!("{:#?}", est.hits_dropped);
    assert_eq!(est.hits_used, 4);
    assert_eq!(est.hits_dropped.len(), 3);
    assert!(est.hits_dropped[0].contains("hit 2") && est.hits_dropped[0].contains("double"));
    assert!(
        est.hits_dropped[1].contains("hit 4") && est.hits_dropped[1].contains("force x overloaded")
    );
    assert!(
        est.hits_dropped[2].contains("hit 6")
            && est.hits_dropped[2].contains("response x overloaded")
    );
    let (w, r, _) = errors(&est, 50.0, 1500.0, 0.98, |f| {
        discrete_receptance(&sys, f, dt)
    });
    // 4 averages: the random error of H1 at γ² = 0.98 is 5 % (1 σ)
    assert!(r < 0.02 && w < 0.2, "{r} {w}");
}

/// Four of five hits rebound (a second pulse at 20-35 % a few ms later, as a tired
/// operator's hammer does): dropping them would leave one average, no coherence and no
/// way to judge channels and band. They are kept, each with a force window over both
/// pulses, said so in a warning, and H1 over all five is as accurate as clean hits give.
#[test]
fn double_hits_are_kept_when_too_few_clean_hits_remain() {
    let (f, a, dt, sys) = impact_test(11, 5, |f, a, starts| {
        let dt = 1.0 / 32768.0;
        for (k, &s) in starts.iter().enumerate().skip(1) {
            let peak = f[s..s + 12].iter().cloned().fold(0.0, f64::max);
            let extra = pulses(
                f.len(),
                dt,
                &[s as f64 * dt + 2e-3 + 1e-3 * k as f64],
                &[(0.15 + 0.05 * k as f64) * peak],
                3e-4,
            );
            let (_, ea) = simulate(&sys_for_edit(), &extra, dt);
            for i in 0..f.len() {
                f[i] += extra[i];
                a[i] += ea[i];
            }
        }
    });
    let est = estimate_frf(
        &[record(dt, f, a, ResponseKind::Acceleration)],
        &FrfOptions::default(),
    )
    .unwrap();
    println!("{:#?} {:#?}", est.hits_dropped, est.warnings);
    assert_eq!(est.hits_used, 5, "{:?}", est.hits_dropped);
    assert!(est.hits_dropped.is_empty(), "{:?}", est.hits_dropped);
    assert!(
        est.warnings
            .iter()
            .any(|w| w.contains("double hit") && w.contains("kept")),
        "{:?}",
        est.warnings
    );
    let (w, r, used) = errors(&est, 50.0, 1500.0, 0.98, |f| {
        discrete_receptance(&sys, f, dt)
    });
    // 5 averages at gamma^2 >= 0.98: about 4 % random error (1 sigma) per line
    assert!(r < 0.02 && w < 0.2 && used > 0.8, "{r} {w} {used}");
}

fn sys_for_edit() -> [Sdof; 2] {
    [Sdof::new(300.0, 0.02, 2e7), Sdof::new(900.0, 0.015, 5e7)]
}

#[test]
fn all_hits_bad_is_a_clear_error() {
    let (f, a, dt, _) = impact_test(3, 3, |f, _, starts| {
        for &s in starts {
            let peak = f[s..s + 12].iter().cloned().fold(0.0, f64::max);
            for v in f[s..s + 12].iter_mut() {
                *v = v.min(0.5 * peak);
            }
        }
    });
    let Err(e) = estimate_frf(
        &[record(dt, f, a, ResponseKind::Acceleration)],
        &FrfOptions::default(),
    ) else {
        panic!("every hit is clipped: expected an error");
    };
    assert!(e.is_bad_input());
    let m = e.to_string();
    assert!(
        m.contains("no usable hit") && m.contains("overloaded"),
        "{m}"
    );
}

#[test]
fn exponential_window_estimate_equals_shifted_receptance() {
    // Lightly damped (0.2 %) mode, 0.2 s records: the response is still at ~50 % at the end.
    let fs = 32768.0;
    let dt = 1.0 / fs;
    let sys = [Sdof::new(300.0, 0.002, 2e7)];
    let n = (0.2 * fs) as usize;
    let mut noise = Noise::new(5);
    let records: Vec<_> = (0..5)
        .map(|_| {
            let amp = noise.uniform(50.0, 100.0);
            let f = pulses(n, dt, &[0.005], &[amp], 3e-4);
            let (_, mut a) = simulate(&sys, &f, dt);
            add_noise(&mut a, 1e-4, &mut noise);
            let f: Vec<f64> = f.iter().map(|v| v + 0.02 * noise.gauss()).collect();
            record(dt, f, a, ResponseKind::Acceleration)
        })
        .collect();
    let est = estimate_frf(&records, &FrfOptions::default()).unwrap();
    assert_eq!(est.hits_used, 5);
    let sigma = est
        .exp_window_sigma
        .expect("an exponential window was needed");
    // ends near 1 %: σ ≈ ln(amplitude ratio / 0.01) / duration ≈ ln(50)/0.195
    assert!(sigma > 12.0 && sigma < 30.0, "{sigma}");
    // From acceleration, what is left of the truncation (about 1 %) is divided by ω²:
    // the low-frequency end is the weak part (3.5 % at 150 Hz, 1.4 % at 300 Hz, 0.5 % at
    // 450 Hz), so compare from 150 Hz (half the mode); the 0.3 ms pulse has no force at
    // 5 kHz, so stop at 4.5 kHz.
    let (e_shift, r_shift, _) = errors(&est, 150.0, 4500.0, 0.0, |f| receptance(&sys, f, sigma));
    let (e_raw, _, _) = errors(&est, 250.0, 350.0, 0.0, |f| receptance(&sys, f, 0.0));
    println!("exp window: sigma {sigma:.3} 1/s, error vs H(s+sigma) max {e_shift:.4} rms {r_shift:.4}, vs H(s) {e_raw:.3}");
    assert!(e_shift < 0.05 && r_shift < 0.02, "{e_shift}");
    assert!(e_raw > 0.5, "the window must matter at resonance: {e_raw}");
    // forcing σ = 0 gives the leaky truncated estimate instead
    let mut opts = FrfOptions::default();
    opts.impact.exp_window_sigma = Some(0.0);
    let raw = estimate_frf(&records, &opts).unwrap();
    assert!(raw.exp_window_sigma.is_none());
}

#[test]
fn periodic_chirp_periods_are_averaged() {
    // Periodic chirp: 8 periods of 4096 samples; the first period is the transient and is
    // left out; the others are steady state, so the rectangular-window DFT is exact.
    let fs = 16384.0;
    let dt = 1.0 / fs;
    let sys = [Sdof::new(400.0, 0.03, 1e7)];
    let p = 4096;
    let period: Vec<f64> = (0..p)
        .map(|i| {
            let t = i as f64 / p as f64;
            // sweep over lines 4 .. 400 of the period (16 Hz .. 1.6 kHz)
            let ph = 2.0 * std::f64::consts::PI * (4.0 * t + 0.5 * 396.0 * t * t) * 1.0;
            50.0 * ph.sin()
        })
        .collect();
    let f: Vec<f64> = (0..8 * p).map(|i| period[i % p]).collect();
    let (d, _) = simulate(&sys, &f, dt);
    let mut noise = Noise::new(1);
    let mut d = d[p..].to_vec();
    add_noise(&mut d, 1e-3, &mut noise);
    let opts = FrfOptions {
        excitation: Excitation::Chirp,
        nfft: Some(p),
        ..FrfOptions::default()
    };
    let est = estimate_frf(
        &[record(dt, f[p..].to_vec(), d, ResponseKind::Displacement)],
        &opts,
    )
    .unwrap();
    assert_eq!(est.hits_used, 7);
    assert!((est.df_hz - 4.0).abs() < 1e-12);
    let (w, r, frac) = errors(&est, 30.0, 1500.0, 0.99, |f| {
        discrete_receptance(&sys, f, dt)
    });
    println!("periodic chirp: max {w:.2e} rms {r:.2e} coherent {frac:.3}");
    assert!(frac > 0.99 && w < 0.01, "{w} {frac}");
}

#[test]
fn negative_going_hits_are_found() {
    let (f, a, dt, sys) = impact_test(21, 4, |_, _, _| {});
    let f: Vec<f64> = f.iter().map(|v| -v).collect();
    let a: Vec<f64> = a.iter().map(|v| -v).collect();
    let est = estimate_frf(
        &[record(dt, f, a, ResponseKind::Acceleration)],
        &FrfOptions::default(),
    )
    .unwrap();
    assert_eq!(est.hits_used, 4);
    let (_, r, _) = errors(&est, 50.0, 1500.0, 0.98, |f| {
        discrete_receptance(&sys, f, dt)
    });
    assert!(r < 0.02, "{r}");
}

#[test]
fn hits_along_x_and_y_give_four_channels() {
    use identify::axis::{Axis, Channel};
    let fs = 32768.0;
    let dt = 1.0 / fs;
    // H[out][in]: symmetric coupling through a shared 500 Hz mode
    let direct = [Sdof::new(300.0, 0.02, 2e7), Sdof::new(700.0, 0.02, 3e7)];
    let shared_mode = Sdof::new(500.0, 0.02, 8e7);
    let sys = |o: usize, i: usize| -> Vec<Sdof> {
        if o == i {
            vec![direct[o], shared_mode]
        } else {
            vec![shared_mode]
        }
    };
    let n = (1.2 * fs) as usize;
    let mut noise = Noise::new(77);
    let mut records = Vec::new();
    for input in 0..2 {
        let times: Vec<f64> = (0..4).map(|h| 0.01 + 0.3 * h as f64).collect();
        let amps: Vec<f64> = (0..4).map(|_| noise.uniform(50.0, 100.0)).collect();
        let f = pulses(n, dt, &times, &amps, 3e-4);
        let mut ts = identify::timeseries::TimeSeries {
            source: format!("hits along {}", ["x", "y"][input]),
            dt,
            response_kind: Some(ResponseKind::Displacement),
            ..Default::default()
        };
        for out in 0..2 {
            let (mut d, _) = simulate(&sys(out, input), &f, dt);
            add_noise(&mut d, 1e-3, &mut noise);
            ts.response[out] = Some(d);
        }
        // a little crosstalk on the other force axis (below the 30 % input threshold)
        ts.force[1 - input] = Some(f.iter().map(|v| 0.05 * v + 0.01 * noise.gauss()).collect());
        ts.force[input] = Some(f);
        records.push(ts);
    }
    let est = estimate_frf(&records, &FrfOptions::default()).unwrap();
    assert_eq!(est.hits_used, 8);
    let names: Vec<String> = est.frf.channels.iter().map(|c| c.channel.name()).collect();
    assert_eq!(names, ["xx", "yx", "xy", "yy"]);
    for o in 0..2 {
        for i in 0..2 {
            let ch = Channel::new(Axis::ALL[o], Axis::ALL[i]);
            let one = FrfEstimate {
                frf: identify::frf::Frf {
                    freqs_hz: est.frf.freqs_hz.clone(),
                    channels: vec![est.frf.channel(ch).unwrap().clone()],
                },
                ..est.clone()
            };
            let modes = sys(o, i);
            let (w, r, _) = errors(&one, 100.0, 1500.0, 0.98, |f| {
                discrete_receptance(&modes, f, dt)
            });
            println!("{ch}: rms {r:.4} max {w:.4}");
            assert!(r < 0.02, "{ch}: {r}");
        }
    }
}

#[test]
fn impact_options_at_their_limits_do_not_panic() {
    let (f, a, dt, _) = impact_test(5, 3, |_, _, _| {});
    let rec = record(dt, f, a, ResponseKind::Acceleration);
    for nfft in [16, 17, 64, 1 << 16] {
        let opts = FrfOptions {
            excitation: Excitation::Impact,
            nfft: Some(nfft),
            ..FrfOptions::default()
        };
        let est = estimate_frf(std::slice::from_ref(&rec), &opts).unwrap();
        assert_eq!(est.hits_used, 3, "nfft {nfft}");
        assert!(est.frf.channels[0]
            .h
            .iter()
            .all(|z| z.re.is_finite() && z.im.is_finite()));
    }
    // continuous data forced through the impact path: an error or an estimate, no panic
    let noise = Noise::new(3).vec(5000, 1.0);
    let rec = record(dt, noise.clone(), noise, ResponseKind::Displacement);
    let opts = FrfOptions {
        excitation: Excitation::Impact,
        ..FrfOptions::default()
    };
    let _ = estimate_frf(&[rec], &opts);
}

/// A lightly damped 60 Hz mode that keeps a third of its amplitude when the next hit
/// comes (0.3 s apart): each hit's record holds the earlier hits' ringing and loses its
/// own. Separated over the system's poles (`ImpactOptions::separation`; identify gives
/// it a first fit's), the estimate recovers the sampled system where the plain one
/// cannot (relative error over 20-1500 Hz 32 % plain, 0.5 % separated).
#[test]
fn hits_that_ring_into_the_next_are_separated() {
    use identify::spectra::{HitSeparation, ImpactOptions};
    use num_complex::Complex64;
    let fs = 8192.0;
    let dt = 1.0 / fs;
    let (f0, zeta) = ([60.0, 900.0], [0.01, 0.015]);
    let sys = [
        Sdof::new(f0[0], zeta[0], 2e7),
        Sdof::new(f0[1], zeta[1], 5e7),
    ];
    let hits = 5;
    let n = (0.3 * hits as f64 * fs) as usize;
    let mut noise = Noise::new(11);
    let (times, amps) = draw_hits(&mut noise, hits);
    let f_true = pulses(n, dt, &times, &amps, 5e-4);
    let (_, mut a) = simulate(&sys, &f_true, dt);
    let amax = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for v in a.iter_mut() {
        *v += 1e-5 * amax * noise.gauss();
    }
    let rec = record(dt, f_true, a, ResponseKind::Acceleration);
    let plain = FrfOptions {
        impact: ImpactOptions {
            exp_window_sigma: Some(0.0),
            ..ImpactOptions::default()
        },
        ..FrfOptions::default()
    };
    let poles: Vec<Complex64> = f0
        .iter()
        .zip(zeta)
        .map(|(&f, z)| {
            let w = 2.0 * std::f64::consts::PI * f;
            Complex64::new(-z * w, w * (1.0 - z * z).sqrt())
        })
        .collect();
    let mut separated = plain.clone();
    separated.impact.separation = Some(HitSeparation {
        poles,
        continued: vec![true, false],
    });
    // error relative to the FRF's norm over 20-1500 Hz (what a fit percentage counts)
    let misfit = |opts: &FrfOptions| {
        let est = estimate_frf(std::slice::from_ref(&rec), opts).unwrap();
        let (mut e2, mut t2) = (0.0, 0.0);
        for (k, &f) in est.frf.freqs_hz.iter().enumerate() {
            if (20.0..=1500.0).contains(&f) {
                let t = discrete_receptance(&sys, f, dt);
                e2 += (est.frf.channels[0].h[k] - t).norm_sqr();
                t2 += t.norm_sqr();
            }
        }
        (est.method, (e2 / t2).sqrt())
    };
    let (_, e_plain) = misfit(&plain);
    let (method, e_sep) = misfit(&separated);
    assert!(method.contains("separated"), "{method}");
    println!("ringing hits: relative error plain {e_plain:.4}, separated {e_sep:.5}");
    assert!(
        e_plain > 0.05,
        "the plain estimate should suffer: {e_plain}"
    );
    assert!(
        e_sep < 0.01 && e_sep < 0.05 * e_plain,
        "{e_sep} vs {e_plain}"
    );
}
