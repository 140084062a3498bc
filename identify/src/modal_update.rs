//! Update of selected modes of a model from FRF points (Levenberg–Marquardt with a prior).
//!
//! The lifetime refit's own method: only the modes whose resonance region the operating
//! data excites are free (natural frequency, damping, numerators of every channel); the
//! others are held. The data term is the complex misfit at the measured lines, each
//! weighted by the inverse of its standard error (from coherence); a weak prior pulls
//! the free parameters towards the previous model so that a mode seen on one flank
//! only cannot run away.

use crate::axis::Channel;
use crate::error::{Error, Result};
use crate::model::ModalModel;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// FRF points of one channel with their standard errors.
#[derive(Debug, Clone)]
pub struct Points {
    /// The channel.
    pub channel: Channel,
    /// Frequencies \[Hz\].
    pub freqs_hz: Vec<f64>,
    /// Measured receptance.
    pub h: Vec<Complex64>,
    /// Standard error of each point (same unit as `h`), > 0.
    pub sigma: Vec<f64>,
}

/// Squared misfits `|F(f) e^{−iωτ} − H| ² / σ²` of every point, per channel (the model's
/// response delayed by `delay_s`; channels the model lacks count as model = 0).
fn normalized_residuals(model: &ModalModel, pts: &[Points], delay_s: f64) -> Vec<Vec<f64>> {
    pts.iter()
        .map(|p| {
            let ci = model.channel_index(p.channel);
            p.freqs_hz
                .iter()
                .zip(&p.h)
                .zip(&p.sigma)
                .map(|((f, h), sg)| {
                    let m = ci.map_or(Complex64::new(0.0, 0.0), |ci| {
                        model.eval_hz(ci, *f) * Complex64::from_polar(1.0, -2.0 * PI * f * delay_s)
                    });
                    ((m - h) / sg).norm_sqr()
                })
                .collect()
        })
        .collect()
}

/// RMS misfit in standard errors per real component (1 = within noise).
pub fn chi(model: &ModalModel, pts: &[Points], delay_s: f64) -> f64 {
    let r2 = normalized_residuals(model, pts, delay_s);
    let n: usize = r2.iter().map(Vec::len).sum();
    if n == 0 {
        return 0.0;
    }
    (r2.iter().flatten().sum::<f64>() / (2 * n) as f64).sqrt()
}

/// Largest local RMS misfit in standard errors: over every window of ±2.5 % around a
/// point (at least 5 points), per channel. A missing or shifted resonance is local; the
/// global RMS of [`chi`] dilutes it over the whole band.
pub fn chi_local(model: &ModalModel, pts: &[Points], delay_s: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for (p, r2) in pts.iter().zip(normalized_residuals(model, pts, delay_s)) {
        let f = &p.freqs_hz;
        let (mut lo, mut hi) = (0usize, 0usize);
        let mut acc = 0.0;
        for i in 0..f.len() {
            while hi < f.len() && f[hi] <= f[i] * 1.025 {
                acc += r2[hi] / 2.0;
                hi += 1;
            }
            while f[lo] < f[i] * 0.975 {
                acc -= r2[lo] / 2.0;
                lo += 1;
            }
            let n = hi - lo;
            if n >= 5 {
                worst = worst.max((acc.max(0.0) / n as f64).sqrt());
            }
        }
    }
    worst
}

/// Prior widths (one standard deviation) of the free parameters.
#[derive(Debug, Clone, Copy)]
pub struct Prior {
    /// Of ln ω (0.2 = 20 % frequency change).
    pub ln_wn: f64,
    /// Of ln ζ.
    pub ln_zeta: f64,
    /// Of a numerator, relative to the mode's numerator scale.
    pub num_rel: f64,
}

impl Default for Prior {
    fn default() -> Self {
        Prior {
            ln_wn: 0.2,
            ln_zeta: 1.0,
            num_rel: 0.5,
        }
    }
}

/// Result of [`update_modes`].
#[derive(Debug, Clone)]
pub struct UpdateResult {
    /// The updated model.
    pub model: ModalModel,
    /// Weighted RMS misfit (in standard errors) before and after.
    pub chi_before: f64,
    /// See `chi_before`.
    pub chi_after: f64,
    /// LM iterations used.
    pub iterations: usize,
}

struct Layout {
    free: Vec<usize>,
    n_ch: usize,
}

impl Layout {
    fn n(&self) -> usize {
        self.free.len() * (2 + 2 * self.n_ch)
    }
}

fn unpack(base: &ModalModel, lay: &Layout, theta: &[f64], scale: &[f64]) -> ModalModel {
    let mut m = base.clone();
    let per = 2 + 2 * lay.n_ch;
    for (j, &k) in lay.free.iter().enumerate() {
        let o = j * per;
        m.modes[k].wn = theta[o].exp();
        m.modes[k].zeta = theta[o + 1].exp();
        for c in 0..lay.n_ch {
            m.channels[c].num[k].b0 = theta[o + 2 + 2 * c] * scale[j];
            m.channels[c].num[k].b1 = theta[o + 3 + 2 * c] * scale[j] / base.modes[k].wn;
        }
    }
    m
}

