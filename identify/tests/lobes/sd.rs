//! Semi-discretisation lobes: against a brute-force time simulation of the delay
//! equation, against ZOA in slotting, and the flip lobes of low immersion; on the demo's
//! machine: every limit the first unstable depth, its flip lobe against a time
//! simulation, and SD = ZOA at every speed where the zero-order average is exact.

use identify::axis::{Axis, Channel};
use identify::lobes::{floquet_sd, lobes_sd, lobes_zoa, stable_sd, Cut, SdOptions, Tool};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
use rayon::prelude::*;
use std::f64::consts::PI;

// Insperger & Stépán's 1-DOF milling benchmark (IJNME 2004; Ding et al. 2010):
// fn = 922 Hz, ζ = 0.011, m = 0.03993 kg, Kt = 6e8 N/m², Kn = 2e8 N/m², N = 2.
const FN: f64 = 922.0;
const ZETA: f64 = 0.011;
const MASS: f64 = 0.03993;
const KT: f64 = 6e8;
const KR: f64 = 2e8 / 6e8;

fn sdof() -> ModalModel {
    let ch = |o, b0| ChannelModel {
        channel: Channel::new(o, o),
        num: vec![ModeNum { b0, b1: 0.0 }],
        d: 0.0,
    };
    ModalModel {
        modes: vec![Mode::from_hz(FN, ZETA)],
        channels: vec![ch(Axis::X, 1.0 / MASS), ch(Axis::Y, 0.0)],
    }
}

fn tool() -> Tool {
    Tool {
        teeth: 2,
        diameter_m: 0.01,
        helix_deg: 0.0,
    }
}

fn cut(ae: f64) -> Cut {
    Cut {
        radial_immersion: ae,
        down_milling: true,
        kt: KT,
        kr: KR,
    }
}

fn opts(m: usize) -> SdOptions {
    SdOptions {
        steps: m,
        rel_tol: 1e-3,
        ..SdOptions::default()
    }
}

/// Brute force, written from the definition: RK4 on
/// m ẍ + c ẋ + k x = ap Kt h_xx(t) (x(t) − x(t − τ)),
/// h_xx(t) = Σ_j g(φ_j) (−sin φ_j cos φ_j − Kr sin² φ_j), φ_j = Ω t + 2πj/N,
/// with cubic Hermite interpolation of the stored history. Returns the growth of the
/// peak |x| from periods [40, 60) to the last 20 periods.
fn growth(rpm: f64, ap: f64, ae: f64, periods: usize) -> f64 {
    let w0 = 2.0 * PI * FN;
    let n = 2usize;
    let tau = 60.0 / (rpm * n as f64);
    let om = 2.0 * PI * rpm / 60.0;
    let st = (2.0 * ae - 1.0f64).acos();
    let ex = PI;
    let h_xx = |t: f64| {
        let mut s = 0.0;
        for j in 0..n {
            let phi = (om * t + 2.0 * PI * j as f64 / n as f64).rem_euclid(2.0 * PI);
            if phi >= st && phi <= ex {
                s += -phi.sin() * phi.cos() - KR * phi.sin().powi(2);
            }
        }
        s
    };
    let k_per = if ae < 1.0 { 2000usize } else { 400 };
    let dt = tau / k_per as f64;
    let mut hist: Vec<(f64, f64)> = vec![(0.0, 0.0); k_per + 1]; // ring of (x, v)
    let delayed = |hist: &Vec<(f64, f64)>, i: usize, frac: f64| -> f64 {
        // value at t_i + frac·dt − τ from ring slots i and i+1 (mod k_per+1)
        let l = hist.len();
        let (x0, v0) = hist[i % l];
        let (x1, v1) = hist[(i + 1) % l];
        let s = frac;
        let h00 = 2.0 * s.powi(3) - 3.0 * s * s + 1.0;
        let h10 = s.powi(3) - 2.0 * s * s + s;
        let h01 = -2.0 * s.powi(3) + 3.0 * s * s;
        let h11 = s.powi(3) - s * s;
        h00 * x0 + h10 * dt * v0 + h01 * x1 + h11 * dt * v1
    };
    let (mut x, mut v) = (1e-6, 0.0);
    let acc = |t: f64, x: f64, v: f64, xd: f64| {
        -2.0 * ZETA * w0 * v - w0 * w0 * x + ap * KT * h_xx(t) * (x - xd) / MASS
    };
    let mut peaks = vec![0.0f64; periods];
    let total = periods * k_per;
    for step in 0..total {
        let t = step as f64 * dt;
        // ring slot of time t − τ is (step) mod (k_per+1) when we store x(t_i) at slot i mod (k_per+1)
        let l = k_per + 1;
        let slot_old = (step + l - k_per) % l; // t_i − τ = t_{i−k_per}
        let xd0 = delayed(&hist, slot_old, 0.0);
        let xdh = delayed(&hist, slot_old, 0.5);
        let xd1 = delayed(&hist, slot_old, 1.0);
        hist[step % l] = (x, v);
        let (k1x, k1v) = (v, acc(t, x, v, xd0));
        let (k2x, k2v) = (
            v + 0.5 * dt * k1v,
            acc(t + 0.5 * dt, x + 0.5 * dt * k1x, v + 0.5 * dt * k1v, xdh),
        );
        let (k3x, k3v) = (
            v + 0.5 * dt * k2v,
            acc(t + 0.5 * dt, x + 0.5 * dt * k2x, v + 0.5 * dt * k2v, xdh),
        );
        let (k4x, k4v) = (v + dt * k3v, acc(t + dt, x + dt * k3x, v + dt * k3v, xd1));
        x += dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        v += dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        let p = step / k_per;
        peaks[p] = peaks[p].max(x.abs());
    }
    let early = peaks[40..60].iter().cloned().fold(0.0, f64::max);
    let late = peaks[periods - 20..].iter().cloned().fold(0.0, f64::max);
    late / early
}

