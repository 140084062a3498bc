//! Zero-order lobes against the closed-form single-degree-of-freedom result.

use identify::axis::{Axis, Channel};
use identify::lobes::{
    average_directional_matrix, lobes_zoa, write_lobes_csv, Cut, LobePoint, Tool,
};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
use identify::Error;
use num_complex::Complex64;
use std::f64::consts::PI;

fn approx_eq(a: f64, b: f64, abs: f64, rel: f64) -> bool {
    (a - b).abs() <= abs + rel * a.abs().max(b.abs())
}

/// SDOF in x: q̈ + 2ζω q̇ + ω² q = F, x = q / m; y rigid (zero numerator).
fn sdof(f_hz: f64, zeta: f64, mass: f64) -> ModalModel {
    let ch = |o, b0| ChannelModel {
        channel: Channel::new(o, o),
        num: vec![ModeNum { b0, b1: 0.0 }],
        d: 0.0,
    };
    ModalModel {
        modes: vec![Mode::from_hz(f_hz, zeta)],
        channels: vec![ch(Axis::X, 1.0 / mass), ch(Axis::Y, 0.0)],
    }
}

const FN: f64 = 922.0;
const ZETA: f64 = 0.011;
const MASS: f64 = 0.03993;

fn slot() -> (Tool, Cut) {
    (
        Tool {
            teeth: 2,
            diameter_m: 0.01,
            helix_deg: 0.0,
        },
        Cut {
            radial_immersion: 1.0,
            down_milling: true,
            kt: 6e8,
            kr: 1.0 / 3.0,
        },
    )
}

