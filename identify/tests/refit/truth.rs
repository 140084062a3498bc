//! Lifetime refit against the truth on the virtual machine: worn modes seen only through
//! milling data (mechanistic cutting force at a few spindle speeds plus a broadband share);
//! the updated twin's FRF at the operating pose is scored against the analytic FRF of the
//! worn machine, in the band the milling excites (30–1500 Hz: the tooth-passing harmonics
//! and the broadband share reach every mode up to the 1380 Hz one).

use identify::axis::Axis;
use identify::frf::fit_percent;
use identify::interpolate::TwinEvaluator;
use identify::refit::{refit, RefitMethod, RefitOptions};

use identify::twin::Twin;
use vmachine::daq::{milling_at_centre, Daq};
use vmachine::structure::ModalMachine;

const AXES: [Axis; 2] = [Axis::X, Axis::Y];
const BAND: (f64, f64) = (30.0, 1500.0);

/// Worst direct-channel fit of the twin at `pose` vs the machine's analytic FRF in `band`.
fn accuracy(twin: &Twin, m: &ModalMachine, pose: [f64; 3]) -> f64 {
    let freqs: Vec<f64> = (0..=1000)
        .map(|i| BAND.0 + (BAND.1 - BAND.0) * i as f64 / 1000.0)
        .collect();
    let truth = m.frf_at(pose, &freqs, &AXES);
    let mut ev = TwinEvaluator::new(twin).unwrap();
    let model = ev.model_at(pose).clone();
    truth
        .channels
        .iter()
        .filter(|c| c.channel.output == c.channel.input)
        .map(|c| {
            let ci = model.channel_index(c.channel).unwrap();
            let est: Vec<_> = freqs.iter().map(|&f| model.eval_hz(ci, f)).collect();
            fit_percent(&c.h, &est)
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn worn_mode_seen_in_milling_at_three_speeds_both_methods() {
    let machine = ModalMachine::default_machine();
    // the twin identified before the wear: exact, so the test measures the refit alone
    let twin = machine.exact_twin([3, 3, 2], &AXES);
    let worn = machine.clone().with_stiffness_change(2, 0.85);
    let data = milling_at_centre(&worn, &[2400.0, 3300.0, 4500.0], 15.0, 7);
    let c = machine.center();
    let before = accuracy(&twin, &worn, c);
    assert!(before < 50.0, "the wear must matter: {before:.2} %");
    let truth_f = worn.mode_at(2, c).freq_hz();
    for (method, min_fit) in [
        (RefitMethod::Modal, 98.0),
        (RefitMethod::Time, 99.5),
        (RefitMethod::Paper, 97.5),
    ] {
        let (new, rep) = refit(
            &twin,
            &data,
            &RefitOptions {
                method,
                ..RefitOptions::default()
            },
        )
        .unwrap();
        let after = accuracy(&new, &worn, c);
        eprintln!(
            "{method:?}: worst direct channel vs worn truth {before:.2} % -> {after:.2} % \
             (30-1500 Hz); drift fit {:.2} %, modes changed {:?}",
            rep.drift_fit_pct,
            rep.modes
                .iter()
                .map(|m| format!(
                    "{} {:.2}->{:.2} Hz",
                    m.mode, m.freq_before_hz, m.freq_after_hz
                ))
                .collect::<Vec<_>>()
        );
        assert!(rep.updated);
        assert!(after >= min_fit, "{method:?}: {after:.2} % < {min_fit} %");
        let m2 = rep
            .modes
            .iter()
            .find(|m| m.mode == 2)
            .expect("mode 2 updated");
        assert!(
            (m2.freq_after_hz - truth_f).abs() < 0.005 * truth_f,
            "{method:?}: {} Hz vs {truth_f} Hz",
            m2.freq_after_hz
        );
        if method != RefitMethod::Paper {
            // mtwin's update frees only what changed
            assert_eq!(rep.modes.len(), 1, "{:?}", rep.modes);
            // and the history says so in English (issue 22: "1 modes changed")
            let summary = &new.history.last().unwrap().summary;
            assert!(summary.ends_with(", 1 mode changed"), "{summary}");
        }
    }
}

#[test]
fn lifetime_sequence_tracks_every_wear_step_and_keeps_the_history() {
    let machine = ModalMachine::default_machine();
    let c = machine.center();
    let mut twin = machine.exact_twin([3, 3, 2], &AXES);
    // successive wear: mode 2 stiffness -5 %, -10 %, then mode 5 (520 Hz) -8 % on top
    let steps: Vec<ModalMachine> = vec![
        machine.clone().with_stiffness_change(2, 0.95),
        machine.clone().with_stiffness_change(2, 0.90),
        machine
            .clone()
            .with_stiffness_change(2, 0.90)
            .with_stiffness_change(5, 0.92),
    ];
    let mut states: Vec<Twin> = vec![twin.clone()];
    for (i, truth) in steps.iter().enumerate() {
        let data = milling_at_centre(truth, &[2400.0, 3300.0, 4500.0], 15.0, 50 + 10 * i as u64);
        let (next, rep) = refit(&twin, &data, &RefitOptions::default()).unwrap();
        let before = accuracy(&twin, truth, c);
        let after = accuracy(&next, truth, c);
        eprintln!(
            "step {i}: {before:.2} % -> {after:.2} %, modes changed {:?}",
            rep.modes
                .iter()
                .map(|m| format!(
                    "{} {:.2}->{:.2} Hz",
                    m.mode, m.freq_before_hz, m.freq_after_hz
                ))
                .collect::<Vec<_>>()
        );
        if std::env::var_os("MTWIN_DEBUG_REFIT").is_some() {
            let mut ev = TwinEvaluator::new(&next).unwrap();
            let got = ev.model_at(c).clone();
            let want = truth.model_at(c, &AXES);
            for k in [2usize, 3, 5] {
                eprintln!(
                    "  mode {k}: f {:.3}/{:.3} z {:.5}/{:.5} xx {:.4e}/{:.4e} yy {:.4e}/{:.4e}",
                    got.modes[k].freq_hz(),
                    want.modes[k].freq_hz(),
                    got.modes[k].zeta,
                    want.modes[k].zeta,
                    got.channels[0].num[k].b0,
                    want.channels[0].num[k].b0,
                    got.channels[3].num[k].b0,
                    want.channels[3].num[k].b0
                );
            }
        }
        assert!(rep.updated, "step {i}: drift not detected");
        // every step tracked: the FRF and the worn mode's frequency
        assert!(after >= 99.0, "step {i}: {after:.2} %");
        for m in &rep.modes {
            let f = truth.mode_at(m.mode, c).freq_hz();
            assert!(
                (m.freq_after_hz - f).abs() < 0.003 * f,
                "step {i}: mode {} at {} Hz, truth {f} Hz",
                m.mode,
                m.freq_after_hz
            );
        }
        assert!(after > before, "step {i}");
        // the history grows by one entry that holds the complete previous state
        assert_eq!(next.history.len(), twin.history.len() + 1);
        assert_eq!(next.history.last().unwrap().previous_poses, twin.poses);
        twin = next;
        states.push(twin.clone());
    }
    // nothing lost: every earlier state is recoverable from the final twin, and the file
    // round-trips
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("twin.json");
    twin.save(&p).unwrap();
    let back = Twin::load(&p).unwrap();
    for (k, s) in states.iter().enumerate().take(states.len() - 1) {
        let entry = &back.history[back.history.len() - (states.len() - 1) + k];
        assert_eq!(entry.previous_poses, s.poses, "state {k} lost");
    }
    assert_eq!(back.poses, twin.poses);
}

/// The paper's scenario (section 3.2) on its 3-DoF chain: k1 −10 %, a milling-like force
/// (tooth passing at 2.9 Hz with 6 harmonics plus a broadband share), 0.5 % sensor noise on
/// force AND response. The twin before the wear is the exact chain, so the test measures
/// the refit alone; the updated FRF is scored against the analytic FRF of the worn chain
/// (0.01–40 Hz). Paper: 95.23 %; target 99 %.
#[test]
fn paper_chain_k1_loss_time_update_beats_99_percent() {
    use identify::twin::{OrderInfo, PoseModel};
    use num_complex::Complex64;
    use std::f64::consts::PI;
    use vmachine::chain::MdofChain;
    use vmachine::daq::chain_record;
    use vmachine::excitation::noise;

    let chain = MdofChain::paper_chain();
    let model = chain.modal_model().expect("proportional damping");
    let freqs: Vec<f64> = (1..=4000).map(|k| k as f64 * 0.01).collect();
    let twin = Twin::new(
        "paper chain",
        vec![PoseModel {
            pose: [0.0; 3],
            frf: model.frf(&freqs),
            model,
            band_hz: [0.01, 40.0],
            fit: vec![],
            order: OrderInfo {
                modes: 3,
                automatic: false,
                stable_freqs_hz: vec![],
            },
            sources: vec![],
            frf_exp_window_sigma: None,
            plan: None,
        }],
    );
    let worn = chain.clone().with_k1_factor(0.9);
    let daq = Daq {
        fs: 100.0,
        oversample: 8,
        force_noise: 0.005,
        response_noise: 0.005,
        response: identify::timeseries::ResponseKind::Displacement,
        seed: 11,
    };
    let fs = daq.fs_sim();
    let n = (1800.0 * fs) as usize;
    let mut f: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            20.0 + (1..=6)
                .map(|h| (8.0 / h as f64) * (2.0 * PI * 2.9 * h as f64 * t + 0.3 * h as f64).sin())
                .sum::<f64>()
        })
        .collect();
    f.iter_mut()
        .zip(noise(n, 2.0, 21))
        .for_each(|(a, b)| *a += b);
    let op = chain_record(&worn, f, &daq, "milling_like");
    let score = |t: &Twin| {
        let truth: Vec<Complex64> = freqs.iter().map(|&f| worn.receptance(f)).collect();
        let est: Vec<Complex64> = freqs
            .iter()
            .map(|&f| t.poses[0].model.eval_hz(0, f))
            .collect();
        fit_percent(&truth, &est)
    };
    let before = score(&twin);
    let mut fits = Vec::new();
    for method in [RefitMethod::Modal, RefitMethod::Time] {
        let (new, rep) = refit(
            &twin,
            std::slice::from_ref(&op),
            &RefitOptions {
                method,
                ..RefitOptions::default()
            },
        )
        .unwrap();
        let after = score(&new);
        eprintln!(
            "paper chain, {method:?}: {before:.2} % -> {after:.2} % vs the worn chain; output error {:?}",
            rep.output_error
        );
        fits.push(after);
    }
    assert!(before < 0.0, "the wear must matter: {before:.2} %");
    assert!(fits[1] >= 99.0, "time update {:.2} % < 99 %", fits[1]);
    assert!(
        fits[1] > fits[0],
        "output error must gain on the modal update"
    );
}
