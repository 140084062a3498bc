//! The numerators solved for fixed poles keep the modes in the order given: a
//! campaign's tracked models hold mode `k` as the same physical mode at every pose.

use identify::axis::{Axis, Channel};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
use identify::rational_fit::{solve_numerators, weights, FitOptions};

const XX: Channel = Channel {
    output: Axis::X,
    input: Axis::X,
};

/// Three modes given out of frequency order (300, 100, 200 Hz): the solved model has
/// them in that order, and each slot's numerator is that mode's own (the FRF is
/// reproduced, and the 100 Hz slot carries the 100 Hz mode's residue).
#[test]
fn numerators_for_fixed_poles_keep_the_given_mode_order() {
    let hz = [300.0, 100.0, 200.0];
    let b0 = [4.0e6, 1.0e6, 2.5e6];
    let truth = ModalModel {
        modes: hz.iter().map(|&f| Mode::from_hz(f, 0.02)).collect(),
        channels: vec![ChannelModel {
            channel: XX,
            num: b0.iter().map(|&b| ModeNum { b0: b, b1: 0.0 }).collect(),
            d: 0.0,
        }],
    };
    let freqs: Vec<f64> = (0..400).map(|i| 20.0 + i as f64).collect();
    let frf = truth.frf(&freqs);
    let opts = FitOptions::default();
    let w = weights(&frf, &opts);
    let mut start = truth.clone();
    for n in start.channels[0].num.iter_mut() {
        *n = ModeNum { b0: 0.0, b1: 0.0 };
    }
    let solved = solve_numerators(&start, &frf, &w, &opts).unwrap();
    for k in 0..3 {
        let got = solved.modes[k].wn / (2.0 * std::f64::consts::PI);
        assert!(
            (got - hz[k]).abs() < 1e-6,
            "slot {k}: {got} Hz, given {} Hz",
            hz[k]
        );
        let b = solved.channels[0].num[k].b0;
        assert!(
            (b / b0[k] - 1.0).abs() < 1e-3,
            "slot {k} ({} Hz): b0 {b:e}, true {:e}",
            hz[k],
            b0[k]
        );
    }
}