/// The textbook SDOF lobes: ap = −1/(2 Kt a Re G) with a = |A0_xx|, phase
/// ε = 2π − 2 atan(Re G / Im G), rpm = 60 ω / (N (ε + 2πk)); solved for ω at a given
/// rpm by bisection on every lobe, minimum over lobes.
fn analytic_sdof(rpm: f64, a: f64, kt: f64, n: f64) -> f64 {
    let w0 = 2.0 * PI * FN;
    let k = MASS * w0 * w0;
    let g = |w: f64| {
        let r = w / w0;
        Complex64::new(1.0, 0.0) / (k * Complex64::new(1.0 - r * r, 2.0 * ZETA * r))
    };
    let lobe_rpm = |w: f64, l: f64| {
        let h = g(w);
        let eps = 2.0 * PI - 2.0 * (h.re / h.im).atan();
        60.0 * w / (n * (eps + 2.0 * PI * l))
    };
    let mut best = f64::INFINITY;
    for l in 0..60 {
        let lf = l as f64;
        let (mut lo, mut hi) = (w0 * (1.0 + 1e-9), 4.0 * w0);
        let (flo, fhi) = (lobe_rpm(lo, lf) - rpm, lobe_rpm(hi, lf) - rpm);
        if flo * fhi > 0.0 {
            continue;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if (lobe_rpm(mid, lf) - rpm) * flo > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let ap = -1.0 / (2.0 * kt * a * g(0.5 * (lo + hi)).re);
        best = best.min(ap);
    }
    best
}

#[test]
fn sdof_slotting_matches_closed_form() {
    let model = sdof(FN, ZETA, MASS);
    let (tool, cut) = slot();
    let a0 = average_directional_matrix(&tool, &cut).unwrap();
    // slotting: A0_xx = −N Kr / 4
    assert!(approx_eq(a0[0][0], -2.0 / 3.0 / 4.0 * 1.0, 1e-15, 1e-12));
    let rpm: Vec<f64> = (0..60).map(|i| 4000.0 + 450.0 * i as f64).collect();
    let lobes = lobes_zoa(&model, &tool, &cut, &rpm).unwrap();
    for p in &lobes {
        let ex = analytic_sdof(p.rpm, a0[0][0].abs(), cut.kt, 2.0);
        assert!(
            approx_eq(p.ap_lim_m, ex, 0.0, 2e-3),
            "rpm {}: zoa {} vs analytic {}",
            p.rpm,
            p.ap_lim_m,
            ex
        );
        assert!(p.chatter_hz > FN && p.chatter_hz < 1.5 * FN);
    }
}

#[test]
fn sdof_lobe_minimum_is_2k_zeta_1_plus_zeta() {
    let model = sdof(FN, ZETA, MASS);
    let (tool, cut) = slot();
    let w0 = 2.0 * PI * FN;
    let k = MASS * w0 * w0;
    let a = cut.kr * tool.teeth as f64 / 4.0;
    // b_lim,min = 2 k ζ (1 + ζ) / (Kt a), at chatter frequency ≈ fn (1 + ζ)
    let expected = 2.0 * k * ZETA * (1.0 + ZETA) / (cut.kt * a);
    let rpm: Vec<f64> = (0..4000).map(|i| 8000.0 + 5.0 * i as f64).collect();
    let lobes = lobes_zoa(&model, &tool, &cut, &rpm).unwrap();
    let min = lobes
        .iter()
        .min_by(|a, b| a.ap_lim_m.total_cmp(&b.ap_lim_m))
        .unwrap();
    assert!(
        approx_eq(min.ap_lim_m, expected, 0.0, 1e-3),
        "{min:?} vs {expected}"
    );
    assert!(
        approx_eq(min.chatter_hz, FN * (1.0 + ZETA), 0.0, 2e-3),
        "{min:?}"
    );
    // never below the minimum, never NaN
    assert!(lobes
        .iter()
        .all(|p| p.ap_lim_m >= expected * (1.0 - 1e-3) && !p.ap_lim_m.is_nan()));
}

#[test]
fn symmetric_xy_slotting_independent_of_cross_terms_order() {
    // x and y identical: the ZOA eigenvalues are those of A0 · g, λ = g · eig(A0)
    let mut model = sdof(FN, ZETA, MASS);
    model.channels[1].num[0].b0 = 1.0 / MASS;
    let (tool, cut) = slot();
    let a0 = average_directional_matrix(&tool, &cut).unwrap();
    // slotting A0 = [[-Kr, -1], [1, -Kr]]·N/4 → eigenvalues (N/4)(−Kr ± i)
    let n4 = tool.teeth as f64 / 4.0;
    assert!(approx_eq(a0[0][1], -n4, 1e-15, 1e-12) && approx_eq(a0[1][0], n4, 1e-15, 1e-12));
    let rpm = [9000.0, 12000.0, 15000.0, 21000.0];
    let lobes = lobes_zoa(&model, &tool, &cut, &rpm).unwrap();
    for p in &lobes {
        assert!(p.ap_lim_m.is_finite() && p.ap_lim_m > 0.0, "{p:?}");
    }
    // Re(λ G) > 0 with λ = (N/4)(−Kr ± i): the minimum over ω of 1/(2 Kt Re λG)
    let w0 = 2.0 * PI * FN;
    let k = MASS * w0 * w0;
    let mut best = f64::INFINITY;
    for i in 0..200_000 {
        let w = w0 * (0.5 + 1.5 * i as f64 / 200_000.0);
        let r = w / w0;
        let g = Complex64::new(1.0, 0.0) / (k * Complex64::new(1.0 - r * r, 2.0 * ZETA * r));
        for s in [1.0, -1.0] {
            let lam = Complex64::new(-cut.kr, s) * n4 * g;
            if lam.re > 0.0 {
                best = best.min(1.0 / (2.0 * cut.kt * lam.re));
            }
        }
    }
    let rpm: Vec<f64> = (0..3000).map(|i| 8000.0 + 5.0 * i as f64).collect();
    let lobes = lobes_zoa(&model, &tool, &cut, &rpm).unwrap();
    let min = lobes
        .iter()
        .map(|p| p.ap_lim_m)
        .fold(f64::INFINITY, f64::min);
    assert!(approx_eq(min, best, 0.0, 2e-3), "{min} vs {best}");
}

#[test]
fn errors_are_clear() {
    let (tool, cut) = slot();
    let mut model = sdof(FN, ZETA, MASS);
    model.channels.pop();
    let e = lobes_zoa(&model, &tool, &cut, &[1000.0]).unwrap_err();
    assert!(matches!(e, Error::BadInput(_)));
    assert!(e.to_string().contains("xx and yy"), "{e}");
    let model = sdof(FN, ZETA, MASS);
    let bad = Cut {
        radial_immersion: 0.0,
        ..cut
    };
    assert!(lobes_zoa(&model, &tool, &bad, &[1000.0]).is_err());
    assert!(lobes_zoa(&model, &tool, &cut, &[f64::NAN]).is_err());
    let t0 = Tool { teeth: 0, ..tool };
    assert!(lobes_zoa(&model, &t0, &cut, &[1000.0]).is_err());
    assert!(lobes_zoa(&model, &tool, &cut, &[]).unwrap().is_empty());
}

#[test]
fn csv_has_both_columns() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lobes.csv");
    let z = [LobePoint {
        rpm: 1000.0,
        ap_lim_m: 1e-3,
        chatter_hz: 900.0,
    }];
    let s = [LobePoint {
        rpm: 1000.0,
        ap_lim_m: f64::INFINITY,
        chatter_hz: 0.0,
    }];
    write_lobes_csv(&path, &z, &s).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "rpm,ap_lim_zoa_m,ap_lim_sd_m,chatter_hz_zoa,chatter_hz_sd"
    );
    assert_eq!(lines[1], "1000,1e-3,inf,9e2,0e0");
    let other = [LobePoint {
        rpm: 2000.0,
        ..s[0]
    }];
    assert!(write_lobes_csv(&path, &z, &other).is_err());
}
