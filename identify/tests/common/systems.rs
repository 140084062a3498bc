//! Shared helpers of the spectra tests: exact simulation of modal systems, analytic
//! receptance, seeded noise, record builders, approx helpers.

use identify::timeseries::{ResponseKind, TimeSeries};
use nalgebra::{Complex, Matrix2, Matrix4, Vector2};
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

/// One mode `m q'' + c q' + k q = f`, contributing `q` to the response.
#[derive(Debug, Clone, Copy)]
pub struct Sdof {
    pub m: f64,
    pub c: f64,
    pub k: f64,
}

impl Sdof {
    /// From natural frequency \[Hz\], damping ratio and stiffness \[N/m\].
    pub fn new(fn_hz: f64, zeta: f64, k: f64) -> Self {
        let wn = 2.0 * PI * fn_hz;
        let m = k / (wn * wn);
        Sdof {
            m,
            c: 2.0 * zeta * m * wn,
            k,
        }
    }

    /// Receptance at the Laplace variable s.
    pub fn h(&self, s: Complex64) -> Complex64 {
        1.0 / (self.m * s * s + self.c * s + self.k)
    }
}

/// Analytic receptance of a sum of modes at `f_hz`, Laplace variable shifted by `sigma`
/// (`s = sigma + jω`).
pub fn receptance(modes: &[Sdof], f_hz: f64, sigma: f64) -> Complex64 {
    let s = Complex64::new(sigma, 2.0 * PI * f_hz);
    modes.iter().map(|m| m.h(s)).sum()
}

/// Exact first-order-hold discretisation of one mode at step `dt`.
struct Foh {
    phi: Matrix2<f64>,
    ga: Vector2<f64>,
    gb: Vector2<f64>,
    dt: f64,
}

impl Foh {
    fn new(md: &Sdof, dt: f64) -> Self {
        #[rustfmt::skip]
        let a = Matrix4::new(
            0.0, 1.0, 0.0, 0.0,
            -md.k / md.m, -md.c / md.m, 1.0 / md.m, 0.0,
            0.0, 0.0, 0.0, 1.0,
            0.0, 0.0, 0.0, 0.0,
        ) * dt;
        let e = a.exp();
        Foh {
            phi: Matrix2::new(e[(0, 0)], e[(0, 1)], e[(1, 0)], e[(1, 1)]),
            ga: Vector2::new(e[(0, 2)], e[(1, 2)]),
            gb: Vector2::new(e[(0, 3)], e[(1, 3)]),
            dt,
        }
    }

    /// FRF of the discrete system at `f_hz` (exact truth for the sampled signals).
    fn discrete_h(&self, f_hz: f64) -> Complex64 {
        let z = Complex::from_polar(1.0, 2.0 * PI * f_hz * self.dt);
        let zi = nalgebra::Matrix2::<Complex64>::identity() * z - self.phi.map(Complex::from);
        let inv = zi.try_inverse().unwrap();
        let b = self.ga.map(Complex::from) + self.gb.map(Complex::from) * ((z - 1.0) / self.dt);
        (inv * b)[0]
    }
}

/// Displacement and acceleration of a sum of modes under force `f` sampled at `dt`
/// (force linear between samples, system at rest at the start).
pub fn simulate(modes: &[Sdof], f: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
    let n = f.len();
    let mut d = vec![0.0; n];
    let mut a = vec![0.0; n];
    for md in modes {
        let foh = Foh::new(md, dt);
        let mut x = Vector2::new(0.0, 0.0);
        for i in 0..n {
            d[i] += x[0];
            a[i] += (f[i] - md.c * x[1] - md.k * x[0]) / md.m;
            if i + 1 < n {
                let w = (f[i + 1] - f[i]) / dt;
                x = foh.phi * x + foh.ga * f[i] + foh.gb * w;
            }
        }
    }
    (d, a)
}

/// Exact receptance of the simulated (sampled) system at `f_hz`.
pub fn discrete_receptance(modes: &[Sdof], f_hz: f64, dt: f64) -> Complex64 {
    modes.iter().map(|m| Foh::new(m, dt).discrete_h(f_hz)).sum()
}

/// Seeded Gaussian noise (Box–Muller).
pub struct Noise(StdRng);

impl Noise {
    pub fn new(seed: u64) -> Self {
        Noise(StdRng::seed_from_u64(seed))
    }
    pub fn gauss(&mut self) -> f64 {
        let u1: f64 = self.0.gen_range(1e-12..1.0);
        let u2: f64 = self.0.gen_range(0.0..1.0);
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0.gen_range(lo..hi)
    }
    pub fn vec(&mut self, n: usize, sd: f64) -> Vec<f64> {
        (0..n).map(|_| sd * self.gauss()).collect()
    }
}

pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Adds noise of `rel` × RMS of `x`.
pub fn add_noise(x: &mut [f64], rel: f64, noise: &mut Noise) {
    let sd = rel * rms(x);
    for v in x.iter_mut() {
        *v += sd * noise.gauss();
    }
}

/// A record with force and response along x.
pub fn record(dt: f64, f: Vec<f64>, y: Vec<f64>, kind: ResponseKind) -> TimeSeries {
    let mut ts = TimeSeries {
        source: "simulated".into(),
        dt,
        response_kind: Some(kind),
        ..TimeSeries::default()
    };
    ts.force[0] = Some(f);
    ts.response[0] = Some(y);
    ts
}

/// |a - b| <= abs + rel * |b|.
pub fn approx_eq(a: Complex64, b: Complex64, abs: f64, rel: f64) -> bool {
    (a - b).norm() <= abs + rel * b.norm()
}

/// Half-sine pulses of `width_s` at `times_s` with `amps` added to a force of `n` samples.
pub fn pulses(n: usize, dt: f64, times_s: &[f64], amps: &[f64], width_s: f64) -> Vec<f64> {
    let mut f = vec![0.0; n];
    for (&t0, &a) in times_s.iter().zip(amps) {
        let i0 = (t0 / dt).ceil() as usize;
        let mut i = i0;
        while i < n {
            let tau = i as f64 * dt - t0;
            if tau > width_s {
                break;
            }
            f[i] += a * (PI * tau / width_s).sin();
            i += 1;
        }
    }
    f
}

pub use super::shared;
