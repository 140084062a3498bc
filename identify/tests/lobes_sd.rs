//! Semi-discretisation lobes: against a brute-force time simulation of the delay
//! equation, against ZOA in slotting, and the flip lobes of low immersion.

use identify::axis::{Axis, Channel};
use identify::lobes::{floquet_sd, lobes_sd, lobes_zoa, stable_sd, Cut, SdOptions, Tool};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
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
    let k_per = 400usize;
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
        let sd = lobes_sd(&model, &tool(), &cut(ae), &[rpm], &opts(30)).unwrap()[0];
        assert!(sd.ap_lim_m.is_finite() && sd.ap_lim_m > 0.0, "{sd:?}");
        let below = growth(rpm, 0.85 * sd.ap_lim_m, ae, 240);
        let above = growth(rpm, 1.15 * sd.ap_lim_m, ae, 240);
        eprintln!(
            "ae {ae} rpm {rpm}: ap_sd {:.3} mm, growth at 0.85: {below:.3e}, at 1.15: {above:.3e}",
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
