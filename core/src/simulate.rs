//! Time simulation: the modal state-space core shared by `mtwin simulate` and the FMU.
//!
//! Each mode `k` and force axis `j` owns a state `(q, q̇)` obeying
//! `q̈ + 2ζω q̇ + ω² q = F_j`; a response is `Σ_k (b0 q + b1 q̇) + d F`. The parameters
//! (ω, ζ, b0, b1, d) may change from one step to the next (the axes move and the twin is
//! re-interpolated): the state keeps its meaning, so the response does not jump.
//!
//! Every step is discretised exactly for the step length actually taken, with the force
//! either held constant over the step (zero-order hold, the FMI 2.0 view of an input) or
//! varying linearly between samples (first-order hold). A measured record is the sampled
//! view of an anti-aliased, band-limited signal: [`Hold::BandLimited`] simulates the
//! signal its samples stand for (windowed-sinc upsampling, then first-order hold on the
//! fine grid), where a hold on the samples themselves mis-states the force near the
//! Nyquist frequency (first-order hold: `sinc²(f/fs)`, 30 % short at a third of the
//! sample rate, plus images).

use crate::axis::Axis;
use crate::model::{ModalModel, Mode, ModeNum};
use serde::{Deserialize, Serialize};

/// How the force behaves between two samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Hold {
    /// Constant over the step (what an FMI 2.0 master gives a co-simulation slave).
    #[default]
    Zoh,
    /// Linear between the samples at both ends of the step.
    Foh,
    /// The band-limited signal the samples stand for (an anti-aliased measurement):
    /// upsampled [`BAND_LIMITED_FACTOR`]× by windowed-sinc interpolation, then
    /// first-order hold on the fine grid (0.2 % short at 0.4 of the sample rate). Only
    /// for whole records ([`simulate`], [`crate::interpolate::simulate_twin`],
    /// [`crate::extended::simulate_extended`]); a step-by-step [`Simulator`], which
    /// cannot see the samples ahead, treats it as [`Hold::Foh`].
    #[serde(rename = "band_limited")]
    BandLimited,
}

/// Oversampling factor of [`Hold::BandLimited`].
pub const BAND_LIMITED_FACTOR: usize = 16;

/// Half-length, in input samples, of the interpolation kernel of [`upsample`].
const UPSAMPLE_HALF: usize = 24;

/// Blackman-windowed sinc at `t` input samples from the centre (half-length
/// [`UPSAMPLE_HALF`]).
fn interpolation_kernel(t: f64) -> f64 {
    let k = UPSAMPLE_HALF as f64;
    if t.abs() >= k {
        return 0.0;
    }
    let sinc = if t == 0.0 {
        1.0
    } else {
        (std::f64::consts::PI * t).sin() / (std::f64::consts::PI * t)
    };
    let x = std::f64::consts::PI * (t / k + 1.0); // 0..2π over the kernel
    sinc * (0.42 - 0.5 * x.cos() + 0.08 * (2.0 * x).cos())
}

/// `x` upsampled `factor`× by band-limited (Blackman-windowed sinc) interpolation, zero
/// before the first and after the last sample: `(n − 1)·factor + 1` samples, sample
/// `i·factor` of the result is `x[i]`.
pub fn upsample(x: &[[f64; 3]], factor: usize) -> Vec<[f64; 3]> {
    let n = x.len();
    let l = factor.max(1);
    if n < 2 || l == 1 {
        return x.to_vec();
    }
    let h = UPSAMPLE_HALF as isize;
    // taps per phase r: weight of x[i + j] for the fine sample i·l + r, j in -h+1..=h
    let taps: Vec<Vec<f64>> = (0..l)
        .map(|r| {
            (-h + 1..=h)
                .map(|j| interpolation_kernel(j as f64 - r as f64 / l as f64))
                .collect()
        })
        .collect();
    // the same taps by offset j, phases 1..l side by side: every phase's sum then runs
    // over j in the same order, all phases at once
    let width = 2 * UPSAMPLE_HALF;
    let by_offset: Vec<f64> = (0..width)
        .flat_map(|jj| taps.iter().skip(1).map(move |t| t[jj]))
        .collect();
    // a channel that is 0 throughout upsamples to +0 (the sums start at +0)
    let active: Vec<usize> = (0..3).filter(|&c| x.iter().any(|v| v[c] != 0.0)).collect();
    let columns: Vec<Vec<f64>> = active
        .iter()
        .map(|&c| x.iter().map(|v| v[c]).collect())
        .collect();
    let mut acc = vec![0.0; l - 1];
    let mut out = Vec::with_capacity((n - 1) * l + 1);
    for i in 0..n {
        out.push(x[i]);
        if i + 1 == n {
            break;
        }
        if i + 1 < UPSAMPLE_HALF || i + UPSAMPLE_HALF >= n {
            // near the ends: the taps outside the record are skipped
            for tr in taps.iter().skip(1) {
                let mut v = [0.0; 3];
                for (jj, w) in tr.iter().enumerate() {
                    let k = i as isize + jj as isize - h + 1;
                    if k < 0 || k >= n as isize {
                        continue;
                    }
                    let xk = &x[k as usize];
                    for c in 0..3 {
                        v[c] += w * xk[c];
                    }
                }
                out.push(v);
            }
            continue;
        }
        let start = out.len();
        out.resize(start + l - 1, [0.0; 3]);
        for (&c, col) in active.iter().zip(&columns) {
            acc.fill(0.0);
            let win = &col[i + 1 - UPSAMPLE_HALF..=i + UPSAMPLE_HALF];
            for (w, &xk) in by_offset.chunks_exact(l - 1).zip(win) {
                for (a, t) in acc.iter_mut().zip(w) {
                    *a += t * xk;
                }
            }
            for (o, a) in out[start..].iter_mut().zip(&acc) {
                o[c] = *a;
            }
        }
    }
    out
}

