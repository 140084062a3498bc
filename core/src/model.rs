//! The identified LTI model in a well-conditioned modal form.
//!
//! A model is a set of second-order sections shared by all channels (the modes) plus,
//! per channel, one real numerator per mode and a constant residual compliance:
//!
//! ```text
//! H_c(s) = Σ_k (b1_ck s + b0_ck) / (s² + 2 ζ_k ω_k s + ω_k²)  +  d_c
//! ```
//!
//! With `ζ < 1` a section is a conjugate pole pair `p = -ζω ± jω√(1-ζ²)` with residue
//! `r = (b1 p + b0) / (p - p̄)`; with `ζ ≥ 1` it holds two real poles (an over-damped pair),
//! so every real rational model of even order is representable. No polynomial
//! coefficients are ever stored: those lose their poles when rounded (the paper's own
//! printed model has unstable poles after rounding to 4 digits).

use crate::axis::Channel;
use crate::frf::{Frf, FrfChannel};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// One mode: a second-order section `s² + 2ζω s + ω²` common to all channels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Mode {
    /// Undamped natural angular frequency ω \[rad/s\].
    pub wn: f64,
    /// Damping ratio ζ (> 0 for a stable mode; ≥ 1 means two real poles).
    pub zeta: f64,
}

impl Mode {
    /// Mode from natural frequency \[Hz\] and damping ratio.
    pub fn from_hz(f_hz: f64, zeta: f64) -> Self {
        Mode {
            wn: 2.0 * PI * f_hz,
            zeta,
        }
    }

    /// Mode holding the pole `p` and its conjugate.
    pub fn from_pole(p: Complex64) -> Self {
        let wn = p.norm();
        Mode {
            wn,
            zeta: -p.re / wn,
        }
    }

    /// Natural frequency \[Hz\].
    pub fn freq_hz(&self) -> f64 {
        self.wn / (2.0 * PI)
    }

    /// The pole with non-negative imaginary part (for ζ ≥ 1: the slower real pole).
    pub fn pole(&self) -> Complex64 {
        let (w, z) = (self.wn, self.zeta);
        if z < 1.0 {
            Complex64::new(-z * w, w * (1.0 - z * z).sqrt())
        } else {
            Complex64::new(-z * w + w * (z * z - 1.0).sqrt(), 0.0)
        }
    }

    /// Both poles of the section.
    pub fn poles(&self) -> [Complex64; 2] {
        let (w, z) = (self.wn, self.zeta);
        if z < 1.0 {
            let p = self.pole();
            [p, p.conj()]
        } else {
            let r = w * (z * z - 1.0).sqrt();
            [
                Complex64::new(-z * w + r, 0.0),
                Complex64::new(-z * w - r, 0.0),
            ]
        }
    }

    /// Denominator `s² + 2ζω s + ω²` at `s`.
    pub fn den(&self, s: Complex64) -> Complex64 {
        s * s + s * (2.0 * self.zeta * self.wn) + self.wn * self.wn
    }

    /// `∂den/∂ln ω = 2ζω s + 2ω²` and `∂den/∂ln ζ = 2ζω s` at `s` (both linear in `s`, with
    /// slope `2ζω`).
    pub fn den_log_derivatives(&self, s: Complex64) -> [Complex64; 2] {
        let slope = 2.0 * self.zeta * self.wn;
        [s * slope + 2.0 * self.wn * self.wn, s * slope]
    }

    /// True when both poles lie strictly in the left half plane.
    pub fn is_stable(&self) -> bool {
        self.wn > 0.0 && self.zeta > 0.0 && self.wn.is_finite() && self.zeta.is_finite()
    }
}

/// Numerator of one mode in one channel: `b1 s + b0`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ModeNum {
    /// Constant coefficient [m/N · rad²/s²].
    pub b0: f64,
    /// Coefficient of `s` [m/N · rad/s].
    pub b1: f64,
}

