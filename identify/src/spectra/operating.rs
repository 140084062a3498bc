//! Spectra of operating data: forces on several axes at once (milling), so the FRF
//! at each line is the multi-input H1 `H = G_yf G_ff⁻¹`, with the multiple coherence and
//! the standard error of every point. Also the response PSD the paper thresholds.

use crate::axis::{Axis, Channel};
use crate::error::{Error, Result};
use crate::timeseries::{ResponseKind, TimeSeries};
use nalgebra::{Complex, DMatrix};
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Cross-spectral FRF estimate of operating records.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OperatingSpectra {
    /// Frequency lines \[Hz\] (0 Hz excluded).
    pub freqs_hz: Vec<f64>,
    /// Force axes used as inputs.
    pub inputs: Vec<Axis>,
    /// Response axes.
    pub outputs: Vec<Axis>,
    /// Receptance per (output, input) channel and line.
    pub h: Vec<(Channel, Vec<Complex64>)>,
    /// Multiple coherence per output and line.
    pub coherence: Vec<(Axis, Vec<f64>)>,
    /// Response PSD (displacement, m²/Hz) per output and line.
    pub psd_out: Vec<(Axis, Vec<f64>)>,
    /// Force PSD (N²/Hz) per input and line.
    pub psd_in: Vec<(Axis, Vec<f64>)>,
    /// Standard error of each H point per channel and line (same order as `h`):
    /// `sqrt((1 − γ²) G_yy [G_ff⁻¹]_jj / (2 n))` per real component — with correlated
    /// inputs (the cutting forces in x and y) larger than the single-input value of
    /// [`OperatingSpectra::rel_error`].
    pub sigma: Vec<(Channel, Vec<f64>)>,
    /// Number of averaged segments.
    pub n_avg: usize,
    /// Line spacing \[Hz\].
    pub df_hz: f64,
}

impl OperatingSpectra {
    /// Relative standard error of an H1 point with coherence `g2` over `n` averages
    /// (Bendat & Piersol): `sqrt((1-γ²) / (2 n γ²))`.
    pub fn rel_error(g2: f64, n: usize) -> f64 {
        let g2 = g2.clamp(1e-6, 1.0 - 1e-9);
        ((1.0 - g2) / (2.0 * n.max(1) as f64 * g2)).sqrt()
    }
}