#[test]
fn boundary_matches_brute_force_time_simulation() {
    let model = sdof();
    for (ae, rpm) in [
        (1.0, 9000.0),
        (1.0, 14000.0),
        (0.05, 10000.0),
        (0.05, 16000.0),
    ] {
        let sd = lobes_sd(&model, &tool(), &cut(ae), &[rpm], &opts(80)).unwrap()[0];
        assert!(sd.ap_lim_m.is_finite() && sd.ap_lim_m > 0.0, "{sd:?}");
        let periods = 600;
        let below = growth(rpm, 0.95 * sd.ap_lim_m, ae, periods);
        let above = growth(rpm, 1.05 * sd.ap_lim_m, ae, periods);
        // the per-period growth factor of the simulation is the spectral radius
        // (peaks of [40, 60) vs the last 20 periods: 540 periods apart)
        let span = (periods - 20 - 40) as f64;
        for (g, f) in [(below, 0.95), (above, 1.05)] {
            let rho_bf = g.powf(1.0 / span);
            let rho_sd = floquet_sd(&model, &tool(), &cut(ae), rpm, f * sd.ap_lim_m, &opts(80))
                .unwrap()
                .spectral_radius;
            eprintln!("  ap×{f}: rho brute force {rho_bf:.5}, rho sd {rho_sd:.5}");
            assert!((rho_bf - rho_sd).abs() < 5e-3, "{rho_bf} vs {rho_sd}");
        }
        eprintln!(
            "ae {ae} rpm {rpm}: ap_sd {:.3} mm, growth at 0.95: {below:.3e}, at 1.05: {above:.3e}",
            sd.ap_lim_m * 1e3
        );
        assert!(
            below < 0.5,
            "ae {ae} rpm {rpm}: decays below the limit? {below}"
        );
        assert!(
            above > 2.0,
            "ae {ae} rpm {rpm}: grows above the limit? {above}"
        );
    }
}