/// Runs a whole-record simulation under [`Hold::BandLimited`]: `run(fine_forces,
/// fine_dt, coarse_index_of_fine_sample, every)` simulates the upsampled record step by
/// step (a [`Simulator`] with [`Hold::BandLimited`] steps as [`Hold::Foh`]) and returns
/// its response at every `every`-th fine sample: the original samples.
pub fn run_band_limited(
    forces: &[[f64; 3]],
    dt: f64,
    run: impl FnOnce(&[[f64; 3]], f64, &dyn Fn(usize) -> usize, usize) -> Vec<[f64; 3]>,
) -> Vec<[f64; 3]> {
    let l = BAND_LIMITED_FACTOR;
    let fine = upsample(forces, l);
    run(&fine, dt / l as f64, &|m| m / l, l)
}

/// [`run_band_limited`] of one fixed model from rest (what [`Simulator`] gives on the
/// upsampled record, the response at the original samples), stepped at the record's own
/// rate: the [`BAND_LIMITED_FACTOR`] first-order-hold steps between two samples and the
/// interpolation kernel's taps (the record zero-extended, as [`upsample`] treats its ends)
/// are folded into one transition `Φ^L` per mode, driven by the sample that has left the
/// kernel's window, and one FIR of `2·24 − 1` taps per channel (the modes' transients
/// while a sample is in the window, summed over the modes). The same response up to
/// rounding (the sums run in another order), for about 6 multiply-adds per mode and
/// force axis, 2 per mode and channel and 47 per channel, per sample, instead of 16
/// steps and the upsampling.
/// Displacement per axis x, y, z at every sample.
pub fn band_limited_lti(model: &ModalModel, forces: &[[f64; 3]], dt: f64) -> Vec<[f64; 3]> {
    let n = forces.len();
    let l = BAND_LIMITED_FACTOR;
    if n < 2 {
        // no interpolation (upsample returns the samples): the step-by-step path
        return run_band_limited(forces, dt, |f, h, _, every| {
            let mut sim = Simulator::new(model.modes.len(), Hold::BandLimited);
            let mut out = vec![sim.output(model, &f[0])];
            for i in 1..f.len() {
                sim.step(model, &f[i - 1], &f[i], h);
                if i % every == 0 {
                    out.push(sim.output(model, &f[i]));
                }
            }
            out
        });
    }
    let h = dt / l as f64;
    let half = UPSAMPLE_HALF;
    let width = 2 * half;
    let nm = model.modes.len();
    let w2 = 2 * nm;
    // fine sample i·L + r, 0 < r < L, = Σ_jj taps[r][jj] x[i + jj + 1 - half]
    let taps: Vec<Vec<f64>> = (0..l)
        .map(|r| {
            (0..width)
                .map(|jj| {
                    let j = jj as f64 + 1.0 - half as f64;
                    interpolation_kernel(j - r as f64 / l as f64)
                })
                .collect()
        })
        .collect();
    // per mode: Φ^L, and the FIR v[jj][2k + c] taking the samples to the state change
    let mut fir = vec![0.0; width * w2];
    let mut trans = Vec::with_capacity(nm);
    for (k, mode) in model.modes.iter().enumerate() {
        let st = SectionStep::new(mode, h, Hold::BandLimited);
        let mut pows: Vec<M2> = vec![[[1.0, 0.0], [0.0, 1.0]]];
        for p in 1..=l {
            let next = mat_mul(&st.phi, &pows[p - 1]);
            pows.push(next);
        }
        let mv = |a: &M2, g: &[f64; 2]| {
            [
                a[0][0] * g[0] + a[0][1] * g[1],
                a[1][0] * g[0] + a[1][1] * g[1],
            ]
        };
        // weight of fine sample i·L + r in the state after the L steps
        let weight = |r: usize| {
            let mut c = [0.0; 2];
            if r < l {
                let v = mv(&pows[l - 1 - r], &st.g0);
                c = [c[0] + v[0], c[1] + v[1]];
            }
            if r >= 1 {
                let v = mv(&pows[l - r], &st.g1);
                c = [c[0] + v[0], c[1] + v[1]];
            }
            c
        };
        for (r, tr) in taps.iter().enumerate().skip(1) {
            let c = weight(r);
            for (jj, t) in tr.iter().enumerate() {
                fir[jj * w2 + 2 * k] += c[0] * t;
                fir[jj * w2 + 2 * k + 1] += c[1] * t;
            }
        }
        // fine samples i·L and (i + 1)·L are the samples x[i] and x[i + 1]
        for (r, jj) in [(0, half - 1), (l, half)] {
            let c = weight(r);
            fir[jj * w2 + 2 * k] += c[0];
            fir[jj * w2 + 2 * k + 1] += c[1];
        }
        trans.push(pows[l]);
    }
    // A unit sample x[m] reaches mode k's state from n = m − (half − 1) on (the kernel
    // looks ahead): through the FIR while it is in the window, n ≤ m + half, then freely,
    // s[n] = Φ^{L·(n − m − half)} s[m + half]. So the state is a recursion driven by
    // x[n − half] through one input vector (the state at lag `half` of a unit sample),
    // and the transient at lags −(half − 1)..=(half − 1) differs from that recursion only
    // by a finite response, which the outputs take through one FIR per channel summed
    // over the modes: ~2·half multiply-adds per channel and sample instead of 4·half per
    // mode.
    let lags = width - 1; // −(half − 1)..=(half − 1)
    let mut drive = Vec::with_capacity(nm); // s at lag `half` of a unit sample
    let mut transient = vec![[0.0; 2]; nm * lags]; // s at lag idx − (half − 1)
    for (k, p) in trans.iter().enumerate() {
        let mut s = [0.0; 2];
        for idx in 0..width {
            let jj = width - 1 - idx;
            s = [
                p[0][0] * s[0] + p[0][1] * s[1] + fir[jj * w2 + 2 * k],
                p[1][0] * s[0] + p[1][1] * s[1] + fir[jj * w2 + 2 * k + 1],
            ];
            if idx < lags {
                transient[k * lags + idx] = s;
            }
        }
        drive.push(s);
    }
    let mut out = vec![[0.0; 3]; n];
    // the force axes that carry force; the others leave their states at rest
    for j in (0..3).filter(|&j| forces.iter().any(|f| f[j] != 0.0)) {
        let chans: Vec<&crate::model::ChannelModel> = (model.channels.iter())
            .filter(|c| c.channel.input.index() == j)
            .collect();
        if chans.is_empty() {
            continue;
        }
        // x zero-extended by the kernel's half-width on both sides: x[m] = xp[m + half - 1]
        let mut xp = vec![0.0; n + width];
        for (d, f) in xp[half - 1..].iter_mut().zip(forces) {
            *d = f[j];
        }
        // per channel, the transients (and the feedthrough at lag 0) as one FIR over
        // x[n − (half − 1) + jj] = xp[n + jj]: tap jj is lag (half − 1) − jj
        let direct: Vec<Vec<f64>> = (chans.iter())
            .map(|ch| {
                let mut taps: Vec<f64> = (0..lags)
                    .map(|jj| {
                        let idx = lags - 1 - jj;
                        (ch.num.iter().enumerate())
                            .map(|(k, b)| {
                                let t = transient[k * lags + idx];
                                b.b0 * t[0] + b.b1 * t[1]
                            })
                            .sum()
                    })
                    .collect();
                taps[half - 1] += ch.d;
                let mut z = vec![0.0; n];
                fir_block(&taps, &xp[..n + lags - 1], &mut z);
                z
            })
            .collect();
        // the record starts at rest: take back the states that the kernel's look-ahead
        // built before sample 0 (the free response of the state at 0, s[0] = Σ_m T[−m]·x[m])
        let mut state: Vec<[f64; 2]> = (0..nm)
            .map(|k| {
                let mut s0 = [0.0; 2];
                for (m, x) in xp[half - 1..].iter().take(half.min(n)).enumerate() {
                    let t = transient[k * lags + half - 1 - m];
                    s0 = [s0[0] - t[0] * x, s0[1] - t[1] * x];
                }
                s0
            })
            .collect();
        for i in 0..n {
            for (ch, z) in chans.iter().zip(&direct) {
                let mut acc = z[i];
                for (num, s) in ch.num.iter().zip(&state) {
                    acc += num.b0 * s[0] + num.b1 * s[1];
                }
                out[i][ch.channel.output.index()] += acc;
            }
            // x[i − half + 1], the sample entering the recursion at step i → i + 1
            let x = xp[i];
            for ((s, p), g) in state.iter_mut().zip(&trans).zip(&drive) {
                *s = [
                    p[0][0] * s[0] + p[0][1] * s[1] + g[0] * x,
                    p[1][0] * s[0] + p[1][1] * s[1] + g[1] * x,
                ];
            }
        }
    }
    out
}

