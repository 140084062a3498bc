//! Fixed benchmark cases shared by the identification bench and the peer comparison.

use mtwin_core::axis::{Axis, Channel};
use mtwin_core::frf::Frf;
use mtwin_core::model::{ChannelModel, ModalModel, Mode, ModeNum};
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// An 8-mode, 2-channel (xx, yx) structure: 95–1900 Hz, 1–5 % damping, two closely
/// spaced modes (410/425 Hz), real residues from two mode shapes and a 50 kg modal mass.
pub fn eight_modes() -> ModalModel {
    let fs = [95.0, 180.0, 410.0, 425.0, 760.0, 1100.0, 1550.0, 1900.0];
    let z = [0.03, 0.02, 0.015, 0.02, 0.025, 0.01, 0.03, 0.05];
    let modes: Vec<Mode> = fs
        .iter()
        .zip(z)
        .map(|(&f, z)| Mode::from_hz(f, z))
        .collect();
    let shape_x = [1.0, 0.4, 0.8, -0.6, 0.5, 0.3, -0.4, 0.2];
    let shape_y = [0.3, 1.0, -0.5, 0.7, 0.6, -0.5, 0.3, 0.4];
    let mass = 50.0;
    let ch = |o: Axis, sh: &[f64; 8]| ChannelModel {
        channel: Channel::new(o, Axis::X),
        num: (0..8)
            .map(|k| ModeNum {
                b0: sh[k] * shape_x[k] / mass,
                b1: 0.0,
            })
            .collect(),
        d: 0.0,
    };
    ModalModel {
        modes,
        channels: vec![ch(Axis::X, &shape_x), ch(Axis::Y, &shape_y)],
    }
}

/// `model`'s FRF at `freqs` with noise of 1 % of |H| on every line (an H1 with coherence
/// 0.9999) plus a floor of 0.1 % of the channel's RMS, and the coherence that implies.
pub fn noisy_frf(model: &ModalModel, freqs: &[f64], seed: u64) -> Frf {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut frf = model.frf(freqs);
    for c in &mut frf.channels {
        let rms = (c.h.iter().map(|v| v.norm_sqr()).sum::<f64>() / c.h.len() as f64).sqrt();
        let sigma: Vec<f64> = c.h.iter().map(|v| 0.01 * v.norm() + 1e-3 * rms).collect();
        c.coherence = Some(
            c.h.iter()
                .zip(&sigma)
                .map(|(v, s)| v.norm_sqr() / (v.norm_sqr() + s * s))
                .collect(),
        );
        for (v, s) in c.h.iter_mut().zip(&sigma) {
            let (a, b): (f64, f64) = (rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0));
            // uniform in [-1, 1] has variance 1/3: scale to s per complex line
            *v += Complex64::new(a, b) * (s * 3f64.sqrt() / 2f64.sqrt());
        }
    }
    frf
}
