//! The virtual machine against its analytic truth.

use identify::axis::Axis;
use identify::frf::fit_percent;
use identify::spectra::{estimate_frf, Excitation, FrfOptions};
use identify::timeseries::ResponseKind;
use vmachine::chain::MdofChain;
use vmachine::daq::{acquire, chain_record, impact_record, simulate_machine, Daq};
use vmachine::excitation::{noise, Milling};
use vmachine::structure::ModalMachine;

#[test]
fn noise_excited_machine_matches_the_analytic_frf() {
    let m = ModalMachine::default_machine();
    let daq = Daq {
        force_noise: 0.0,
        response_noise: 0.0,
        ..Daq::default()
    };
    let pose = [0.1, 0.5, 0.3];
    let fs = daq.fs_sim();
    let n = (20.0 * fs) as usize;
    let forces = [Some(noise(n, 100.0, 3)), None, None];
    let resp = simulate_machine(
        &m,
        &forces,
        fs,
        &|_| pose,
        &[Axis::X, Axis::Y],
        daq.response,
    );
    let ts = acquire(forces, resp, &|_| pose, &daq, "noise");
    let est = estimate_frf(
        &[ts],
        &FrfOptions {
            excitation: Excitation::Continuous,
            nfft: Some(8192),
            ..FrfOptions::default()
        },
    )
    .unwrap();
    let frf = est.frf.band(40.0, 2000.0);
    let truth = m.frf_at(pose, &frf.freqs_hz, &[Axis::X, Axis::Y]);
    for c in &frf.channels {
        let t = truth
            .channels
            .iter()
            .find(|t| t.channel == c.channel)
            .unwrap();
        let fit = fit_percent(&t.h, &c.h);
        eprintln!("{}: {fit:.3} %", c.channel);
        assert!(fit > 98.0, "{}: {fit}", c.channel);
    }
}

#[test]
fn model_at_is_the_analytic_frf_and_poses_shift_modes() {
    let m = ModalMachine::default_machine();
    let freqs = [50.0, 181.0, 700.0];
    let p = [0.0, 0.6, 0.4];
    let model = m.model_at(p, &[Axis::X, Axis::Y]);
    let frf = m.frf_at(p, &freqs, &[Axis::X, Axis::Y]);
    for (ci, c) in frf.channels.iter().enumerate() {
        for (k, &f) in freqs.iter().enumerate() {
            assert!((model.eval_hz(ci, f) - c.h[k]).norm() <= 1e-12 * c.h[k].norm());
        }
    }
    // frequencies move by a few percent up to ~10 % across the workspace
    let lo = m.grid([2, 2, 2]);
    let mut max_shift: f64 = 0.0;
    for k in 0..m.modes.len() {
        for p in &lo {
            let r = m.mode_at(k, *p).freq_hz() / m.modes[k].f_hz - 1.0;
            max_shift = max_shift.max(r.abs());
        }
    }
    assert!(max_shift > 0.05 && max_shift < 0.15, "{max_shift}");
}

