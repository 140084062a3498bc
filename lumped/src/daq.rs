//! Data acquisition: anti-alias low-pass and decimation from the simulation rate to the
//! output rate, then sensor noise (white, 1/f) and ADC quantisation per channel.

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Output rate, oversampling and anti-alias filter.
#[derive(Clone, Debug)]
pub struct Daq {
    /// Output sample rate (Hz).
    pub fs: f64,
    /// Simulation steps per output sample.
    pub oversample: usize,
    /// Filter half-length in output samples (taps = 2·half·oversample + 1).
    pub half_len: usize,
    /// −6 dB cut-off as a fraction of the output rate.
    pub cutoff: f64,
}

impl Default for Daq {
    /// 10240 Hz, 8× oversampled, 16-sample half length, cut-off 0.45·fs (flat to ±0.1 %
    /// up to about 0.36·fs, −70 dB above 0.55·fs).
    fn default() -> Self {
        Daq {
            fs: 10240.0,
            oversample: 8,
            half_len: 16,
            cutoff: 0.45,
        }
    }
}

impl Daq {
    /// Simulation rate (Hz).
    pub fn fs_sim(&self) -> f64 {
        self.fs * self.oversample as f64
    }

    /// Simulation step (s).
    pub fn h(&self) -> f64 {
        1.0 / self.fs_sim()
    }

    /// The linear-phase anti-alias FIR (Blackman-windowed sinc, unit DC gain), applied
    /// centred, i.e. with zero phase.
    pub fn fir(&self) -> Vec<f64> {
        let half = self.half_len * self.oversample;
        let fc = self.cutoff / self.oversample as f64; // cycles per simulation sample
        let n = 2 * half + 1;
        let mut taps: Vec<f64> = (0..n)
            .map(|i| {
                let k = i as f64 - half as f64;
                let sinc = if k == 0.0 {
                    2.0 * fc
                } else {
                    (2.0 * std::f64::consts::PI * fc * k).sin() / (std::f64::consts::PI * k)
                };
                let w = 0.42 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos()
                    + 0.08 * (4.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
                sinc * w
            })
            .collect();
        let s: f64 = taps.iter().sum();
        for t in &mut taps {
            *t /= s;
        }
        taps
    }

    /// Filter and keep every `oversample`-th sample: output `i` is simulation sample
    /// `i·oversample` (no delay); zeros are assumed outside the record.
    pub fn decimate(&self, x: &[f64]) -> Vec<f64> {
        let taps = self.fir();
        let half = (taps.len() / 2) as isize;
        let n = x.len();
        (0..n / self.oversample)
            .map(|i| {
                let c = (i * self.oversample) as isize;
                let mut acc = 0.0;
                for (j, t) in taps.iter().enumerate() {
                    let k = c + j as isize - half;
                    if k >= 0 && (k as usize) < n {
                        acc += t * x[k as usize];
                    }
                }
                acc
            })
            .collect()
    }
}

/// Sensor noise and ADC of one channel, relative to the channel's input range.
#[derive(Clone, Debug, PartialEq)]
pub struct Noise {
    /// White noise standard deviation / range.
    pub white: f64,
    /// 1/f (pink) noise standard deviation / range.
    pub pink: f64,
    /// ADC resolution (bits) over ±range (0 = no quantisation).
    pub bits: u32,
}

impl Noise {
    /// A good 24-bit system: 1e-4 white, 5e-5 pink of the range.
    pub fn good() -> Self {
        Noise {
            white: 1e-4,
            pink: 5e-5,
            bits: 24,
        }
    }

    /// No noise, no quantisation.
    pub fn none() -> Self {
        Noise {
            white: 0.0,
            pink: 0.0,
            bits: 0,
        }
    }
}

/// The input range a tester would pick: the smallest of 1, 2, 5 × 10ᵏ at or above
/// 1.25 × the signal's peak.
pub fn auto_range(x: &[f64]) -> f64 {
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs())) * 1.25;
    if peak <= 0.0 || !peak.is_finite() {
        return 1.0;
    }
    let e = peak.log10().floor();
    let base = 10f64.powf(e);
    for m in [1.0, 2.0, 5.0, 10.0] {
        if m * base >= peak {
            return m * base;
        }
    }
    10.0 * base
}

/// Unit-variance 1/f noise: Paul Kellet's refined filter of white noise (−10 dB/decade
/// within ±0.05 dB over three decades below a tenth of the sample rate), normalised.
pub fn pink_noise(n: usize, rng: &mut StdRng) -> Vec<f64> {
    let mut b = [0.0f64; 7];
    let mut out: Vec<f64> = (0..n + 2000)
        .map(|_| {
            let w: f64 = StandardNormal.sample(rng);
            b[0] = 0.99886 * b[0] + w * 0.0555179;
            b[1] = 0.99332 * b[1] + w * 0.0750759;
            b[2] = 0.96900 * b[2] + w * 0.1538520;
            b[3] = 0.86650 * b[3] + w * 0.3104856;
            b[4] = 0.55000 * b[4] + w * 0.5329522;
            b[5] = -0.7616 * b[5] - w * 0.0168980;
            let p = b.iter().sum::<f64>() + w * 0.5362;
            b[6] = w * 0.115926;
            p
        })
        .skip(2000)
        .collect();
    let mean = out.iter().sum::<f64>() / n.max(1) as f64;
    let sd = (out.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n.max(1) as f64).sqrt();
    for v in &mut out {
        *v = (*v - mean) / sd.max(f64::MIN_POSITIVE);
    }
    out
}

/// Add noise and quantise one channel in place with the input range `range` (e.g.
/// [`auto_range`] of the clean signals of that sensor type).
pub fn corrupt(x: &mut [f64], range: f64, noise: &Noise, seed: u64) {
    let mut rng = StdRng::seed_from_u64(seed);
    if noise.white > 0.0 || noise.pink > 0.0 {
        let pink = pink_noise(x.len(), &mut rng);
        for (v, p) in x.iter_mut().zip(pink) {
            let w: f64 = StandardNormal.sample(&mut rng);
            *v += range * (noise.white * w + noise.pink * p);
        }
    }
    if noise.bits > 0 {
        let lsb = 2.0 * range / 2f64.powi(noise.bits as i32);
        for v in x.iter_mut() {
            *v = ((*v / lsb).round() * lsb).clamp(-range, range);
        }
    }
}
