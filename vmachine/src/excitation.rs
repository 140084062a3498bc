//! Excitation signals, sampled at the simulation rate.

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;

/// One hammer hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Time of the hit, in s.
    pub t: f64,
    /// Peak force, in N.
    pub peak: f64,
    /// Duration of the half-sine pulse, in s (about 0.3 ms for a steel tip).
    pub width: f64,
}

/// A train of half-sine hammer hits, `n` samples at `fs` Hz. A force above `clip` (the
/// sensor's range) is clipped there, as an overloaded channel records it.
pub fn impacts(fs: f64, n: usize, hits: &[Hit], clip: Option<f64>) -> Vec<f64> {
    let mut f = vec![0.0; n];
    for h in hits {
        let i0 = (h.t * fs).floor().max(0.0) as usize;
        let i1 = ((h.t + h.width) * fs).ceil() as usize;
        for i in i0..=i1.min(n.saturating_sub(1)) {
            let tau = i as f64 / fs - h.t;
            if tau > 0.0 && tau < h.width {
                f[i] += h.peak * (PI * tau / h.width).sin();
            }
        }
    }
    if let Some(c) = clip {
        f.iter_mut().for_each(|v| *v = v.clamp(-c, c));
    }
    f
}

/// Evenly spaced hits: `count` hits every `spacing` seconds starting at `first`, peaks
/// drawn around `peak` (±20 %) from `seed`.
pub fn hit_series(
    count: usize,
    first: f64,
    spacing: f64,
    peak: f64,
    width: f64,
    seed: u64,
) -> Vec<Hit> {
    let mut rng = StdRng::seed_from_u64(seed);
    let u = rand_distr::Uniform::new(0.8, 1.2);
    (0..count)
        .map(|i| Hit {
            t: first + i as f64 * spacing,
            peak: peak * u.sample(&mut rng),
            width,
        })
        .collect()
}

/// Linear chirp from `f0` to `f1` Hz over `n` samples at `fs` Hz, amplitude `amp`.
/// With `periods > 1` the sweep is repeated (a periodic chirp: each period an exact
/// repetition, so averaging over periods gives an unbiased FRF).
pub fn chirp(fs: f64, n: usize, f0: f64, f1: f64, amp: f64, periods: usize) -> Vec<f64> {
    let p = (n / periods.max(1)).max(1);
    let tp = p as f64 / fs;
    (0..n)
        .map(|i| {
            let t = (i % p) as f64 / fs;
            amp * (2.0 * PI * (f0 * t + 0.5 * (f1 - f0) / tp * t * t)).sin()
        })
        .collect()
}

/// White Gaussian noise of standard deviation `std`.
pub fn noise(n: usize, std: f64, seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    let d =
        Normal::new(0.0, std.max(0.0)).unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("valid"));
    (0..n).map(|_| d.sample(&mut rng)).collect()
}

/// A milling operation for the mechanistic force model (Altintas): tooth `j` at angle
/// `φ_j = Ω t + 2πj/N` (clockwise from +y, feed along +x), chip `h = f_t sin φ` (plus
/// runout), tangential force `Ft = Kt ap h + Kte ap`, radial `Fr = Kr Kt ap h + Kre ap`,
/// `Fx = −Ft cos φ − Fr sin φ`, `Fy = Ft sin φ − Fr cos φ` on the tool.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Milling {
    /// Spindle speed in rev/min.
    pub rpm: f64,
    /// Number of teeth.
    pub teeth: usize,
    /// Radial immersion ae/D in (0, 1].
    pub immersion: f64,
    /// Down (climb) milling.
    pub down: bool,
    /// Feed per tooth in m.
    pub feed_per_tooth: f64,
    /// Axial depth of cut in m.
    pub ap: f64,
    /// Tangential cutting coefficient in N/m².
    pub kt: f64,
    /// Radial/tangential ratio.
    pub kr: f64,
    /// Tangential edge coefficient in N/m.
    pub kte: f64,
    /// Radial edge coefficient in N/m.
    pub kre: f64,
    /// Radial runout of tooth 0 relative to the others, in m (changes its chip).
    pub runout: f64,
}

impl Default for Milling {
    fn default() -> Self {
        Milling {
            rpm: 6000.0,
            teeth: 3,
            immersion: 0.5,
            down: true,
            feed_per_tooth: 0.1e-3,
            ap: 2e-3,
            kt: 6e8,
            kr: 0.3,
            kte: 2e4,
            kre: 1.5e4,
            runout: 5e-6,
        }
    }
}

impl Milling {
    /// Entry and exit angles of the engagement.
    pub fn engagement(&self) -> (f64, f64) {
        let a = self.immersion.clamp(1e-6, 1.0);
        if self.down {
            ((2.0 * a - 1.0).clamp(-1.0, 1.0).acos(), PI)
        } else {
            (0.0, (1.0 - 2.0 * a).clamp(-1.0, 1.0).acos())
        }
    }

    /// Tooth passing frequency in Hz.
    pub fn tooth_hz(&self) -> f64 {
        self.rpm / 60.0 * self.teeth as f64
    }

    /// Forces (Fx, Fy) on the tool at times `t0 + i/fs`, `n` samples (nominal chip, no
    /// regeneration).
    pub fn forces(&self, fs: f64, n: usize, t0: f64) -> (Vec<f64>, Vec<f64>) {
        let (st, ex) = self.engagement();
        let omega = self.rpm / 60.0 * 2.0 * PI;
        let nt = self.teeth.max(1);
        let mut fx = vec![0.0; n];
        let mut fy = vec![0.0; n];
        for i in 0..n {
            let t = t0 + i as f64 / fs;
            for j in 0..nt {
                let phi = (omega * t + 2.0 * PI * j as f64 / nt as f64).rem_euclid(2.0 * PI);
                if phi < st || phi > ex {
                    continue;
                }
                let extra = if j == 0 {
                    self.runout
                } else {
                    -self.runout / (nt as f64 - 1.0).max(1.0)
                };
                let h = (self.feed_per_tooth + extra).max(0.0) * phi.sin();
                let ft = self.kt * self.ap * h + self.kte * self.ap;
                let fr = self.kr * self.kt * self.ap * h + self.kre * self.ap;
                fx[i] += -ft * phi.cos() - fr * phi.sin();
                fy[i] += ft * phi.sin() - fr * phi.cos();
            }
        }
        (fx, fy)
    }
}