/// `z[b] = Σ_jj f[jj] · x[b + jj]` for every `b` of `z` (`x` holds `z.len() + f.len() - 1`
/// samples), sixteen outputs at a time in registers (eight independent sums of two).
fn fir_block(f: &[f64], x: &[f64], z: &mut [f64]) {
    const R: usize = 16;
    let width = f.len();
    let mut chunks = z.chunks_exact_mut(R);
    let mut b = 0;
    for zc in &mut chunks {
        let xw = &x[b..b + width + R - 1];
        let mut acc = [0.0f64; R];
        for (xs, &c) in xw.windows(R).zip(f) {
            for t in 0..R {
                acc[t] += c * xs[t];
            }
        }
        zc.copy_from_slice(&acc);
        b += R;
    }
    for (t, zt) in chunks.into_remainder().iter_mut().enumerate() {
        let xs = &x[b + t..b + t + width];
        *zt = xs.iter().zip(f).map(|(x, c)| c * x).sum();
    }
}

/// Exact discretisation of one section `[q, q̇]` for a step `h`:
/// `x⁺ = Φ x + g0 u₀ + g1 u₁` (for ZOH `g1 = 0`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectionStep {
    /// State transition e^{Ah}.
    pub phi: [[f64; 2]; 2],
    /// Input vector of the force at the start of the step.
    pub g0: [f64; 2],
    /// Input vector of the force at the end of the step (FOH only).
    pub g1: [f64; 2],
}

