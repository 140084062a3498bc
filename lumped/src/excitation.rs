//! Forces at the simulation rate: impact hammer, band-limited random (shaker), linear
//! and logarithmic sine sweeps, stepped sine, and a mechanistic milling force.

use rand::rngs::StdRng;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// A force history at the simulation rate: `[fx, fy, fz]` per sample (N).
pub type Force = Vec<[f64; 3]>;

/// An impact hammer: the pulse is a half-sine whose duration follows from the hammer's
/// mass and the tip's contact stiffness, `T = π √(m / k_tip)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Hammer {
    /// Hammer head mass (kg).
    pub mass: f64,
    /// Contact stiffness of tip and surface (N/m).
    pub tip_stiffness: f64,
}

/// One hit of a hammer.
#[derive(Clone, Debug, PartialEq)]
pub struct Hit {
    /// Start time (s).
    pub t: f64,
    /// Peak force (N).
    pub peak: f64,
}

impl Hammer {
    /// A 0.3 kg hammer with a hard plastic tip (pulse ≈ 0.35 ms, flat to ≈ 3 kHz).
    pub fn plastic() -> Self {
        Hammer {
            mass: 0.3,
            tip_stiffness: 2.4e7,
        }
    }

    /// A 0.3 kg hammer with a steel tip (pulse ≈ 0.12 ms).
    pub fn steel() -> Self {
        Hammer {
            mass: 0.3,
            tip_stiffness: 2.0e8,
        }
    }

    /// Pulse duration `π √(m/k)` (s).
    pub fn pulse_s(&self) -> f64 {
        PI * (self.mass / self.tip_stiffness).sqrt()
    }

    /// The hits as a force along the unit vector `dir`, `n` samples at rate `fs`.
    pub fn force(&self, hits: &[Hit], dir: [f64; 3], fs: f64, n: usize) -> Force {
        let tc = self.pulse_s();
        let mut f = vec![[0.0; 3]; n];
        for hit in hits {
            let i0 = (hit.t * fs).floor().max(0.0) as usize;
            let i1 = (((hit.t + tc) * fs).ceil() as usize).min(n);
            for (i, fi) in f.iter_mut().enumerate().take(i1).skip(i0) {
                let tau = i as f64 / fs - hit.t;
                if (0.0..=tc).contains(&tau) {
                    let v = hit.peak * (PI * tau / tc).sin();
                    for d in 0..3 {
                        fi[d] += v * dir[d];
                    }
                }
            }
        }
        f
    }

    /// `count` hits in `duration` seconds: random spacing (±20 % around even), peak
    /// force in `peak` (uniform), and with probability `double_p` a double hit (a second,
    /// 10–30 % pulse 1–3 ms after one of them).
    pub fn random_hits(
        &self,
        count: usize,
        duration: f64,
        peak: (f64, f64),
        double_p: f64,
        rng: &mut StdRng,
    ) -> Vec<Hit> {
        let slot = duration / count.max(1) as f64;
        let mut hits = Vec::new();
        for k in 0..count {
            let t = slot * (k as f64 + 0.1 + rng.gen_range(0.0..0.2));
            let p = rng.gen_range(peak.0..=peak.1);
            hits.push(Hit { t, peak: p });
            if rng.gen_bool(double_p.clamp(0.0, 1.0)) {
                hits.push(Hit {
                    t: t + rng.gen_range(1e-3..3e-3),
                    peak: p * rng.gen_range(0.1..0.3),
                });
            }
        }
        hits
    }
}

/// Gaussian random force with a flat spectrum between `f_lo` and `f_hi` (Hz) (an
/// inverse FFT of random complex lines), standard deviation `rms` (N), along `dir`.
pub fn random_force(
    fs: f64,
    n: usize,
    band: (f64, f64),
    rms: f64,
    dir: [f64; 3],
    rng: &mut StdRng,
) -> Force {
    let mut spec = vec![Complex64::new(0.0, 0.0); n];
    let df = fs / n as f64;
    for (k, s) in spec.iter_mut().enumerate().take(n / 2).skip(1) {
        let f = k as f64 * df;
        if f >= band.0 && f <= band.1 {
            let a: f64 = StandardNormal.sample(rng);
            let b: f64 = StandardNormal.sample(rng);
            *s = Complex64::new(a, b);
        }
    }
    for k in 1..n / 2 {
        spec[n - k] = spec[k].conj();
    }
    let mut planner = FftPlanner::new();
    planner.plan_fft_inverse(n).process(&mut spec);
    let x: Vec<f64> = spec.iter().map(|c| c.re).collect();
    let sd = (x.iter().map(|v| v * v).sum::<f64>() / n.max(1) as f64).sqrt();
    x.iter()
        .map(|v| {
            let s = v * rms / sd.max(f64::MIN_POSITIVE);
            [s * dir[0], s * dir[1], s * dir[2]]
        })
        .collect()
}

