//! Frequency response functions (the data the rational fit works on) and the fit metric.

use crate::axis::Channel;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// One measured or modelled FRF channel, receptance in m/N.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrfChannel {
    /// Which response per which force.
    pub channel: Channel,
    /// Complex receptance at each frequency line \[m/N\].
    pub h: Vec<Complex64>,
    /// Coherence γ² in [0, 1] at each line, when estimated from data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coherence: Option<Vec<f64>>,
}

/// A set of FRF channels on one common, strictly increasing frequency grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Frf {
    /// Frequency lines \[Hz\], strictly increasing.
    pub freqs_hz: Vec<f64>,
    /// The channels, each with one value per frequency line.
    pub channels: Vec<FrfChannel>,
}

impl Frf {
    /// The channel with this name, if present.
    pub fn channel(&self, c: Channel) -> Option<&FrfChannel> {
        self.channels.iter().find(|ch| ch.channel == c)
    }

    /// Angular frequencies \[rad/s\] of the grid.
    pub fn omegas(&self) -> Vec<f64> {
        self.freqs_hz
            .iter()
            .map(|f| 2.0 * std::f64::consts::PI * f)
            .collect()
    }

    /// Restricts every channel to lines with `lo <= f <= hi`.
    pub fn band(&self, lo: f64, hi: f64) -> Frf {
        let keep: Vec<usize> = (0..self.freqs_hz.len())
            .filter(|&i| self.freqs_hz[i] >= lo && self.freqs_hz[i] <= hi)
            .collect();
        Frf {
            freqs_hz: keep.iter().map(|&i| self.freqs_hz[i]).collect(),
            channels: self
                .channels
                .iter()
                .map(|c| FrfChannel {
                    channel: c.channel,
                    h: keep.iter().map(|&i| c.h[i]).collect(),
                    coherence: c
                        .coherence
                        .as_ref()
                        .map(|g| keep.iter().map(|&i| g[i]).collect()),
                })
                .collect(),
        }
    }
}

/// Weighted RMS `sqrt(Σ w²|h|² / Σ w²)` of one channel, formed relative to the largest
/// weighted value so that receptances near 1e±300 neither overflow nor underflow when
/// squared. `None` when the channel is zero or has no weight.
pub fn weighted_rms(h: &[Complex64], w: &[f64]) -> Option<f64> {
    let top = h
        .iter()
        .zip(w)
        .filter(|(_, w)| **w > 0.0)
        .fold(0.0f64, |m, (h, _)| m.max(h.re.abs()).max(h.im.abs()));
    if !(top > 0.0 && top.is_finite()) {
        return None;
    }
    let (num, den) = h
        .iter()
        .zip(w)
        .filter(|(_, w)| **w > 0.0)
        .fold((0.0, 0.0), |(a, b), (h, w)| {
            (a + w * w * (h / top).norm_sqr(), b + w * w)
        });
    (den > 0.0 && num > 0.0).then(|| top * (num / den).sqrt())
}

/// The paper's fit metric (its equation 5; docs/formats.md, "Diagnosis output"), in percent:
/// `(1 - ||F - H|| / ||F - mean(F)||) * 100` over complex (or real) values.
///
/// `truth` is the reference (measured or analytic), `model` the estimate. Returns
/// `-inf` when the reference is constant (to rounding). The sums are formed relative to
/// the largest value, so receptances near 1e±300 neither overflow nor underflow.
pub fn fit_percent(truth: &[Complex64], model: &[Complex64]) -> f64 {
    fit_percent_of(truth, model)
}

/// [`fit_percent`] for real signals (time responses): each sample taken as a complex
/// value with zero imaginary part as it is read, without complex copies of the signals.
pub fn fit_percent_real(truth: &[f64], model: &[f64]) -> f64 {
    fit_percent_of(truth, model)
}

/// [`fit_percent`] of values of any type that converts to a complex number.
fn fit_percent_of<T: Copy + Into<Complex64>>(truth: &[T], model: &[T]) -> f64 {
    assert_eq!(truth.len(), model.len(), "fit_percent: length mismatch");
    let c = |v: &T| -> Complex64 { (*v).into() };
    let n = truth.len().max(1) as f64;
    let top = truth
        .iter()
        .chain(model)
        .map(c)
        .fold(0.0f64, |m, v| m.max(v.re.abs()).max(v.im.abs()));
    if top == 0.0 {
        return f64::NEG_INFINITY;
    }
    let scale = if top.is_finite() { 1.0 / top } else { 1.0 };
    // two-pass mean: exact to rounding, so a constant reference is recognised
    let mean0 = truth.iter().map(|a| c(a) * scale).sum::<Complex64>() / n;
    let mean = mean0
        + truth
            .iter()
            .map(|a| c(a) * scale - mean0)
            .sum::<Complex64>()
            / n;
    let num: f64 = truth
        .iter()
        .zip(model)
        .map(|(a, b)| ((c(a) - c(b)) * scale).norm_sqr())
        .sum::<f64>()
        .sqrt();
    let den: f64 = truth
        .iter()
        .map(|a| (c(a) * scale - mean).norm_sqr())
        .sum::<f64>()
        .sqrt();
    let size: f64 = truth
        .iter()
        .map(|a| (c(a) * scale).norm_sqr())
        .sum::<f64>()
        .sqrt();
    if den == 0.0 || den <= 1e-12 * size {
        return f64::NEG_INFINITY;
    }
    (1.0 - num / den) * 100.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_fit_is_the_complex_fit_of_real_values() {
        let t: Vec<f64> = (0..257)
            .map(|k| (0.37 * k as f64).sin() * 1e-7 + 3e-9)
            .collect();
        let m: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(k, v)| v * (1.0 + 1e-3 * (k % 7) as f64))
            .collect();
        let c = |v: &[f64]| {
            v.iter()
                .map(|&x| Complex64::new(x, 0.0))
                .collect::<Vec<_>>()
        };
        assert_eq!(fit_percent_real(&t, &m), fit_percent(&c(&t), &c(&m)));
        assert_eq!(fit_percent_real(&[1.0; 5], &[2.0; 5]), f64::NEG_INFINITY);
    }

    #[test]
    fn fit_is_100_for_identical_and_0_for_mean() {
        let f: Vec<Complex64> = (0..10)
            .map(|i| Complex64::new(i as f64, -(i as f64) * 0.5))
            .collect();
        assert!((fit_percent(&f, &f) - 100.0).abs() < 1e-12);
        let mean = f.iter().sum::<Complex64>() / 10.0;
        let m = vec![mean; 10];
        assert!(fit_percent(&f, &m).abs() < 1e-12);
    }
}