type M2 = [[f64; 2]; 2];

fn mat_mul(a: &M2, b: &M2) -> M2 {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}

impl SectionStep {
    /// Discretises `mode` over a step `h` with the given hold.
    pub fn new(mode: &Mode, h: f64, hold: Hold) -> Self {
        let (w, z) = (mode.wn, mode.zeta);
        let c = 2.0 * z * w;
        let a: M2 = [[0.0, 1.0], [-w * w, -c]];
        // Φ = e^{Ah} from the 2×2 closed form: μ = tr/2, Δ² = μ² - det.
        let mu = -c / 2.0;
        let disc = mu * mu - w * w;
        let (f0, f1) = if disc < 0.0 {
            let q = (-disc).sqrt();
            let (sn, cs) = (q * h).sin_cos();
            let s = if q * h < 1e-8 { h } else { sn / q };
            (cs, s)
        } else {
            let q = disc.sqrt();
            let s = if q * h < 1e-8 { h } else { (q * h).sinh() / q };
            ((q * h).cosh(), s)
        };
        let e = (mu * h).exp();
        // e^{Ah} = e^{μh} [ f0 I + f1 (A - μI) ]
        let phi = [
            [e * (f0 + f1 * (a[0][0] - mu)), e * f1 * a[0][1]],
            [e * f1 * a[1][0], e * (f0 + f1 * (a[1][1] - mu))],
        ];
        // Γ = ∫₀ʰ e^{Aσ} dσ B and M1 = ∫₀ʰ e^{Aσ} (h-σ)/h dσ B, B = [0, 1]ᵀ.
        // series where the closed forms cancel (M1 loses ~(ωh)⁻² ulps), closed forms above
        let (gamma, m1) = if w * h < 0.05 {
            // Power series: Γ = Σ A^k h^{k+1}/(k+1)! B, M1 = Σ A^k h^{k+1}/(k+2)! B.
            let mut ak: M2 = [[1.0, 0.0], [0.0, 1.0]];
            let mut g = [0.0; 2];
            let mut m = [0.0; 2];
            let mut hk = h; // h^{k+1}
            let mut fact1 = 1.0; // (k+1)!
            for k in 0..30 {
                let fact2 = fact1 * (k as f64 + 2.0);
                let dg = [ak[0][1] * hk / fact1, ak[1][1] * hk / fact1];
                g[0] += dg[0];
                g[1] += dg[1];
                m[0] += ak[0][1] * hk / fact2;
                m[1] += ak[1][1] * hk / fact2;
                // the terms shrink like (ωh)^k / k!: stop once they no longer change g
                // (M1's terms are smaller still)
                if k >= 2 && dg[0].abs() <= 1e-17 * g[0].abs() && dg[1].abs() <= 1e-17 * g[1].abs()
                {
                    break;
                }
                ak = mat_mul(&a, &ak);
                hk *= h;
                fact1 = fact2;
            }
            (g, m)
        } else {
            // Closed forms with A⁻¹ = (1/ω²) [[-c, -1], [ω², 0]].
            let inv = |v: [f64; 2]| [(-c * v[0] - v[1]) / (w * w), v[0]];
            let pm_i_b = [phi[0][1], phi[1][1] - 1.0]; // (Φ - I) B
            let g = inv(pm_i_b);
            // M1 = -A⁻¹B + (1/h) A⁻²(Φ - I)B
            let ainv_b = inv([0.0, 1.0]);
            let a2 = inv(g);
            (g, [-ainv_b[0] + a2[0] / h, -ainv_b[1] + a2[1] / h])
        };
        match hold {
            Hold::Zoh => SectionStep {
                phi,
                g0: gamma,
                g1: [0.0, 0.0],
            },
            Hold::Foh | Hold::BandLimited => SectionStep {
                phi,
                g0: [gamma[0] - m1[0], gamma[1] - m1[1]],
                g1: m1,
            },
        }
    }

    /// Advances one state.
    #[inline]
    pub fn advance(&self, x: &mut [f64; 2], u0: f64, u1: f64) {
        let q = self.phi[0][0] * x[0] + self.phi[0][1] * x[1] + self.g0[0] * u0 + self.g1[0] * u1;
        let v = self.phi[1][0] * x[0] + self.phi[1][1] * x[1] + self.g0[1] * u0 + self.g1[1] * u1;
        *x = [q, v];
    }
}