/// Kind of sine sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sweep {
    /// Frequency rising linearly in time.
    Linear,
    /// Frequency rising exponentially (equal time per octave).
    Logarithmic,
}

/// A sine sweep from `f0` to `f1` (Hz) in `duration` s of amplitude `amp` (N) along
/// `dir`, 10 ms cosine fades at both ends, then zeros up to `n` samples.
#[allow(clippy::too_many_arguments)]
pub fn sweep(
    kind: Sweep,
    fs: f64,
    n: usize,
    f0: f64,
    f1: f64,
    duration: f64,
    amp: f64,
    dir: [f64; 3],
) -> Force {
    let fade = 0.01;
    (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            if t > duration {
                return [0.0; 3];
            }
            let phase = match kind {
                Sweep::Linear => 2.0 * PI * (f0 * t + (f1 - f0) * t * t / (2.0 * duration)),
                Sweep::Logarithmic => {
                    let r = (f1 / f0).ln();
                    2.0 * PI * f0 * duration / r * ((t * r / duration).exp() - 1.0)
                }
            };
            let w = if t < fade {
                0.5 - 0.5 * (PI * t / fade).cos()
            } else if t > duration - fade {
                0.5 - 0.5 * (PI * (duration - t) / fade).cos()
            } else {
                1.0
            };
            let v = amp * w * phase.sin();
            [v * dir[0], v * dir[1], v * dir[2]]
        })
        .collect()
}

/// A stepped sine: each frequency dwells `dwell` s (5 ms fades in and out), amplitude
/// `amp` along `dir`. Returns the force and the start sample of each step.
pub fn stepped_sine(
    fs: f64,
    freqs: &[f64],
    dwell: f64,
    amp: f64,
    dir: [f64; 3],
) -> (Force, Vec<usize>) {
    let per = (dwell * fs).round() as usize;
    let fade = 0.005;
    let mut f = Vec::with_capacity(per * freqs.len());
    let mut starts = Vec::new();
    for &fr in freqs {
        starts.push(f.len());
        for i in 0..per {
            let t = i as f64 / fs;
            let w = if t < fade {
                0.5 - 0.5 * (PI * t / fade).cos()
            } else if t > dwell - fade {
                0.5 - 0.5 * (PI * (dwell - t).max(0.0) / fade).cos()
            } else {
                1.0
            };
            let v = amp * w * (2.0 * PI * fr * t).sin();
            f.push([v * dir[0], v * dir[1], v * dir[2]]);
        }
    }
    (f, starts)
}

/// A mechanistic milling force (Altintas): chip thickness `h = f_t sin φ` plus runout,
/// tangential/radial/axial coefficients with edge terms, helix by axial slices, per-tooth
/// variation. Feed along +x (`feed_y` = false) or +y; the tool turns clockwise seen from
/// the spindle; `φ` is measured from the axis normal to the feed.
#[derive(Clone, Debug, PartialEq)]
pub struct Milling {
    /// Number of teeth.
    pub teeth: usize,
    /// Tool diameter (m).
    pub diameter: f64,
    /// Helix angle (deg).
    pub helix_deg: f64,
    /// Spindle speed (rpm).
    pub rpm: f64,
    /// Feed per tooth (m).
    pub feed_per_tooth: f64,
    /// Axial depth of cut (m).
    pub depth: f64,
    /// Radial immersion `a_e / D` (0…1].
    pub immersion: f64,
    /// Down (climb) milling if true, up milling otherwise.
    pub down: bool,
    /// Feed along y instead of x.
    pub feed_y: bool,
    /// Cutting coefficients `K_tc, K_rc, K_ac` (N/m²).
    pub kc: [f64; 3],
    /// Edge coefficients `K_te, K_re, K_ae` (N/m).
    pub ke: [f64; 3],
    /// Radial runout of the tool axis (m).
    pub runout: f64,
    /// Angle of the runout relative to tooth 0 (rad).
    pub runout_angle: f64,
    /// Per-tooth factor on the coefficients (tooth-to-tooth variation), one per tooth.
    pub tooth_factor: Vec<f64>,
    /// Axial slices for the helix.
    pub slices: usize,
}

