//! The data a fit works on: band-limited, weighted, scaled for conditioning.

use super::{FitOptions, Weighting};
use crate::axis::Channel;
use crate::error::{Error, Result};
use crate::frf::Frf;
use crate::model::{ChannelModel, ModalModel, Mode, ModeNum};
use num_complex::Complex64;
use std::f64::consts::PI;

/// FRF lines of the fitted band with their weights, in scaled units:
/// `s = jω / w_scale` (so the band ends near |s| = 1) and `h = H / h_scale[c]`
/// (every channel of unit weighted RMS, so all channels count alike).
#[derive(Debug, Clone)]
pub(crate) struct Prepared {
    /// The fitted lines in original units (channels with coherence when given).
    pub band: Frf,
    /// Scaled Laplace variable per line.
    pub s: Vec<Complex64>,
    /// Angular-frequency scale \[rad/s\].
    pub w_scale: f64,
    /// Channel names.
    pub channels: Vec<Channel>,
    /// Scaled FRF per channel and line.
    pub h: Vec<Vec<Complex64>>,
    /// Scale of each channel \[m/N\].
    pub h_scale: Vec<f64>,
    /// Amplitude weight per channel and line (0 = not fitted).
    pub w: Vec<Vec<f64>>,
    /// Per channel the lines with positive weight (the fitted ones), ascending.
    pub fitted: Vec<Vec<usize>>,
}

/// Largest coherence that still raises the weight; above it every line counts fully.
const COH_CLIP: f64 = 0.99;
/// Half-width in octaves of the neighbourhood whose RMS level divides the balanced weight.
const BALANCE_OCTAVES: f64 = 1.0 / 6.0;

/// RMS of `|h|` over the lines within ±`octaves` of each line.
pub(crate) fn local_level(freqs: &[f64], h: &[Complex64], octaves: f64) -> Vec<f64> {
    let power: Vec<f64> = h.iter().map(|v| v.norm_sqr()).collect();
    crate::plan::smooth_octave(freqs, &power, octaves)
        .into_iter()
        .map(|p| p.max(0.0).sqrt())
        .collect()
}

/// Largest coherence used by the inverse-variance weight.
const IV_CLIP: f64 = 0.9999;

impl Prepared {
    /// Validates `frf`, restricts it to the band and builds the weights.
    pub fn new(frf: &Frf, opts: &FitOptions) -> Result<Prepared> {
        let weights = match &opts.weighting {
            Weighting::Custom(w) => Some(w.as_slice()),
            _ => None,
        };
        Self::with_weights(frf, opts, weights)
    }