/// ZOH discrete transfer function of one section: `(b, a)` in powers of `z⁻¹`.
pub fn section_zoh_tf(mode: &Mode, num: &ModeNum, ts: f64) -> (Vec<f64>, Vec<f64>) {
    let st = SectionStep::new(mode, ts, Hold::Zoh);
    let (p, g) = (st.phi, st.g0);
    let (c0, c1) = (num.b0, num.b1);
    let n1 = c0 * g[0] + c1 * g[1];
    let n2 = c0 * (-p[1][1] * g[0] + p[0][1] * g[1]) + c1 * (p[1][0] * g[0] - p[0][0] * g[1]);
    let tr = p[0][0] + p[1][1];
    let det = p[0][0] * p[1][1] - p[0][1] * p[1][0];
    (vec![0.0, n1, n2], vec![1.0, -tr, det])
}

impl ModalModel {
    /// Discrete-time transfer function `H(z⁻¹) = B(z⁻¹)/A(z⁻¹)` of channel `ci` at sample
    /// time `ts`, the form of the paper's equation (1), for inspection.
    ///
    /// Each mode is discretised exactly with a zero-order hold on the input (MATLAB
    /// `c2d(..., 'zoh')`), then the sections are summed. Returns `(b, a)` with `a[0] = 1`,
    /// `b[k]` the coefficient of `z⁻ᵏ`. Never store these: high-order polynomials lose
    /// their poles when rounded.
    pub fn discrete_tf(&self, ci: usize, ts: f64) -> (Vec<f64>, Vec<f64>) {
        let ch = &self.channels[ci];
        let mut num = vec![ch.d];
        let mut den = vec![1.0];
        for (m, n) in self.modes.iter().zip(&ch.num) {
            let (bk, ak) = section_zoh_tf(m, n, ts);
            // num/den + bk/ak = (num*ak + bk*den) / (den*ak)
            let left = poly_mul(&num, &ak);
            let right = poly_mul(&bk, &den);
            num = poly_add(&left, &right);
            den = poly_mul(&den, &ak);
        }
        (num, den)
    }
}

fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

fn poly_add(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len().max(b.len())];
    for (i, x) in a.iter().enumerate() {
        out[i] += x;
    }
    for (i, x) in b.iter().enumerate() {
        out[i] += x;
    }
    out
}

/// State of a running simulation of a [`ModalModel`] (or of a pose-dependent sequence of
/// models with the same modes and channels).
#[derive(Debug, Clone)]
pub struct Simulator {
    hold: Hold,
    n_modes: usize,
    /// `state[k * 3 + j]` = (q, q̇) of mode k driven by force axis j.
    state: Vec<[f64; 2]>,
    steps: Vec<SectionStep>,
    /// The modes and step the cached `steps` were built for.
    cached: Option<(Vec<Mode>, f64)>,
    /// Cubic modal stiffness κ per mode (empty = all linear).
    cubic: Vec<f64>,
}

impl Simulator {
    /// A simulator at rest for models with `n_modes` modes.
    pub fn new(n_modes: usize, hold: Hold) -> Self {
        Simulator {
            hold,
            n_modes,
            state: vec![[0.0; 2]; 3 * n_modes],
            steps: Vec::with_capacity(n_modes),
            cached: None,
            cubic: Vec::new(),
        }
    }

    /// Gives mode `k` a cubic stiffness `κ_k`: `q̈ + 2ζω q̇ + ω² q (1 + κ q²) = F` on each
    /// force axis' modal coordinate (exact for excitation along one axis, an approximation
    /// otherwise). Such modes are integrated with classical Runge–Kutta (sub-steps of at
    /// most 1/20 of the mode's period, at least 8 per step) under the simulator's hold;
    /// the others keep the exact discretisation. Returns false (and changes nothing) when
    /// `kappa` has the wrong length or a non-finite value.
    pub fn set_cubic(&mut self, kappa: &[f64]) -> bool {
        if kappa.len() != self.n_modes || !kappa.iter().all(|v| v.is_finite()) {
            return false;
        }
        self.cubic = if kappa.iter().all(|v| *v == 0.0) {
            Vec::new()
        } else {
            kappa.to_vec()
        };
        true
    }

    /// The hold used between samples.
    pub fn hold(&self) -> Hold {
        self.hold
    }

    /// Back to rest.
    pub fn reset(&mut self) {
        self.state.iter_mut().for_each(|x| *x = [0.0; 2]);
    }

    /// The raw state, `(q, q̇)` per mode and force axis.
    pub fn state(&self) -> &[[f64; 2]] {
        &self.state
    }

    /// Replaces the raw state (e.g. to restore a serialized FMU state).
    pub fn set_state(&mut self, s: &[[f64; 2]]) -> bool {
        if s.len() != self.state.len() {
            return false;
        }
        self.state.copy_from_slice(s);
        true
    }