impl ModeNum {
    /// Numerator of the pair with pole `p` (Im p > 0) and residue `r`:
    /// `r/(s-p) + r̄/(s-p̄) = (2Re(r) s - 2Re(r p̄)) / ((s-p)(s-p̄))`.
    pub fn from_residue(p: Complex64, r: Complex64) -> Self {
        ModeNum {
            b1: 2.0 * r.re,
            b0: -2.0 * (r * p.conj()).re,
        }
    }

    /// Residue at the pole `p` of `mode` (for an under-damped mode).
    pub fn residue(&self, mode: &Mode) -> Complex64 {
        let p = mode.pole();
        (p * self.b1 + self.b0) / (p - p.conj())
    }
}

/// The model of one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelModel {
    /// Which response per which force.
    pub channel: Channel,
    /// One numerator per mode of the owning [`ModalModel`], same order.
    pub num: Vec<ModeNum>,
    /// Residual compliance of out-of-band modes \[m/N\] (direct feedthrough).
    pub d: f64,
}

/// A multi-channel modal model with common poles (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ModalModel {
    /// The modes, sorted by natural frequency.
    pub modes: Vec<Mode>,
    /// Per channel numerators and residual.
    pub channels: Vec<ChannelModel>,
}

impl ModalModel {
    /// Model order: number of poles (twice the number of modes).
    pub fn order(&self) -> usize {
        2 * self.modes.len()
    }

    /// The channel model, if present.
    pub fn channel(&self, c: Channel) -> Option<&ChannelModel> {
        self.channels.iter().find(|m| m.channel == c)
    }

    /// Index of the channel, if present.
    pub fn channel_index(&self, c: Channel) -> Option<usize> {
        self.channels.iter().position(|m| m.channel == c)
    }

    /// Transfer function of channel `ci` at the Laplace variable `s`.
    pub fn eval_s(&self, ci: usize, s: Complex64) -> Complex64 {
        let ch = &self.channels[ci];
        let mut h = Complex64::new(ch.d, 0.0);
        for (m, n) in self.modes.iter().zip(&ch.num) {
            h += (s * n.b1 + n.b0) / m.den(s);
        }
        h
    }

    /// Magnitude of mode `k`'s own term in channel `ci` at its natural frequency,
    /// `|b0 + jωn b1| / |den(jωn)|`: the mode's resonance peak in that channel.
    pub fn mode_peak(&self, ci: usize, k: usize) -> f64 {
        let (md, n) = (self.modes[k], self.channels[ci].num[k]);
        let s = Complex64::new(0.0, md.wn);
        (Complex64::new(n.b0, 0.0) + s * n.b1).norm() / md.den(s).norm()
    }

    /// Receptance of channel `ci` at frequency `f_hz`.
    pub fn eval_hz(&self, ci: usize, f_hz: f64) -> Complex64 {
        self.eval_s(ci, Complex64::new(0.0, 2.0 * PI * f_hz))
    }

    /// The model's FRF (all channels) on a frequency grid \[Hz\].
    pub fn frf(&self, freqs_hz: &[f64]) -> Frf {
        Frf {
            freqs_hz: freqs_hz.to_vec(),
            channels: (0..self.channels.len())
                .map(|ci| FrfChannel {
                    channel: self.channels[ci].channel,
                    h: freqs_hz.iter().map(|&f| self.eval_hz(ci, f)).collect(),
                    coherence: None,
                })
                .collect(),
        }
    }

    /// True when every mode is stable and every number is finite.
    pub fn is_valid(&self) -> bool {
        self.modes.iter().all(Mode::is_stable)
            && self.channels.iter().all(|c| {
                c.d.is_finite()
                    && c.num.len() == self.modes.len()
                    && c.num.iter().all(|n| n.b0.is_finite() && n.b1.is_finite())
            })
    }

    /// Sorts the modes by natural frequency, keeping numerators aligned.
    pub fn sort_modes(&mut self) {
        let mut idx: Vec<usize> = (0..self.modes.len()).collect();
        idx.sort_by(|&a, &b| self.modes[a].wn.total_cmp(&self.modes[b].wn));
        self.modes = idx.iter().map(|&i| self.modes[i]).collect();
        for c in &mut self.channels {
            c.num = idx.iter().map(|&i| c.num[i]).collect();
        }
    }