#[test]
fn slotting_sd_agrees_with_zoa_at_lobe_minima() {
    // 4 teeth, slotting, two different modes in x and y: the classic case where ZOA is
    // accurate (Altintas & Budak 1995)
    let ch = |o, k: usize, b0| ChannelModel {
        channel: Channel::new(o, o),
        num: (0..2)
            .map(|i| ModeNum {
                b0: if i == k { b0 } else { 0.0 },
                b1: 0.0,
            })
            .collect(),
        d: 0.0,
    };
    let model = ModalModel {
        modes: vec![Mode::from_hz(600.0, 0.035), Mode::from_hz(660.0, 0.03)],
        channels: vec![ch(Axis::X, 0, 1.0 / 0.4), ch(Axis::Y, 1, 1.0 / 0.35)],
    };
    let tool = Tool { teeth: 4, ..tool() };
    let cut = Cut {
        kr: 0.3,
        ..cut(1.0)
    };
    let rpm: Vec<f64> = (0..400).map(|i| 4000.0 + 30.0 * i as f64).collect();
    let zoa = lobes_zoa(&model, &tool, &cut, &rpm).unwrap();
    // local minima of the ZOA lobes
    let minima: Vec<_> = (1..zoa.len() - 1)
        .filter(|&i| zoa[i].ap_lim_m < zoa[i - 1].ap_lim_m && zoa[i].ap_lim_m < zoa[i + 1].ap_lim_m)
        .map(|i| zoa[i])
        .collect();
    assert!(minima.len() >= 2, "{minima:?}");
    let sp: Vec<f64> = minima.iter().map(|p| p.rpm).collect();
    let sd = lobes_sd(&model, &tool, &cut, &sp, &opts(40)).unwrap();
    for (z, s) in minima.iter().zip(&sd) {
        let rel = (s.ap_lim_m - z.ap_lim_m).abs() / z.ap_lim_m;
        eprintln!(
            "rpm {:.0}: zoa {:.4} mm @ {:.1} Hz, sd {:.4} mm @ {:.1} Hz ({:.2} %)",
            z.rpm,
            z.ap_lim_m * 1e3,
            z.chatter_hz,
            s.ap_lim_m * 1e3,
            s.chatter_hz,
            rel * 100.0
        );
        assert!(rel < 0.05, "{z:?} vs {s:?}");
        assert!((s.chatter_hz - z.chatter_hz).abs() < 0.03 * z.chatter_hz);
    }
}

#[test]
fn low_immersion_shows_flip_lobes_zoa_misses() {
    let model = sdof();
    let cut = cut(0.05);
    let rpm: Vec<f64> = (0..16).map(|i| 14000.0 + 1000.0 * i as f64).collect();
    let zoa = lobes_zoa(&model, &tool(), &cut, &rpm).unwrap();
    let sd = lobes_sd(&model, &tool(), &cut, &rpm, &opts(20)).unwrap();
    let mut flips = 0;
    for (z, s) in zoa.iter().zip(&sd) {
        let fl = floquet_sd(&model, &tool(), &cut, s.rpm, s.ap_lim_m * 1.01, &opts(20)).unwrap();
        let is_flip = fl.multiplier.im.abs() < 1e-6 && fl.multiplier.re < -1.0;
        eprintln!(
            "rpm {:.0}: zoa {:.3} mm, sd {:.3} mm, multiplier {:.3}{}",
            z.rpm,
            z.ap_lim_m * 1e3,
            s.ap_lim_m * 1e3,
            fl.multiplier,
            if is_flip { " (flip)" } else { "" }
        );
        if is_flip && s.ap_lim_m < 0.7 * z.ap_lim_m {
            flips += 1;
            // period doubling: chatter at an odd multiple of half the tooth frequency
            let ft = s.rpm * 2.0 / 60.0;
            let r = s.chatter_hz / (0.5 * ft);
            assert!(
                (r - r.round()).abs() < 1e-6 && r.round() as i64 % 2 == 1,
                "{s:?}"
            );
        }
    }
    assert!(flips >= 2, "expected flip lobes below the ZOA limit");
}

#[test]
fn converges_with_steps_and_stable_sd_is_consistent() {
    let model = sdof();
    let c = cut(1.0);
    // second order in the step: the error at m falls 4× when m doubles
    let ap = |m| lobes_sd(&model, &tool(), &c, &[12000.0], &opts(m)).unwrap()[0].ap_lim_m;
    // (pre-asymptotic below m ≈ 40 with 2.5 vibration periods per tooth period)
    let (a, b, r) = (ap(40), ap(80), ap(160));
    eprintln!("m=40: {a:.6e}, m=80: {b:.6e}, m=160: {r:.6e}");
    let (ea, eb) = ((a - r).abs() / r, (b - r).abs() / r);
    assert!(ea < 0.04 && eb < 0.01 && eb < 0.35 * ea, "{ea} {eb}");
    let b = lobes_sd(&model, &tool(), &c, &[12000.0], &opts(40)).unwrap()[0];
    let (s_lo, r_lo) = stable_sd(&model, &tool(), &c, 12000.0, 0.95 * b.ap_lim_m).unwrap();
    let (s_hi, r_hi) = stable_sd(&model, &tool(), &c, 12000.0, 1.05 * b.ap_lim_m).unwrap();
    assert!(s_lo && r_lo < 1.0 && !s_hi && r_hi > 1.0, "{r_lo} {r_hi}");
    // zero depth: free vibration over one tooth period, ρ = e^{−ζω τ}
    let (ok, r0) = stable_sd(&model, &tool(), &c, 12000.0, 0.0).unwrap();
    let tau = 60.0 / (12000.0 * 2.0);
    assert!(
        ok && (r0 - (-ZETA * 2.0 * PI * FN * tau).exp()).abs() < 1e-9,
        "{r0}"
    );
}