/// Updates the modes `free` of `model` to fit `points` (Levenberg–Marquardt).
pub fn update_modes(
    model: &ModalModel,
    free: &[usize],
    points: &[Points],
    prior: Prior,
    max_iter: usize,
) -> Result<UpdateResult> {
    let lay = Layout {
        free: free.to_vec(),
        n_ch: model.channels.len(),
    };
    if lay.free.is_empty() {
        return Ok(UpdateResult {
            model: model.clone(),
            chi_before: 0.0,
            chi_after: 0.0,
            iterations: 0,
        });
    }
    // numerator scale per free mode: the largest |b0| + |b1| ω over the channels
    let scale: Vec<f64> = lay
        .free
        .iter()
        .map(|&k| {
            let w = model.modes[k].wn;
            model
                .channels
                .iter()
                .map(|c| c.num[k].b0.abs() + c.num[k].b1.abs() * w)
                .fold(0.0, f64::max)
                .max(1e-300)
        })
        .collect();
    let per = 2 + 2 * lay.n_ch;
    let mut theta0 = vec![0.0; lay.n()];
    for (j, &k) in lay.free.iter().enumerate() {
        let o = j * per;
        theta0[o] = model.modes[k].wn.ln();
        theta0[o + 1] = model.modes[k].zeta.max(1e-6).ln();
        for c in 0..lay.n_ch {
            theta0[o + 2 + 2 * c] = model.channels[c].num[k].b0 / scale[j];
            theta0[o + 3 + 2 * c] = model.channels[c].num[k].b1 * model.modes[k].wn / scale[j];
        }
    }
    let prior_sd: Vec<f64> = (0..lay.n())
        .map(|i| match i % per {
            0 => prior.ln_wn,
            1 => prior.ln_zeta,
            _ => prior.num_rel,
        })
        .collect();
    let chan_idx: Vec<Option<usize>> = points
        .iter()
        .map(|p| model.channel_index(p.channel))
        .collect();
    let n_data: usize = points.iter().map(|p| 2 * p.h.len()).sum();
    if n_data == 0 {
        return Err(Error::BadInput(
            "no FRF points to update the model from (the operating data excites nothing in band)"
                .into(),
        ));
    }
    let n_res = n_data + lay.n();
    let residuals = |theta: &[f64]| -> (DVector<f64>, ModalModel) {
        let m = unpack(model, &lay, theta, &scale);
        let mut r = DVector::zeros(n_res);
        let mut i = 0;
        for (p, ci) in points.iter().zip(&chan_idx) {
            for ((f, h), s) in p.freqs_hz.iter().zip(&p.h).zip(&p.sigma) {
                let e = match ci {
                    Some(ci) => (m.eval_hz(*ci, *f) - h) / *s,
                    None => Complex64::new(0.0, 0.0),
                };
                r[i] = e.re;
                r[i + 1] = e.im;
                i += 2;
            }
        }
        for (j, (t, t0)) in theta.iter().zip(&theta0).enumerate() {
            r[n_data + j] = (t - t0) / prior_sd[j];
        }
        (r, m)
    };
    let jacobian = |theta: &[f64], m: &ModalModel| -> DMatrix<f64> {
        let mut jm = DMatrix::zeros(n_res, lay.n());
        let mut i = 0;
        for (p, ci) in points.iter().zip(&chan_idx) {
            let Some(ci) = *ci else {
                i += 2 * p.h.len();
                continue;
            };
            for (f, s) in p.freqs_hz.iter().zip(&p.sigma) {
                let sv = Complex64::new(0.0, 2.0 * PI * f);
                for (j, &k) in lay.free.iter().enumerate() {
                    let o = j * per;
                    let mode = m.modes[k];
                    let den = mode.den(sv);
                    let num = m.channels[ci].num[k];
                    let nv = sv * num.b1 + num.b0;
                    // d/d ln ω and d/d ln ζ of (b1 s + b0)/(s² + 2ζω s + ω²)
                    let [dden_dlnw, dden_dlnz] = mode.den_log_derivatives(sv);
                    let d_lnw = -nv * dden_dlnw / (den * den);
                    let d_lnz = -nv * dden_dlnz / (den * den);
                    let d_b0 = Complex64::new(scale[j], 0.0) / den;
                    let d_b1 = sv * (scale[j] / model.modes[k].wn) / den;
                    let mut put = |col: usize, v: Complex64| {
                        jm[(i, col)] = v.re / s;
                        jm[(i + 1, col)] = v.im / s;
                    };
                    put(o, d_lnw);
                    put(o + 1, d_lnz);
                    put(o + 2 + 2 * ci, d_b0);
                    put(o + 3 + 2 * ci, d_b1);
                }
                i += 2;
            }
        }
        for j in 0..lay.n() {
            jm[(n_data + j, j)] = 1.0 / prior_sd[j];
        }
        let _ = theta;
        jm
    };
    let mut theta = theta0.clone();
    let (mut r, mut m) = residuals(&theta);
    let chi_before = (r.rows(0, n_data).norm_squared() / n_data as f64).sqrt();
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut it = 0;
    while it < max_iter {
        it += 1;
        let jm = jacobian(&theta, &m);
        let jt = jm.transpose();
        let jtj = &jt * &jm;
        let g = &jt * &r;
        let mut improved = false;
        for _ in 0..12 {
            let mut a = jtj.clone();
            for d in 0..a.nrows() {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let cand: Vec<f64> = theta.iter().zip(step.iter()).map(|(t, s)| t + s).collect();
            let (rc, mc) = residuals(&cand);
            let cc = rc.norm_squared();
            if cc.is_finite() && cc < cost && mc.is_valid() {
                let rel = (cost - cc) / cost.max(1e-300);
                theta = cand;
                r = rc;
                m = mc;
                cost = cc;
                lambda = (lambda * 0.3).max(1e-9);
                improved = rel > 1e-10;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let chi_after = (r.rows(0, n_data).norm_squared() / n_data as f64).sqrt();
    if !m.is_valid() {
        return Err(Error::Numerical(
            "modal update produced an invalid model".into(),
        ));
    }
    Ok(UpdateResult {
        model: m,
        chi_before,
        chi_after,
        iterations: it,
    })
}

/// `target` changed like `old → new` with weight `w`: relative when old and new share a
/// sign and old is not negligible, absolute otherwise.
fn scale_change(target: f64, old: f64, new: f64, w: f64) -> f64 {
    if old.abs() > 1e-12 * (new.abs() + old.abs()) && (new / old) > 0.0 {
        target * (1.0 + w * (new / old - 1.0))
    } else {
        target + w * (new - old)
    }
}

/// Applies the change `old → new` (models at the operating pose) to `target` with
/// weight `w` in [0, 1].
pub fn apply_change(target: &mut ModalModel, old: &ModalModel, new: &ModalModel, w: f64) {
    for k in 0..target.modes.len().min(old.modes.len()) {
        let r = new.modes[k].wn / old.modes[k].wn;
        target.modes[k].wn *= r.powf(w);
        let dz = (new.modes[k].zeta / old.modes[k].zeta).ln();
        target.modes[k].zeta *= (w * dz).exp();
        for ((t, o), n) in target
            .channels
            .iter_mut()
            .zip(&old.channels)
            .zip(&new.channels)
        {
            let nk = &mut t.num[k];
            nk.b0 = scale_change(nk.b0, o.num[k].b0, n.num[k].b0, w);
            nk.b1 = scale_change(nk.b1, o.num[k].b1, n.num[k].b1, w);
        }
    }
    for ((t, o), n) in target
        .channels
        .iter_mut()
        .zip(&old.channels)
        .zip(&new.channels)
    {
        t.d += w * (n.d - o.d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use crate::model::{ChannelModel, Mode, ModeNum};

    fn two_modes(f2: f64) -> ModalModel {
        let modes = vec![Mode::from_hz(100.0, 0.02), Mode::from_hz(f2, 0.03)];
        let num = modes
            .iter()
            .map(|m| ModeNum {
                b0: 1e-6 * m.wn * m.wn,
                b1: 0.0,
            })
            .collect();
        ModalModel {
            modes,
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num,
                d: 0.0,
            }],
        }
    }

    /// A shifted second mode is recovered from points around it only; the first mode,
    /// held, stays exactly as it was.
    #[test]
    fn recovers_a_shifted_mode_from_local_points() {
        let old = two_modes(300.0);
        let truth = two_modes(280.0);
        let freqs: Vec<f64> = (0..40).map(|i| 250.0 + i as f64 * 2.0).collect();
        let h: Vec<Complex64> = freqs.iter().map(|&f| truth.eval_hz(0, f)).collect();
        let sigma = h.iter().map(|v| 0.01 * v.norm() + 1e-12).collect();
        let pts = [Points {
            channel: Channel::new(Axis::X, Axis::X),
            freqs_hz: freqs,
            h,
            sigma,
        }];
        let res = update_modes(&old, &[1], &pts, Prior::default(), 50).unwrap();
        assert!(
            (res.model.modes[1].freq_hz() - 280.0).abs() < 0.05,
            "{:?}",
            res.model.modes
        );
        assert_eq!(res.model.modes[0], old.modes[0]);
        assert!(res.chi_after < 0.05 * res.chi_before);
    }
}