    /// As [`Prepared::new`] with explicit per channel per line weights (overriding
    /// `opts.weighting`).
    pub fn with_weights(
        frf: &Frf,
        opts: &FitOptions,
        custom: Option<&[Vec<f64>]>,
    ) -> Result<Prepared> {
        validate(frf)?;
        let nf = frf.freqs_hz.len();
        if let Some(w) = custom {
            if w.len() != frf.channels.len() || w.iter().any(|v| v.len() != nf) {
                return Err(Error::BadInput(format!(
                    "custom weights: need {} channels x {} lines, one weight per FRF line",
                    frf.channels.len(),
                    nf
                )));
            }
            if w.iter().flatten().any(|v| !v.is_finite() || *v < 0.0) {
                return Err(Error::BadInput(
                    "custom weights must be finite and non-negative".into(),
                ));
            }
        }
        let (lo, hi) = opts.band_hz.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        if !(lo < hi) {
            return Err(Error::BadInput(format!(
                "band {lo}..{hi} Hz is empty: give the lower edge first"
            )));
        }
        let w_full = full_weights(frf, opts, custom, (lo, hi));
        let keep: Vec<usize> = (0..nf)
            .filter(|&k| w_full.iter().any(|w| w[k] > 0.0))
            .collect();
        if keep.len() < 6 {
            return Err(Error::BadInput(format!(
                "only {} usable frequency lines in the band (coherence >= {} and inside {:?} Hz): \
                 widen the band, lower min_coherence or measure with more excitation",
                keep.len(),
                opts.min_coherence,
                opts.band_hz
            )));
        }
        let f_hi = frf.freqs_hz[*keep.last().unwrap_or(&0)];
        if f_hi <= 0.0 {
            return Err(Error::BadInput(
                "the band holds no positive frequency".into(),
            ));
        }
        let band = Frf {
            freqs_hz: keep.iter().map(|&k| frf.freqs_hz[k]).collect(),
            channels: frf
                .channels
                .iter()
                .map(|c| crate::frf::FrfChannel {
                    channel: c.channel,
                    h: keep.iter().map(|&k| c.h[k]).collect(),
                    coherence: c
                        .coherence
                        .as_ref()
                        .map(|g| keep.iter().map(|&k| g[k]).collect()),
                })
                .collect(),
        };
        let w: Vec<Vec<f64>> = w_full
            .iter()
            .map(|w| keep.iter().map(|&k| w[k]).collect())
            .collect();
        let w_scale = 2.0 * PI * f_hi;
        let s = band
            .freqs_hz
            .iter()
            .map(|f| Complex64::new(0.0, 2.0 * PI * f / w_scale))
            .collect();
        let mut h = Vec::new();
        let mut h_scale = Vec::new();
        for (c, wc) in band.channels.iter().zip(&w) {
            let sc = crate::frf::weighted_rms(&c.h, wc).unwrap_or(1.0);
            h_scale.push(sc);
            h.push(c.h.iter().map(|v| v / sc).collect());
        }
        let fitted = w
            .iter()
            .map(|wc| (0..wc.len()).filter(|&k| wc[k] > 0.0).collect())
            .collect();
        Ok(Prepared {
            channels: band.channels.iter().map(|c| c.channel).collect(),
            band,
            s,
            w_scale,
            h,
            h_scale,
            w,
            fitted,
        })
    }

    /// Number of lines.
    pub fn n_lines(&self) -> usize {
        self.s.len()
    }

    /// Σ w² |h|² over all channels and lines (the weighted data energy).
    pub fn energy(&self) -> f64 {
        self.h
            .iter()
            .zip(&self.w)
            .map(|(h, w)| {
                h.iter()
                    .zip(w)
                    .map(|(h, w)| w * w * h.norm_sqr())
                    .sum::<f64>()
            })
            .sum()
    }

    /// Model in original units from scaled modes and per channel coefficients
    /// `[b1_0, b0_0, b1_1, b0_1, …, d]` of the scaled basis `s/den`, `1/den`, `1`.
    pub fn to_model(&self, modes: &[Mode], coefs: &[Vec<f64>]) -> ModalModel {
        let ws = self.w_scale;
        let mut model = ModalModel {
            modes: modes
                .iter()
                .map(|m| Mode {
                    wn: m.wn * ws,
                    zeta: m.zeta,
                })
                .collect(),
            channels: self
                .channels
                .iter()
                .zip(coefs)
                .zip(&self.h_scale)
                .map(|((&channel, x), &hs)| ChannelModel {
                    channel,
                    num: (0..modes.len())
                        .map(|j| ModeNum {
                            b1: hs * x[2 * j] * ws,
                            b0: hs * x[2 * j + 1] * ws * ws,
                        })
                        .collect(),
                    d: hs * x[2 * modes.len()],
                })
                .collect(),
        };
        model.sort_modes();
        model
    }

    /// Scaled modes of a model in original units.
    pub fn scale_modes(&self, modes: &[Mode]) -> Vec<Mode> {
        modes
            .iter()
            .map(|m| Mode {
                wn: m.wn / self.w_scale,
                zeta: m.zeta,
            })
            .collect()
    }
}