    /// Advances by `h` seconds with the forces `u0` at the start and `u1` at the end of
    /// the step (ZOH ignores `u1`), using the parameters of `model`.
    ///
    /// # Panics
    /// If `model` has a different number of modes than the simulator was built for.
    pub fn step(&mut self, model: &ModalModel, u0: &[f64; 3], u1: &[f64; 3], h: f64) {
        assert_eq!(model.modes.len(), self.n_modes, "mode count changed");
        // rebuild the exact discretisation only when the modes or the step changed
        let same = self
            .cached
            .as_ref()
            .is_some_and(|(m, hh)| *hh == h && m == &model.modes);
        if !same {
            self.steps.clear();
            self.steps.extend(
                model
                    .modes
                    .iter()
                    .map(|m| SectionStep::new(m, h, self.hold)),
            );
            match &mut self.cached {
                Some((m, hh)) => {
                    m.clear();
                    m.extend_from_slice(&model.modes);
                    *hh = h;
                }
                None => self.cached = Some((model.modes.clone(), h)),
            }
        }
        for (k, st) in self.steps.iter().enumerate() {
            let kappa = self.cubic.get(k).copied().unwrap_or(0.0);
            for j in 0..3 {
                if u0[j] != 0.0 || u1[j] != 0.0 || self.state[k * 3 + j] != [0.0, 0.0] {
                    if kappa == 0.0 {
                        st.advance(&mut self.state[k * 3 + j], u0[j], u1[j]);
                    } else {
                        let u1 = if self.hold == Hold::Zoh { u0[j] } else { u1[j] };
                        // a band-limited record is stepped at 16x its rate: the
                        // sub-steps of 1/20 period suffice there
                        let min_steps = if self.hold == Hold::BandLimited { 1 } else { 8 };
                        rk4_cubic(
                            &mut self.state[k * 3 + j],
                            &model.modes[k],
                            kappa,
                            (u0[j], u1),
                            h,
                            min_steps,
                        );
                    }
                }
            }
        }
    }

    /// Responses along x, y, z for the current state and the force `u` now
    /// (axes the model has no channel for are 0).
    pub fn output(&self, model: &ModalModel, u: &[f64; 3]) -> [f64; 3] {
        let mut y = [0.0; 3];
        for ch in &model.channels {
            let (o, j) = (ch.channel.output.index(), ch.channel.input.index());
            let mut acc = ch.d * u[j];
            for (k, n) in ch.num.iter().enumerate() {
                let x = self.state[k * 3 + j];
                acc += n.b0 * x[0] + n.b1 * x[1];
            }
            y[o] += acc;
        }
        y
    }
}

/// Advances `q̈ + 2ζω q̇ + ω² q (1 + κ q²) = u(t)` over `h`, `u` linear from `u0` to `u1`.
fn rk4_cubic(x: &mut [f64; 2], mode: &Mode, kappa: f64, u: (f64, f64), h: f64, min_steps: usize) {
    let (u0, u1) = u;
    let (w, z) = (mode.wn, mode.zeta);
    let n =
        ((h * w / (2.0 * std::f64::consts::PI) * 20.0).ceil() as usize).clamp(min_steps, 100_000);
    let dt = h / n as f64;
    let f = |t: f64, x: [f64; 2]| -> [f64; 2] {
        let u = u0 + (u1 - u0) * t / h;
        [
            x[1],
            u - 2.0 * z * w * x[1] - w * w * x[0] * (1.0 + kappa * x[0] * x[0]),
        ]
    };
    let mut y = *x;
    for s in 0..n {
        let t = s as f64 * dt;
        let k1 = f(t, y);
        let k2 = f(
            t + dt / 2.0,
            [y[0] + dt / 2.0 * k1[0], y[1] + dt / 2.0 * k1[1]],
        );
        let k3 = f(
            t + dt / 2.0,
            [y[0] + dt / 2.0 * k2[0], y[1] + dt / 2.0 * k2[1]],
        );
        let k4 = f(t + dt, [y[0] + dt * k3[0], y[1] + dt * k3[1]]);
        y[0] += dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]);
        y[1] += dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]);
    }
    *x = y;
}

/// Simulates a sampled force record through a model that may change per sample.
///
/// `forces[i]` is the force at sample `i`; `model_at(i)` the model valid at sample `i`
/// (same modes and channels throughout). Returns the response at every sample:
/// `y[i]` depends on forces up to and including sample `i` (feedthrough `d`).
pub fn simulate<'a>(
    forces: &[[f64; 3]],
    dt: f64,
    hold: Hold,
    mut model_at: impl FnMut(usize) -> &'a ModalModel,
) -> Vec<[f64; 3]> {
    if hold == Hold::BandLimited {
        return run_band_limited(forces, dt, |f, h, coarse, every| {
            simulate_dyn(f, h, Hold::BandLimited, &mut |m| model_at(coarse(m)), every)
        });
    }
    simulate_dyn(forces, dt, hold, &mut model_at, 1)
}

/// The response at samples `0, every, 2·every, …` of a simulation over all `forces`.
fn simulate_dyn<'a>(
    forces: &[[f64; 3]],
    dt: f64,
    hold: Hold,
    model_at: &mut dyn FnMut(usize) -> &'a ModalModel,
    every: usize,
) -> Vec<[f64; 3]> {
    let mut out = Vec::with_capacity(forces.len().div_ceil(every));
    if forces.is_empty() {
        return out;
    }
    let first = model_at(0);
    let mut sim = Simulator::new(first.modes.len(), hold);
    out.push(sim.output(first, &forces[0]));
    for i in 1..forces.len() {
        // advance over [t_{i-1}, t_i] with the parameters at the start of the step
        let m = model_at(i - 1);
        sim.step(m, &forces[i - 1], &forces[i], dt);
        if i % every == 0 {
            let m = model_at(i);
            out.push(sim.output(m, &forces[i]));
        }
    }
    out
}