    /// Moves every pole by `sigma` along the real axis, keeping residues:
    /// if this model fits `H(s + σ)` (an FRF measured through an exponential window
    /// e^{-σt}), the result models `H(s)`. Over-damped sections are shifted pole by pole.
    pub fn shift_poles(&mut self, sigma: f64) {
        for k in 0..self.modes.len() {
            let m = self.modes[k];
            if m.zeta < 1.0 {
                let p = m.pole();
                let res: Vec<Complex64> =
                    self.channels.iter().map(|c| c.num[k].residue(&m)).collect();
                let q = p + sigma;
                self.modes[k] = Mode::from_pole(q);
                for (c, r) in self.channels.iter_mut().zip(res) {
                    c.num[k] = ModeNum::from_residue(q, r);
                }
            } else {
                // (b1 s + b0)/((s-p1)(s-p2)) with s -> s - σ: b0' = b0 - b1 σ
                let [p1, p2] = m.poles();
                let (q1, q2) = (p1.re + sigma, p2.re + sigma);
                self.modes[k] = Mode {
                    wn: (q1 * q2).abs().sqrt(),
                    zeta: -(q1 + q2) / (2.0 * (q1 * q2).abs().sqrt()),
                };
                for c in &mut self.channels {
                    c.num[k].b0 -= c.num[k].b1 * sigma;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;

    fn one_mode() -> ModalModel {
        let m = Mode::from_hz(100.0, 0.02);
        ModalModel {
            modes: vec![m],
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num: vec![ModeNum { b0: 1.0, b1: 0.0 }],
                d: 0.0,
            }],
        }
    }

    #[test]
    fn sdof_static_compliance_and_peak() {
        let model = one_mode();
        let wn = model.modes[0].wn;
        let h0 = model.eval_hz(0, 0.0);
        assert!((h0.re - 1.0 / (wn * wn)).abs() < 1e-15);
        // At resonance, |H| = 1 / (2 ζ ω²) and the phase is -90°.
        let hr = model.eval_hz(0, 100.0);
        assert!((hr.norm() - 1.0 / (2.0 * 0.02 * wn * wn)).abs() / hr.norm() < 1e-12);
        assert!((hr.arg() + PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn residue_round_trip() {
        let mode = Mode::from_hz(250.0, 0.03);
        let p = mode.pole();
        let r = Complex64::new(1.5e-3, -2.0e-4);
        let n = ModeNum::from_residue(p, r);
        let back = n.residue(&mode);
        assert!((back - r).norm() < 1e-12 * r.norm());
        // partial fractions agree with the section at an arbitrary s
        let s = Complex64::new(3.0, 1234.0);
        let pf = r / (s - p) + r.conj() / (s - p.conj());
        let sec = (s * n.b1 + n.b0) / mode.den(s);
        assert!((pf - sec).norm() < 1e-12 * pf.norm());
    }

    #[test]
    fn shift_poles_undoes_an_exponential_window() {
        let mut model = one_mode();
        model.channels[0].num[0].b1 = 3.0;
        let sigma = 7.0;
        let mut windowed = model.clone();
        windowed.shift_poles(-sigma); // the model of H(s + σ)
        let mut back = windowed.clone();
        back.shift_poles(sigma);
        for f in [0.0, 50.0, 100.0, 170.0] {
            let s = Complex64::new(0.0, 2.0 * PI * f);
            let a = windowed.eval_s(0, s);
            let b = model.eval_s(0, s + sigma);
            assert!((a - b).norm() < 1e-12 * b.norm());
            let c = back.eval_hz(0, f);
            let d = model.eval_hz(0, f);
            assert!((c - d).norm() < 1e-12 * d.norm());
        }
    }

    #[test]
    fn discrete_tf_matches_continuous_at_dc() {
        let model = one_mode();
        let (b, a) = model.discrete_tf(0, 1e-4);
        let hd = b.iter().sum::<f64>() / a.iter().sum::<f64>();
        let hc = model.eval_hz(0, 0.0).re;
        assert!((hd - hc).abs() < 1e-9 * hc.abs());
    }
}
