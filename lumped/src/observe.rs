//! What an impact test can observe: the ordinary coherence of its H1 estimate per
//! channel (hits averaged, one rectangular segment per hit). A hidden effect that acts
//! only where the test's coherence is poor (a low mode whose acceleration sinks into the
//! accelerometer's 1/f noise) leaves no trace in the data: no diagnosis can name it, so
//! the effect draws of [`crate::effects`] pick modes and channels the test observes.

use crate::record::Record;
use num_complex::Complex64;
use rustfft::FftPlanner;

/// The coherence a test must reach at a mode for the mode to count as observed (a
/// textbook lower limit for a usable FRF estimate).
pub const OBSERVED_COHERENCE: f64 = 0.9;

/// Coherence of an impact record's H1 from force axis `input` to each response axis:
/// `(frequencies [Hz], [γ²_x, γ²_y, γ²_z])`, averaged over the hits (hits = force above
/// 5 % of its peak after 50 ms of quiet; segments from 2 ms before each hit, as long as
/// the shortest spacing between hits). Fewer than 2 hits: all coherences 1 (no average).
pub fn impact_coherence(r: &Record, input: usize) -> (Vec<f64>, [Vec<f64>; 3]) {
    let f = &r.force[input.min(2)];
    let peak = f.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let gap = (0.05 * r.fs) as usize;
    let mut starts: Vec<usize> = Vec::new();
    let mut last: Option<usize> = None;
    for (i, v) in f.iter().enumerate() {
        if v.abs() > 0.05 * peak {
            if last.is_none_or(|l| i > l + gap) {
                starts.push(i.saturating_sub((0.002 * r.fs) as usize));
            }
            last = Some(i);
        }
    }
    let n = f.len();
    let len = starts
        .windows(2)
        .map(|w| w[1] - w[0])
        .chain(starts.last().map(|s| n - s))
        .min()
        .unwrap_or(n)
        .max(16);
    let fft = FftPlanner::<f64>::new().plan_fft_forward(len);
    let nl = len / 2;
    let freqs: Vec<f64> = (0..nl).map(|l| l as f64 * r.fs / len as f64).collect();
    let spec = |x: &[f64], s: usize| {
        let mut b: Vec<Complex64> = (0..len)
            .map(|k| Complex64::new(x.get(s + k).copied().unwrap_or(0.0), 0.0))
            .collect();
        fft.process(&mut b);
        b
    };
    let coh = [0usize, 1, 2].map(|o| {
        if starts.len() < 2 {
            return vec![1.0; nl];
        }
        let mut gff = vec![0.0; nl];
        let mut gyy = vec![0.0; nl];
        let mut gfy = vec![Complex64::new(0.0, 0.0); nl];
        for &s in &starts {
            let fs_ = spec(f, s);
            let ys = spec(&r.response[o], s);
            for l in 0..nl {
                gff[l] += fs_[l].norm_sqr();
                gyy[l] += ys[l].norm_sqr();
                gfy[l] += fs_[l].conj() * ys[l];
            }
        }
        (0..nl)
            .map(|l| (gfy[l].norm_sqr() / (gff[l] * gyy[l]).max(1e-300)).clamp(0.0, 1.0))
            .collect()
    });
    (freqs, coh)
}

/// Mean of `coh` over the lines within ±2 % of `f_hz` (at least the nearest line).
pub fn coherence_near(freqs: &[f64], coh: &[f64], f_hz: f64) -> f64 {
    let idx: Vec<usize> = (0..freqs.len())
        .filter(|&i| (freqs[i] / f_hz - 1.0).abs() <= 0.02)
        .collect();
    if idx.is_empty() {
        let i = freqs
            .partition_point(|x| *x < f_hz)
            .min(coh.len().saturating_sub(1));
        return coh.get(i).copied().unwrap_or(0.0);
    }
    idx.iter().map(|&i| coh[i]).sum::<f64>() / idx.len() as f64
}

/// The coherences of a healthy impact test (hammer along x, then y), to judge which
/// modes and channels a test observes.
#[derive(Debug, Clone)]
pub struct Observability {
    /// Per force axis (x, y): frequencies and coherence per response axis.
    pub by_input: Vec<(Vec<f64>, [Vec<f64>; 3])>,
}

impl Observability {
    /// From impact records, hammer along x and along y.
    pub fn from_records(x: &Record, y: &Record) -> Self {
        Observability {
            by_input: vec![impact_coherence(x, 0), impact_coherence(y, 1)],
        }
    }

    /// Coherence near `f_hz` of response axis `out` per force axis `inp`.
    pub fn coherence(&self, out: usize, inp: usize, f_hz: f64) -> f64 {
        self.by_input
            .get(inp)
            .map_or(0.0, |(f, c)| coherence_near(f, &c[out.min(2)], f_hz))
    }

    /// Whether a mode at `f_hz` moving mainly along `axis` is observed: some hammer
    /// direction's response along `axis` reaches [`OBSERVED_COHERENCE`] there.
    pub fn observes(&self, axis: usize, f_hz: f64) -> bool {
        (0..self.by_input.len()).any(|i| self.coherence(axis, i, f_hz) >= OBSERVED_COHERENCE)
    }
}