fn validate(frf: &Frf) -> Result<()> {
    let nf = frf.freqs_hz.len();
    if frf.channels.is_empty() {
        return Err(Error::BadInput("the FRF has no channel to fit".into()));
    }
    if frf.freqs_hz.iter().any(|f| !f.is_finite() || *f < 0.0) {
        return Err(Error::BadInput(
            "FRF frequencies must be finite and non-negative".into(),
        ));
    }
    if frf.freqs_hz.windows(2).any(|p| p[1] <= p[0]) {
        return Err(Error::BadInput(
            "FRF frequencies must be strictly increasing".into(),
        ));
    }
    for c in &frf.channels {
        if c.h.len() != nf {
            return Err(Error::BadInput(format!(
                "channel {}: {} values for {} frequency lines",
                c.channel,
                c.h.len(),
                nf
            )));
        }
        if let Some(k) =
            c.h.iter()
                .position(|h| !h.re.is_finite() || !h.im.is_finite())
        {
            return Err(Error::BadInput(format!(
                "channel {}: non-finite value at {} Hz; remove or repair that line",
                c.channel, frf.freqs_hz[k]
            )));
        }
        if let Some(g) = &c.coherence {
            if g.len() != nf {
                return Err(Error::BadInput(format!(
                    "channel {}: {} coherence values for {} lines",
                    c.channel,
                    g.len(),
                    nf
                )));
            }
        }
    }
    Ok(())
}

/// Amplitude weight per channel per line on the full grid of `frf`: `custom` when given,
/// else from `opts.weighting`; zero below `opts.min_coherence` and outside `band`.
pub(crate) fn full_weights(
    frf: &Frf,
    opts: &FitOptions,
    custom: Option<&[Vec<f64>]>,
    band: (f64, f64),
) -> Vec<Vec<f64>> {
    let nf = frf.freqs_hz.len();
    let (lo, hi) = band;
    let mut w_full: Vec<Vec<f64>> = Vec::with_capacity(frf.channels.len());
    for (ci, ch) in frf.channels.iter().enumerate() {
        let mut w = match (custom, &opts.weighting, &ch.coherence) {
            (Some(cw), _, _) => cw[ci].clone(),
            (None, Weighting::InverseVariance, Some(g)) => {
                // W = 1/σ with σ² = |H|² (1−γ²)/γ² (the H1 variance), normalised later;
                // γ² capped so a perfect line does not get an infinite weight
                let peak = ch.h.iter().map(|v| v.norm()).fold(0.0, f64::max);
                g.iter()
                    .zip(&ch.h)
                    .map(|(&g, h)| {
                        let g = g.clamp(0.0, IV_CLIP);
                        let mag = h.norm().max(1e-6 * peak);
                        if mag > 0.0 {
                            (g / (1.0 - g)).sqrt() / mag
                        } else {
                            0.0
                        }
                    })
                    .collect()
            }
            (None, Weighting::Coherence | Weighting::Balanced | Weighting::Mobility, Some(g)) => g
                .iter()
                .map(|&g| {
                    let g = g.clamp(0.0, COH_CLIP);
                    (g / (1.0 - g) * (1.0 - COH_CLIP) / COH_CLIP).sqrt()
                })
                .collect(),
            _ => vec![1.0; nf],
        };
        if custom.is_none() && opts.weighting == Weighting::Balanced {
            let level = local_level(&frf.freqs_hz, &ch.h, BALANCE_OCTAVES);
            let top = level.iter().cloned().fold(0.0, f64::max);
            for (w, l) in w.iter_mut().zip(&level) {
                *w = if *l > 1e-12 * top { *w / l } else { 0.0 };
            }
        }
        if custom.is_none() && opts.weighting == Weighting::Mobility {
            // W·|H| ∝ |jω H|: the mobility's own scale (the absolute factor cancels)
            let top = frf.freqs_hz.iter().fold(0.0f64, |m, f| m.max(f.abs()));
            if top > 0.0 {
                for (w, f) in w.iter_mut().zip(&frf.freqs_hz) {
                    *w *= f.abs() / top;
                }
            }
        }
        if let Some(g) = &ch.coherence {
            for (w, g) in w.iter_mut().zip(g) {
                if *g < opts.min_coherence || !g.is_finite() {
                    *w = 0.0;
                }
            }
        }
        for (k, f) in frf.freqs_hz.iter().enumerate() {
            if *f < lo || *f > hi {
                w[k] = 0.0;
            }
        }
        w_full.push(w);
    }
    w_full
}