#[test]
fn paper_chain_static_compliance_and_simulation() {
    let c = MdofChain::paper_chain();
    assert!((c.receptance(0.0).re - 1.5e-4).abs() < 1e-15);
    let f = c.natural_freqs_hz();
    assert!((f[0] - 3.17).abs() < 0.01, "{f:?}");
    // the modal model of the proportionally damped chain is its FRF ...
    let modal = c.modal_model().unwrap();
    for fr in [0.0, 3.0, 9.7, 20.0] {
        let (a, b) = (modal.eval_hz(0, fr), c.receptance(fr));
        assert!((a - b).norm() < 1e-10 * b.norm(), "{fr}: {a} vs {b}");
    }
    // ... and the state-space simulation agrees with the modal one (independent code)
    let dt = 1.0 / 800.0;
    let force = noise(20_000, 10.0, 5);
    let rows: Vec<[f64; 3]> = force.iter().map(|&v| [0.0, 0.0, v]).collect();
    let y_modal =
        identify::simulate::simulate(&rows, dt, identify::simulate::Hold::Foh, |_| &modal);
    let y = c.simulate(&force, dt);
    let err = y
        .iter()
        .zip(&y_modal)
        .map(|(a, b)| (a - b[2]).powi(2))
        .sum::<f64>()
        .sqrt();
    let nrm = y.iter().map(|a| a * a).sum::<f64>().sqrt();
    assert!(err < 1e-9 * nrm, "{err} vs {nrm}");
    // the recorded data give the analytic FRF: periodic chirp, the first periods (the
    // transient of ζ1 = 0.25 %) dropped, one period per FFT (no leakage)
    let daq = Daq {
        fs: 100.0,
        oversample: 8,
        force_noise: 0.0,
        response_noise: 0.0,
        response: ResponseKind::Displacement,
        seed: 1,
    };
    let period = 4096;
    let periods = 12;
    let r = daq.oversample;
    let force =
        vmachine::excitation::chirp(daq.fs_sim(), period * r * periods, 0.2, 40.0, 10.0, periods);
    let ts = chain_record(&c, force, &daq, "chain");
    let ts = identify::diagnose::slice(&ts, 6 * period, periods * period);
    let est = estimate_frf(
        &[ts],
        &FrfOptions {
            excitation: Excitation::Chirp,
            nfft: Some(period),
            ..FrfOptions::default()
        },
    )
    .unwrap();
    let frf = est.frf.band(0.5, 30.0);
    let truth = c.frf(&frf.freqs_hz);
    let fit = fit_percent(&truth.channels[0].h, &frf.channels[0].h);
    eprintln!("chain: {fit:.3} %");
    assert!(fit > 98.0, "{fit}");
}

#[test]
fn impact_records_decay_between_hits() {
    let m = ModalMachine::default_machine();
    let ts = impact_record(
        &m,
        m.center(),
        Axis::X,
        &[Axis::X, Axis::Y],
        3,
        &Daq::default(),
        9,
    );
    let f = ts.force(Axis::X).unwrap();
    let a = ts.response(Axis::X).unwrap();
    let fs = ts.fs();
    // three separated pulses
    let peak = f.iter().cloned().fold(0.0, f64::max);
    let mut hits = 0;
    let mut last = -1.0;
    for (i, v) in f.iter().enumerate() {
        let t = i as f64 / fs;
        if *v > 0.5 * peak && t - last > 0.1 {
            hits += 1;
            last = t;
        }
    }
    assert_eq!(hits, 3);
    // the response just before the 2nd hit is small against its peak
    let i2 = (0.51 * fs) as usize;
    let amax = a.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let tail = a[i2 - 50..i2].iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(tail < 0.05 * amax, "{tail} vs {amax}");
}

#[test]
fn milling_force_mean_matches_the_closed_form_in_slotting() {
    let cut = Milling {
        immersion: 1.0,
        teeth: 4,
        runout: 0.0,
        kte: 0.0,
        kre: 0.0,
        ..Milling::default()
    };
    let fs = 200_000.0;
    let n = (60.0 / cut.rpm * fs) as usize; // one revolution
    let (fx, fy) = cut.forces(fs, n, 0.0);
    let mx = fx.iter().sum::<f64>() / n as f64;
    let my = fy.iter().sum::<f64>() / n as f64;
    // Altintas, slotting (φ from 0 to π): F̄x = −N ap Kr Kt c / 4, F̄y = N ap Kt c / 4
    let nt = cut.teeth as f64;
    let c = cut.feed_per_tooth;
    let fx_closed = -nt * cut.ap * cut.kr * cut.kt * c / 4.0;
    let fy_closed = nt * cut.ap * cut.kt * c / 4.0;
    eprintln!("mean fx {mx} (closed {fx_closed}), fy {my} (closed {fy_closed})");
    assert!((mx - fx_closed).abs() < 0.01 * fy_closed.abs());
    assert!((my - fy_closed).abs() < 0.01 * fy_closed.abs());
}