#[test]
fn helix_and_residual_are_handled() {
    let mut model = sdof();
    model.channels[0].d = 1e-9;
    let t = Tool {
        helix_deg: 30.0,
        ..tool()
    };
    let p = lobes_sd(&model, &t, &cut(0.5), &[12000.0], &opts(20)).unwrap()[0];
    assert!(p.ap_lim_m.is_finite() && p.ap_lim_m > 0.0, "{p:?}");
    let bad = Tool {
        diameter_m: 0.0,
        ..t
    };
    assert!(lobes_sd(&model, &bad, &cut(0.5), &[12000.0], &opts(20)).is_err());
}

/// Brute force for a general x–y modal model (cross channels included): RK4 on the modal
/// states `q̈ + 2ζω q̇ + ω² q = F_j`, `r_o = Σ b0 q + b1 q̇`, with the force from the
/// definition `F = ap Kt Σ_j g(φ_j) [−cos φ − Kr sin φ; sin φ − Kr cos φ] h_j`,
/// `h_j = sin φ Δx + cos φ Δy`, `Δ = r(t) − r(t − τ)` (delayed r linear between the
/// stored samples, fine steps). Returns the growth of the peak |r| as in [`growth`].
fn growth_2d(model: &ModalModel, tool: &Tool, c: &Cut, rpm: f64, ap: f64, periods: usize) -> f64 {
    let n_teeth = tool.teeth;
    // helix: the flute at height z lags by z·tanβ/R; 24 axial slices of ap/24
    let slices = if tool.helix_deg != 0.0 { 24 } else { 1 };
    let lag = 2.0 * ap * tool.helix_deg.to_radians().tan() / tool.diameter_m;
    let nm = model.modes.len();
    let idx = |o: Axis, j: Axis| model.channel_index(Channel::new(o, j));
    let ax = [Axis::X, Axis::Y];
    let tau = 60.0 / (rpm * n_teeth as f64);
    let om = 2.0 * PI * rpm / 60.0;
    let (st, ex) = if c.down_milling {
        ((2.0 * c.radial_immersion - 1.0f64).acos(), PI)
    } else {
        (0.0, (1.0 - 2.0 * c.radial_immersion).acos())
    };
    let k_per = 600usize;
    let dt = tau / k_per as f64;
    // state: for mode k, axis j: (q, v) at 4k + 2j
    let ns = 4 * nm;
    let out = |s: &[f64]| -> [f64; 2] {
        let mut r = [0.0; 2];
        for o in 0..2 {
            for j in 0..2 {
                if let Some(ci) = idx(ax[o], ax[j]) {
                    for k in 0..nm {
                        let n = model.channels[ci].num[k];
                        r[o] += n.b0 * s[4 * k + 2 * j] + n.b1 * s[4 * k + 2 * j + 1];
                    }
                }
            }
        }
        r
    };
    let force = |t: f64, r: [f64; 2], rd: [f64; 2]| -> [f64; 2] {
        let (dx, dy) = (r[0] - rd[0], r[1] - rd[1]);
        let mut f = [0.0; 2];
        let b = ap / slices as f64;
        for z in 0..slices {
            let lz = lag * (z as f64 + 0.5) / slices as f64;
            for j in 0..n_teeth {
                let phi = (om * t + 2.0 * PI * j as f64 / n_teeth as f64 - lz).rem_euclid(2.0 * PI);
                if phi >= st && phi <= ex {
                    let (s, co) = phi.sin_cos();
                    let h = s * dx + co * dy;
                    f[0] += b * c.kt * (-co - c.kr * s) * h;
                    f[1] += b * c.kt * (s - c.kr * co) * h;
                }
            }
        }
        f
    };
    let deriv = |t: f64, s: &[f64], rd: [f64; 2]| -> Vec<f64> {
        let f = force(t, out(s), rd);
        let mut d = vec![0.0; ns];
        for (k, m) in model.modes.iter().enumerate() {
            for j in 0..2 {
                let (q, v) = (s[4 * k + 2 * j], s[4 * k + 2 * j + 1]);
                d[4 * k + 2 * j] = v;
                d[4 * k + 2 * j + 1] = f[j] - 2.0 * m.zeta * m.wn * v - m.wn * m.wn * q;
            }
        }
        d
    };
    let mut s = vec![0.0; ns];
    s[0] = 1e-9;
    s[3] = 1e-9;
    let l = k_per + 1;
    let mut hist = vec![[0.0f64; 2]; l];
    let mut peaks = vec![0.0f64; periods];
    for step in 0..periods * k_per {
        let t = step as f64 * dt;
        let old = (step + 1) % l; // r(t − τ)
        let r_a = hist[old];
        let r_b = hist[(step + 2) % l];
        let mid = [0.5 * (r_a[0] + r_b[0]), 0.5 * (r_a[1] + r_b[1])];
        hist[step % l] = out(&s);
        let add = |a: &[f64], b: &[f64], h: f64| -> Vec<f64> {
            a.iter().zip(b).map(|(x, y)| x + h * y).collect()
        };
        let k1 = deriv(t, &s, r_a);
        let k2 = deriv(t + 0.5 * dt, &add(&s, &k1, 0.5 * dt), mid);
        let k3 = deriv(t + 0.5 * dt, &add(&s, &k2, 0.5 * dt), mid);
        let k4 = deriv(t + dt, &add(&s, &k3, dt), r_b);
        for i in 0..ns {
            s[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        let r = out(&s);
        let p = step / k_per;
        peaks[p] = peaks[p].max(r[0].abs().max(r[1].abs()));
    }
    let early = peaks[40..60].iter().cloned().fold(0.0, f64::max);
    let late = peaks[periods - 20..].iter().cloned().fold(0.0, f64::max);
    late / early
}

#[test]
fn two_dof_with_cross_channels_matches_brute_force() {
    // two modes, both seen in x and y with cross terms (a tilted principal direction),
    // 3 teeth, half immersion up milling
    let num = |b: [f64; 2]| {
        b.iter()
            .map(|&b0| ModeNum { b0, b1: 0.0 })
            .collect::<Vec<_>>()
    };
    let ch = |o, j, b: [f64; 2]| ChannelModel {
        channel: Channel::new(o, j),
        num: num(b),
        d: 0.0,
    };
    let (c1, s1) = (0.9f64, 0.436f64); // mode 1 direction ≈ 26°
    let (c2, s2) = (-s1, c1);
    let (m1, m2) = (1.0 / 0.5, 1.0 / 0.6);
    let model = ModalModel {
        modes: vec![Mode::from_hz(700.0, 0.03), Mode::from_hz(820.0, 0.025)],
        channels: vec![
            ch(Axis::X, Axis::X, [m1 * c1 * c1, m2 * c2 * c2]),
            ch(Axis::Y, Axis::Y, [m1 * s1 * s1, m2 * s2 * s2]),
            ch(Axis::X, Axis::Y, [m1 * c1 * s1, m2 * c2 * s2]),
            ch(Axis::Y, Axis::X, [m1 * c1 * s1, m2 * c2 * s2]),
        ],
    };
    let tool = Tool { teeth: 3, ..tool() };
    let c = Cut {
        radial_immersion: 0.5,
        down_milling: false,
        kt: 6e8,
        kr: 0.3,
    };
    for rpm in [9000.0, 13500.0] {
        let sd = lobes_sd(&model, &tool, &c, &[rpm], &opts(40)).unwrap()[0];
        let zoa = lobes_zoa(&model, &tool, &c, &[rpm]).unwrap()[0];
        assert!(sd.ap_lim_m.is_finite(), "{sd:?}");
        let below = growth_2d(&model, &tool, &c, rpm, 0.9 * sd.ap_lim_m, 200);
        let above = growth_2d(&model, &tool, &c, rpm, 1.1 * sd.ap_lim_m, 200);
        eprintln!(
            "rpm {rpm}: sd {:.4} mm @ {:.1} Hz, zoa {:.4} mm @ {:.1} Hz; growth at 0.9: {below:.3e}, 1.1: {above:.3e}",
            sd.ap_lim_m * 1e3,
            sd.chatter_hz,
            zoa.ap_lim_m * 1e3,
            zoa.chatter_hz
        );
        assert!(below < 0.5 && above > 2.0, "rpm {rpm}: {below} {above}");
    }
}

#[test]
fn helix_matches_brute_force() {
    // the 1-DOF benchmark with a 45° helix on a 6 mm cutter: the axial lag at the limit
    // (≈ 2 ap / D rad) spreads the short cut of 10 % immersion noticeably
    let model = sdof();
    let t = Tool {
        teeth: 2,
        diameter_m: 0.006,
        helix_deg: 45.0,
    };
    let c = cut(0.1);
    for rpm in [10000.0, 16000.0] {
        let straight = lobes_sd(&model, &tool(), &c, &[rpm], &opts(40)).unwrap()[0];
        let sd = lobes_sd(&model, &t, &c, &[rpm], &opts(40)).unwrap()[0];
        let below = growth_2d(&model, &t, &c, rpm, 0.92 * sd.ap_lim_m, 300);
        let above = growth_2d(&model, &t, &c, rpm, 1.08 * sd.ap_lim_m, 300);
        eprintln!(
            "rpm {rpm}: helix {:.4} mm, straight {:.4} mm; growth at 0.92: {below:.3e}, 1.08: {above:.3e}",
            sd.ap_lim_m * 1e3,
            straight.ap_lim_m * 1e3
        );
        assert!(below < 0.5 && above > 2.0, "rpm {rpm}: {below} {above}");
    }
}

/// The demo's virtual machine at its centre (9 modes, 62–1380 Hz, x and y with cross
/// channels), as `mtwin demo` draws its lobes.
fn demo_machine() -> ModalModel {
    let m = vmachine::structure::ModalMachine::default_machine();
    m.model_at(m.center(), &[Axis::X, Axis::Y])
}

/// The demo's cut: 3 teeth, half immersion down milling, Kt 600 N/mm², Kr 0.3.
fn demo_cut() -> (Tool, Cut) {
    (
        Tool {
            teeth: 3,
            diameter_m: 0.016,
            helix_deg: 0.0,
        },
        Cut {
            radial_immersion: 0.5,
            down_milling: true,
            kt: 6e8,
            kr: 0.3,
        },
    )
}

#[test]
fn demo_machine_every_sd_limit_is_the_first_unstable_depth() {
    // where the issue saw the limit jump (3024 rpm 104 mm, 3207 rpm 22 mm): each limit is
    // checked from the definition, the spectral radius on a grid of depths under it
    let model = demo_machine();
    let (tool, cut) = demo_cut();
    let rpm = identify::lobes::log_speeds(2500.0, 5000.0, 36);
    let sd = lobes_sd(&model, &tool, &cut, &rpm, &opts(40)).unwrap();
    let rho = |rpm: f64, ap: f64| {
        floquet_sd(&model, &tool, &cut, rpm, ap, &opts(40))
            .unwrap()
            .spectral_radius
    };
    let bad: Vec<String> = sd
        .par_iter()
        .filter_map(|p| {
            assert!(p.ap_lim_m.is_finite(), "{p:?}");
            let n = 48;
            let below = (1..n)
                .map(|j| p.ap_lim_m * j as f64 / n as f64)
                .find(|&a| rho(p.rpm, a) >= 1.0);
            let above = rho(p.rpm, 1.01 * p.ap_lim_m);
            (below.is_some() || above < 1.0).then(|| {
                format!(
                    "{:.0} rpm, limit {:.2} mm: unstable at {:?} mm below it, ρ {above:.4} above",
                    p.rpm,
                    p.ap_lim_m * 1e3,
                    below.map(|a| a * 1e3)
                )
            })
        })
        .collect();
    assert!(bad.is_empty(), "{bad:#?}");
    // the structure the plot shows: the limit drops where a new lobe's island begins
    // (the chatter frequency changes with it), by 2x at least once in this range
    let drops = sd
        .windows(2)
        .filter(|w| {
            let (a, b) = (w[0], w[1]);
            (a.ap_lim_m / b.ap_lim_m).ln().abs() > 2f64.ln()
                && (a.chatter_hz / b.chatter_hz).ln().abs() > 0.01
        })
        .count();
    assert!(drops >= 1, "{sd:#?}");
}

#[test]
fn demo_machine_flip_lobe_matches_a_time_simulation() {
    // around 4000 rpm the teeth pass at 200 Hz, twice the 95 Hz mode: a flip lobe
    // (period doubling) that the zero-order average does not have
    let model = demo_machine();
    let (tool, cut) = demo_cut();
    let rpm = 4000.0;
    let sd = lobes_sd(&model, &tool, &cut, &[rpm], &opts(40)).unwrap()[0];
    let zoa = lobes_zoa(&model, &tool, &cut, &[rpm]).unwrap()[0];
    let fl = floquet_sd(&model, &tool, &cut, rpm, 1.02 * sd.ap_lim_m, &opts(40)).unwrap();
    eprintln!(
        "4000 rpm: sd {:.2} mm @ {:.2} Hz (multiplier {:.4}), zoa {:.2} mm @ {:.2} Hz",
        sd.ap_lim_m * 1e3,
        sd.chatter_hz,
        fl.multiplier,
        zoa.ap_lim_m * 1e3,
        zoa.chatter_hz
    );
    assert!(
        fl.multiplier.re < -1.0 && fl.multiplier.im.abs() < 1e-6,
        "not a flip: {}",
        fl.multiplier
    );
    assert!(
        (sd.chatter_hz - rpm * 3.0 / 120.0).abs() < 1e-6 * rpm,
        "{sd:?}"
    );
    assert!(zoa.ap_lim_m > 2.0 * sd.ap_lim_m, "{zoa:?} vs {sd:?}");
    let below = growth_2d(&model, &tool, &cut, rpm, 0.9 * sd.ap_lim_m, 200);
    let above = growth_2d(&model, &tool, &cut, rpm, 1.1 * sd.ap_lim_m, 200);
    let between = growth_2d(&model, &tool, &cut, rpm, 0.5 * zoa.ap_lim_m, 200);
    eprintln!("growth at 0.9 sd {below:.3e}, 1.1 sd {above:.3e}, half the zoa limit {between:.3e}");
    assert!(below < 0.5 && above > 2.0, "{below} {above}");
    // half the zero-order limit, which the zero-order method calls stable, chatters
    assert!(between > 2.0, "{between}");
}

#[test]
fn four_tooth_slotting_sd_equals_zoa_at_every_speed() {
    // slotting with 4 teeth: two teeth always cut, their directional terms in 2φ cancel
    // and A(t) = A0 at all times; the zero-order method is then exact and the
    // semi-discretisation must agree with it at every speed, minima and pockets alike
    // (no flip lobes), and neither jumps between neighbouring speeds of one lobe
    let model = demo_machine();
    let tool = Tool {
        teeth: 4,
        diameter_m: 0.016,
        helix_deg: 0.0,
    };
    let cut = Cut {
        radial_immersion: 1.0,
        down_milling: true,
        kt: 6e8,
        kr: 0.3,
    };
    let rpm = identify::lobes::log_speeds(2000.0, 20000.0, 60);
    let zoa = lobes_zoa(&model, &tool, &cut, &rpm).unwrap();
    let sd = lobes_sd(&model, &tool, &cut, &rpm, &opts(40)).unwrap();
    let mut worst = 0.0f64;
    for (z, d) in zoa.iter().zip(&sd) {
        let rel = (d.ap_lim_m / z.ap_lim_m - 1.0).abs();
        worst = worst.max(rel);
        assert!(
            rel < 0.015,
            "{:.0} rpm: zoa {:.3} mm @ {:.1} Hz, sd {:.3} mm @ {:.1} Hz",
            z.rpm,
            z.ap_lim_m * 1e3,
            z.chatter_hz,
            d.ap_lim_m * 1e3,
            d.chatter_hz
        );
    }
    eprintln!("4-tooth slotting, 60 speeds 2000-20000 rpm: worst |sd/zoa - 1| {worst:.4}");
    // the overall minimum (the depth stable at any speed) agrees to 1 %
    let min = |v: &[identify::lobes::LobePoint]| {
        v.iter().map(|p| p.ap_lim_m).fold(f64::INFINITY, f64::min)
    };
    assert!((min(&sd) / min(&zoa) - 1.0).abs() < 0.01);
}