/// Helper: the force of a record at every sample as `[fx, fy, fz]` (0 where absent).
pub fn force_rows(ts: &crate::timeseries::TimeSeries) -> Vec<[f64; 3]> {
    let n = ts.len();
    let mut rows = vec![[0.0; 3]; n];
    for a in Axis::ALL {
        if let Some(f) = ts.force(a) {
            for (r, v) in rows.iter_mut().zip(f) {
                r[a.index()] = *v;
            }
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Channel;
    use crate::model::ChannelModel;

    fn sdof(f: f64, z: f64) -> ModalModel {
        ModalModel {
            modes: vec![Mode::from_hz(f, z)],
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num: vec![ModeNum { b0: 1.0, b1: 0.0 }],
                d: 0.0,
            }],
        }
    }

    /// The folded band-limited simulation of a fixed model equals the step-by-step one
    /// on the upsampled record: three modes (one lightly damped, one near Nyquist), two
    /// driven axes and an idle one, feedthrough, records shorter and longer than the
    /// interpolation kernel.
    #[test]
    fn band_limited_lti_equals_the_step_by_step_simulation() {
        let modes = vec![
            Mode::from_hz(47.0, 0.004),
            Mode::from_hz(610.0, 0.03),
            Mode::from_hz(2300.0, 0.02),
        ];
        let num = |a: f64| {
            vec![
                ModeNum { b0: a, b1: 0.1 * a },
                ModeNum {
                    b0: -2.0 * a,
                    b1: 0.0,
                },
                ModeNum {
                    b0: 0.5 * a,
                    b1: -1e-4 * a,
                },
            ]
        };
        let model = ModalModel {
            modes,
            channels: vec![
                ChannelModel {
                    channel: Channel::new(Axis::X, Axis::X),
                    num: num(1.0),
                    d: 1e-3,
                },
                ChannelModel {
                    channel: Channel::new(Axis::Y, Axis::X),
                    num: num(0.3),
                    d: 0.0,
                },
                ChannelModel {
                    channel: Channel::new(Axis::X, Axis::Y),
                    num: num(-0.7),
                    d: 0.0,
                },
                ChannelModel {
                    channel: Channel::new(Axis::Y, Axis::Z),
                    num: num(2.0),
                    d: 0.0,
                },
            ],
        };
        let dt = 1.0 / 6400.0;
        for n in [1, 2, 7, 30, 49, 3000] {
            let u: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let t = i as f64;
                    [
                        (0.37 * t).sin() + (0.011 * t * t).cos(),
                        (1.3 * t).cos(),
                        0.0,
                    ]
                })
                .collect();
            let fast = band_limited_lti(&model, &u, dt);
            let slow = run_band_limited(&u, dt, |f, h, _, every| {
                let mut sim = Simulator::new(3, Hold::BandLimited);
                let mut out = vec![sim.output(&model, &f[0])];
                for i in 1..f.len() {
                    sim.step(&model, &f[i - 1], &f[i], h);
                    if i % every == 0 {
                        out.push(sim.output(&model, &f[i]));
                    }
                }
                out
            });
            assert_eq!(fast.len(), slow.len());
            let top = slow.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in fast.iter().zip(&slow) {
                for c in 0..3 {
                    assert!((a[c] - b[c]).abs() <= 1e-11 * top, "n {n}: {a:?} vs {b:?}");
                }
            }
        }
    }

    /// A sampled sine at 0.3 of the sample rate (an anti-aliased record's upper band):
    /// the band-limited hold gives the steady-state amplitude |H(f)| within 0.2 %, the
    /// first-order hold on the samples is about `sinc²(0.3)` = 0.75 of it.
    #[test]
    fn band_limited_hold_is_exact_near_nyquist() {
        let (fs, f) = (10240.0, 3072.0);
        let model = sdof(1000.0, 0.05);
        let n = 4096;
        let w = 2.0 * std::f64::consts::PI * f;
        let u: Vec<[f64; 3]> = (0..n)
            .map(|i| [(w * i as f64 / fs).sin(), 0.0, 0.0])
            .collect();
        let exact = model.eval_hz(0, f).norm();
        let amplitude = |y: &[[f64; 3]]| {
            // least-squares sine amplitude over the second half (transient gone)
            let (mut sc, mut ss, mut cc, mut s2, mut c2) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for (i, r) in y.iter().enumerate().skip(n / 2).take(n / 2 - 64) {
                let (s, c) = (w * i as f64 / fs).sin_cos();
                sc += s * c;
                ss += r[0] * s;
                cc += r[0] * c;
                s2 += s * s;
                c2 += c * c;
            }
            let det = s2 * c2 - sc * sc;
            let a = (ss * c2 - cc * sc) / det;
            let b = (cc * s2 - ss * sc) / det;
            (a * a + b * b).sqrt()
        };
        let band = simulate(&u, 1.0 / fs, Hold::BandLimited, |_| &model);
        assert_eq!(band.len(), n);
        let ratio = amplitude(&band) / exact;
        assert!((ratio - 1.0).abs() < 2e-3, "band-limited {ratio}");
        let foh = amplitude(&simulate(&u, 1.0 / fs, Hold::Foh, |_| &model)) / exact;
        assert!((foh - 0.75).abs() < 0.05, "first-order hold {foh}");
        // the upsampler passes through the samples
        let up = upsample(&u, BAND_LIMITED_FACTOR);
        assert_eq!(up.len(), (n - 1) * BAND_LIMITED_FACTOR + 1);
        assert!((0..n).all(|i| up[i * BAND_LIMITED_FACTOR] == u[i]));
    }

    /// The upsampler equals its definition term by term (each fine sample the sum over
    /// the taps in order, taps outside the record skipped), bit for bit, for lengths
    /// shorter than, near and far beyond the kernel, with a channel that is all zero.
    #[test]
    fn upsample_equals_the_direct_sum() {
        fn direct(x: &[[f64; 3]], l: usize) -> Vec<[f64; 3]> {
            let (n, h) = (x.len() as isize, UPSAMPLE_HALF as isize);
            let mut out = Vec::new();
            for i in 0..n {
                out.push(x[i as usize]);
                if i + 1 == n {
                    break;
                }
                for r in 1..l {
                    let mut v = [0.0; 3];
                    for j in -h + 1..=h {
                        let k = i + j;
                        if (0..n).contains(&k) {
                            let w = interpolation_kernel(j as f64 - r as f64 / l as f64);
                            for c in 0..3 {
                                v[c] += w * x[k as usize][c];
                            }
                        }
                    }
                    out.push(v);
                }
            }
            out
        }
        let mut seed = 12345u64;
        let mut rnd = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for n in [2, 3, 17, 47, 48, 49, 97, 128, 331] {
            let x: Vec<[f64; 3]> = (0..n).map(|_| [rnd(), 0.0, rnd() * 1e3]).collect();
            for l in [2, 5, BAND_LIMITED_FACTOR] {
                let (fast, slow) = (upsample(&x, l), direct(&x, l));
                assert_eq!(fast.len(), slow.len());
                for (a, b) in fast.iter().zip(&slow) {
                    for c in 0..3 {
                        assert_eq!(a[c].to_bits(), b[c].to_bits(), "n {n}, l {l}");
                    }
                }
            }
        }
    }

    /// Step response of an SDOF system: q(t) = (1 - e^{-σt}(cos ωd t + σ/ωd sin ωd t))/ω².
    #[test]
    fn step_response_is_exact_for_any_step_length() {
        for &(f, z) in &[(50.0, 0.02), (800.0, 0.05), (3.0, 1.5)] {
            let m = sdof(f, z);
            let w = 2.0 * std::f64::consts::PI * f;
            let exact = |t: f64| {
                let s = z * w;
                if z < 1.0 {
                    let wd = w * (1.0 - z * z).sqrt();
                    (1.0 - (-s * t).exp() * ((wd * t).cos() + s / wd * (wd * t).sin())) / (w * w)
                } else {
                    let r = w * (z * z - 1.0).sqrt();
                    let (p1, p2) = (-s + r, -s - r);
                    (1.0 + (p2 * (p1 * t).exp() - p1 * (p2 * t).exp()) / (p1 - p2)) / (w * w)
                }
            };
            for &h in &[1e-6, 3.7e-4, 1e-3, 0.05] {
                for hold in [Hold::Zoh, Hold::Foh] {
                    let mut sim = Simulator::new(1, hold);
                    let mut t = 0.0;
                    for _ in 0..40 {
                        sim.step(&m, &[1.0, 0.0, 0.0], &[1.0, 0.0, 0.0], h);
                        t += h;
                    }
                    let y = sim.output(&m, &[1.0, 0.0, 0.0])[0];
                    let e = exact(t);
                    assert!(
                        (y - e).abs() <= 1e-9 * (1.0 / (w * w)),
                        "f={f} z={z} h={h} {hold:?}: {y} vs {e}"
                    );
                }
            }
        }
    }

    /// FOH reproduces a ramp input exactly: compare with a very fine ZOH simulation.
    #[test]
    fn foh_is_exact_for_ramps() {
        let m = sdof(120.0, 0.03);
        let h = 1e-3;
        let mut foh = Simulator::new(1, Hold::Foh);
        let mut fine = Simulator::new(1, Hold::Zoh);
        let sub = 2000;
        for k in 0..50 {
            let (u0, u1) = (k as f64 * h, (k + 1) as f64 * h);
            foh.step(&m, &[u0, 0.0, 0.0], &[u1, 0.0, 0.0], h);
            for s in 0..sub {
                let u = u0 + (u1 - u0) * (s as f64 + 0.5) / sub as f64;
                fine.step(&m, &[u, 0.0, 0.0], &[u, 0.0, 0.0], h / sub as f64);
            }
        }
        let a = foh.output(&m, &[0.0; 3])[0];
        let b = fine.output(&m, &[0.0; 3])[0];
        assert!((a - b).abs() < 1e-6 * b.abs(), "{a} vs {b}");
    }
}