/// Welch estimate (Hann, 50 % overlap, segments of `nfft`) over one or more records with
/// the same sample rate. Acceleration responses are turned into receptance by −1/ω².
pub fn operating_spectra(records: &[TimeSeries], nfft: usize) -> Result<OperatingSpectra> {
    let first = records
        .first()
        .ok_or_else(|| Error::BadInput("no operating data".into()))?;
    let dt = first.dt;
    let inputs: Vec<Axis> = Axis::ALL
        .into_iter()
        .filter(|a| {
            records
                .iter()
                .all(|r| r.force(*a).is_some_and(|f| f.iter().any(|v| *v != 0.0)))
        })
        .collect();
    let outputs: Vec<Axis> = Axis::ALL
        .into_iter()
        .filter(|a| records.iter().all(|r| r.response(*a).is_some()))
        .collect();
    if inputs.is_empty() || outputs.is_empty() {
        return Err(Error::BadInput(
            "operating data needs force and response columns present in every record".into(),
        ));
    }
    for r in records {
        if (r.dt - dt).abs() > 1e-6 * dt {
            return Err(Error::BadInput(format!(
                "{}: sample rate differs from {} ({} vs {} Hz); resample or refit separately",
                r.source,
                first.source,
                1.0 / r.dt,
                1.0 / dt
            )));
        }
    }
    let (ni, no) = (inputs.len(), outputs.len());
    let nl = nfft / 2;
    let window: Vec<f64> = (0..nfft)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / nfft as f64).cos())
        .collect();
    let wss: f64 = window.iter().map(|w| w * w).sum();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(nfft);
    // accumulators per line: Gff (ni×ni), Gyf (no×ni), Gyy (no)
    let mut gff = vec![Complex64::new(0.0, 0.0); nl * ni * ni];
    let mut gyf = vec![Complex64::new(0.0, 0.0); nl * no * ni];
    let mut gyy = vec![0.0; nl * no];
    let mut n_avg = 0usize;
    let mut buf_f: Vec<Vec<Complex64>> = vec![vec![Complex64::new(0.0, 0.0); nfft]; ni];
    let mut buf_y: Vec<Vec<Complex64>> = vec![vec![Complex64::new(0.0, 0.0); nfft]; no];
    for r in records {
        let n = r.len();
        if n < nfft {
            continue;
        }
        let hop = nfft / 2;
        let mut start = 0;
        while start + nfft <= n {
            for (b, a) in buf_f.iter_mut().zip(&inputs) {
                let x = &r.force(*a).unwrap_or(&[])[start..start + nfft];
                let mean = x.iter().sum::<f64>() / nfft as f64;
                for i in 0..nfft {
                    b[i] = Complex64::new((x[i] - mean) * window[i], 0.0);
                }
                fft.process(b);
            }
            for (b, a) in buf_y.iter_mut().zip(&outputs) {
                let x = &r.response(*a).unwrap_or(&[])[start..start + nfft];
                let mean = x.iter().sum::<f64>() / nfft as f64;
                for i in 0..nfft {
                    b[i] = Complex64::new((x[i] - mean) * window[i], 0.0);
                }
                fft.process(b);
            }
            for l in 1..nl {
                for i in 0..ni {
                    for j in 0..ni {
                        gff[(l * ni + i) * ni + j] += buf_f[i][l] * buf_f[j][l].conj();
                    }
                }
                for o in 0..no {
                    for j in 0..ni {
                        gyf[(l * no + o) * ni + j] += buf_y[o][l] * buf_f[j][l].conj();
                    }
                    gyy[l * no + o] += buf_y[o][l].norm_sqr();
                }
            }
            n_avg += 1;
            start += hop;
        }
    }
    if n_avg == 0 {
        return Err(Error::BadInput(format!(
            "operating records are shorter than one spectral segment ({nfft} samples = {:.3} s)",
            nfft as f64 * dt
        )));
    }
    let fs = 1.0 / dt;
    let df = fs / nfft as f64;
    let norm = 2.0 / (fs * wss * n_avg as f64);
    let accel = first.response_kind == Some(ResponseKind::Acceleration);
    let mut freqs = Vec::with_capacity(nl - 1);
    let mut h: Vec<(Channel, Vec<Complex64>)> = Vec::new();
    for &o in &outputs {
        for &i in &inputs {
            h.push((Channel::new(o, i), Vec::with_capacity(nl - 1)));
        }
    }
    let mut sigma: Vec<(Channel, Vec<f64>)> = h
        .iter()
        .map(|(c, _)| (*c, Vec::with_capacity(nl - 1)))
        .collect();
    let mut coh: Vec<(Axis, Vec<f64>)> = outputs.iter().map(|a| (*a, Vec::new())).collect();
    let mut pout: Vec<(Axis, Vec<f64>)> = outputs.iter().map(|a| (*a, Vec::new())).collect();
    let mut pin: Vec<(Axis, Vec<f64>)> = inputs.iter().map(|a| (*a, Vec::new())).collect();
    for l in 1..nl {
        let f = l as f64 * df;
        freqs.push(f);
        let w2 = (2.0 * PI * f).powi(2);
        let conv = if accel { -1.0 / w2 } else { 1.0 };
        let g = DMatrix::<Complex<f64>>::from_fn(ni, ni, |i, j| gff[(l * ni + i) * ni + j]);
        let ginv = g.clone().try_inverse();
        for (j, p) in pin.iter_mut().enumerate() {
            p.1.push(gff[(l * ni + j) * ni + j].re * norm);
        }
        for o in 0..no {
            let row = DMatrix::<Complex<f64>>::from_fn(1, ni, |_, j| gyf[(l * no + o) * ni + j]);
            let hrow = match &ginv {
                Some(gi) => &row * gi,
                None => DMatrix::zeros(1, ni),
            };
            // multiple coherence: H Gfy / Gyy
            let explained: Complex64 = (0..ni).map(|j| hrow[(0, j)] * row[(0, j)].conj()).sum();
            let gy = gyy[l * no + o];
            let g2 = if gy > 0.0 {
                (explained.re / gy).clamp(0.0, 1.0)
            } else {
                0.0
            };
            coh[o].1.push(g2);
            pout[o].1.push(gy * norm * conv * conv);
            for j in 0..ni {
                h[o * ni + j].1.push(hrow[(0, j)] * conv);
                let var = ginv.as_ref().map_or(f64::INFINITY, |gi| {
                    (1.0 - g2) * gy * gi[(j, j)].re.max(0.0) / (2.0 * n_avg as f64)
                });
                sigma[o * ni + j].1.push(var.sqrt() * conv.abs());
            }
        }
    }
    Ok(OperatingSpectra {
        freqs_hz: freqs,
        inputs,
        outputs,
        h,
        coherence: coh,
        psd_out: pout,
        psd_in: pin,
        sigma,
        n_avg,
        df_hz: df,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two simultaneous random forces through two known FIR paths into one response:
    /// the multi-input H1 recovers both paths (DFT of the FIR taps), coherence ≈ 1.
    #[test]
    fn mimo_h1_recovers_two_fir_paths() {
        let n = 1 << 15;
        let mut lcg = crate::test_util::Lcg(12345);
        let mut rnd = || lcg.uniform();
        let f1: Vec<f64> = (0..n).map(|_| rnd()).collect();
        let f2: Vec<f64> = (0..n).map(|_| rnd() + 0.3 * rnd()).collect();
        let h1 = [0.5, 0.25, -0.1];
        let h2 = [0.0, -0.3, 0.2, 0.05];
        let y: Vec<f64> = (0..n)
            .map(|k| {
                let a: f64 = h1
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| k >= *i)
                    .map(|(i, c)| c * f1[k - i])
                    .sum();
                let b: f64 = h2
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| k >= *i)
                    .map(|(i, c)| c * f2[k - i])
                    .sum();
                a + b
            })
            .collect();
        let ts = TimeSeries {
            source: "synthetic".into(),
            t0: 0.0,
            dt: 1e-3,
            force: [Some(f1), Some(f2), None],
            response: [Some(y), None, None],
            response_kind: Some(ResponseKind::Displacement),
            ..Default::default()
        };
        let sp = operating_spectra(&[ts], 256).unwrap();
        let dft = |taps: &[f64], f: f64| -> Complex64 {
            taps.iter()
                .enumerate()
                .map(|(i, c)| Complex64::from_polar(*c, -2.0 * PI * f * i as f64 * 1e-3))
                .sum()
        };
        for (ch, taps) in [(0usize, &h1[..]), (1, &h2[..])] {
            for (l, f) in sp.freqs_hz.iter().enumerate().step_by(7) {
                let e = (sp.h[ch].1[l] - dft(taps, *f)).norm();
                assert!(e < 0.02, "path {ch} at {f} Hz: error {e}");
            }
        }
        assert!(sp.coherence[0].1.iter().all(|g| *g > 0.99));
    }
}