impl Milling {
    /// A 3-tooth 16 mm end mill in steel, down milling 25 % immersion, random runout
    /// (2–10 µm) and tooth factors (±5 %) from `rng`.
    pub fn random(rpm: f64, depth: f64, rng: &mut StdRng) -> Self {
        let teeth = 3;
        Milling {
            teeth,
            diameter: 0.016,
            helix_deg: 30.0,
            rpm,
            feed_per_tooth: 0.08e-3,
            depth,
            immersion: 0.25,
            down: true,
            feed_y: false,
            kc: [1.8e9, 0.7e9, 0.35e9],
            ke: [2.0e4, 2.5e4, 0.8e4],
            runout: rng.gen_range(2e-6..10e-6),
            runout_angle: rng.gen_range(0.0..2.0 * PI),
            tooth_factor: (0..teeth).map(|_| rng.gen_range(0.95..1.05)).collect(),
            slices: 12,
        }
    }

    /// Tooth passing frequency (Hz).
    pub fn tooth_hz(&self) -> f64 {
        self.rpm / 60.0 * self.teeth as f64
    }

    /// Feed speed (m/s).
    pub fn feed_speed(&self) -> f64 {
        self.feed_per_tooth * self.tooth_hz()
    }

    /// Entry and exit angles (rad).
    pub fn engagement(&self) -> (f64, f64) {
        let a = (1.0 - 2.0 * self.immersion.clamp(1e-6, 1.0)).acos();
        if self.down {
            (PI - a, PI)
        } else {
            (0.0, a)
        }
    }

    /// Force on the tool (N) at `n` samples of rate `fs` from time `t0`.
    pub fn force(&self, fs: f64, n: usize, t0: f64) -> Force {
        let (st, ex) = self.engagement();
        let r = self.diameter / 2.0;
        let pitch = 2.0 * PI / self.teeth as f64;
        let dz = self.depth / self.slices as f64;
        let lag_per_m = self.helix_deg.to_radians().tan() / r;
        let omega = 2.0 * PI * self.rpm / 60.0;
        // runout: radius of tooth j and the chip it leaves to the next one
        let radius: Vec<f64> = (0..self.teeth)
            .map(|j| self.runout * (self.runout_angle - j as f64 * pitch).cos())
            .collect();
        (0..n)
            .map(|i| {
                let t = t0 + i as f64 / fs;
                let mut fx = 0.0;
                let mut fy = 0.0;
                let mut fz = 0.0;
                for j in 0..self.teeth {
                    let prev = (j + self.teeth - 1) % self.teeth;
                    let dr = radius[j] - radius[prev];
                    let g = self.tooth_factor.get(j).copied().unwrap_or(1.0);
                    for s in 0..self.slices {
                        let z = (s as f64 + 0.5) * dz;
                        let phi =
                            (omega * t + j as f64 * pitch - lag_per_m * z).rem_euclid(2.0 * PI);
                        if phi < st || phi > ex {
                            continue;
                        }
                        let h = (self.feed_per_tooth * phi.sin() + dr).max(0.0);
                        if h <= 0.0 {
                            continue;
                        }
                        let ft = g * (self.kc[0] * h + self.ke[0]) * dz;
                        let fr = g * (self.kc[1] * h + self.ke[1]) * dz;
                        let fa = g * (self.kc[2] * h + self.ke[2]) * dz;
                        let (s_, c_) = phi.sin_cos();
                        fx += -ft * c_ - fr * s_;
                        fy += ft * s_ - fr * c_;
                        fz += fa;
                    }
                }
                if self.feed_y {
                    // the cutting frame turned +90° about z: its x (feed) is world y
                    [-fy, fx, fz]
                } else {
                    [fx, fy, fz]
                }
            })
            .collect()
    }
}
