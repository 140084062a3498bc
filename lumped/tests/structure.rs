//! The structure's modes: eigen-analysis vs the analytic FRF, pose dependence,
//! non-proportional damping, reproducible random machines.
mod common;

use lumped::effects::visible;
use lumped::frf::linspace;
use lumped::modal::pair_modes;
use lumped::structure::{Assembly, Machine, CENTRE};

#[test]
fn modal_sum_rebuilds_the_analytic_receptance() {
    let asm = Machine::nominal().assemble(CENTRE, 0.0);
    let modes = asm.modes();
    for f in [30.0, 137.0, 480.0, 2000.0, 4000.0] {
        let h = asm.receptance(f);
        let hm = Assembly::modal_receptance(&modes, f);
        let scale = (0..3).map(|i| h[(i, i)].norm()).fold(0.0, f64::max);
        let err = (h - hm).iter().map(|v| v.norm()).fold(0.0, f64::max) / scale;
        assert!(err < 1e-4, "{f} Hz: {err}");
    }
}

#[test]
fn visible_modes_sit_at_peaks_of_the_analytic_frf() {
    let m = Machine::nominal();
    let modes = m.modes(CENTRE);
    let vis = visible(&modes, 0.1);
    assert!((6..=16).contains(&vis.len()), "{} visible modes", vis.len());
    let mut checked = 0;
    for &i in &vis {
        let md = &modes[i];
        let a = md.axis();
        // well separated from other visible modes on the same channel: a local maximum
        let alone = vis.iter().all(|&j| {
            j == i
                || modes[j].axis() != a
                || (modes[j].freq_hz / md.freq_hz).ln().abs() > 4.0 * md.zeta + 0.05
        });
        if !alone {
            continue;
        }
        let freqs = linspace(md.freq_hz * 0.85, md.freq_hz * 1.15, 601);
        let frf = m.analytic_frf(CENTRE, &freqs);
        let mag: Vec<f64> = frf.channel(a, a).iter().map(|v| v.norm()).collect();
        let k = (0..mag.len())
            .max_by(|&x, &y| mag[x].total_cmp(&mag[y]))
            .unwrap_or(0);
        // a peak of a damped mode sits at ω_n √(1 − 2ζ²) (receptance); neighbours pull it
        // by less than half its half-power half-width ζ f_n
        let expect = md.freq_hz * (1.0 - 2.0 * md.zeta * md.zeta).sqrt();
        assert!(
            common::approx_eq(freqs[k], expect, 0.5 * md.zeta * md.freq_hz, 0.005),
            "mode {:.1} Hz: peak at {:.1}",
            md.freq_hz,
            freqs[k]
        );
        checked += 1;
    }
    assert!(checked >= 4, "only {checked} isolated modes");
}

#[test]
fn modes_shift_with_the_axis_positions() {
    let m = Machine::nominal();
    let c = m.modes(CENTRE);
    let vis = visible(&c, 0.1);
    let mut largest: f64 = 0.0;
    for pose in [[0.0, 0.0, 0.0], [0.8, 0.6, 0.3], [0.4, 0.3, 0.3]] {
        let p = m.modes(pose);
        for (i, j, mac) in pair_modes(&c, &p) {
            if vis.contains(&i) && mac > 0.5 {
                largest = largest.max((p[j].freq_hz / c[i].freq_hz - 1.0).abs());
            }
        }
    }
    // a few percent across the workspace (the ram screw and overhang give the most)
    assert!(largest > 0.03 && largest < 0.3, "largest shift {largest}");
    // cross coupling appears off the symmetry plane y = 0.3
    let h0 = m.analytic_frf(CENTRE, &[72.9]).h[0];
    let h1 = m.analytic_frf([0.4, 0.1, 0.15], &[72.9]).h[0];
    assert!(h0[(1, 0)].norm() < 1e-6 * h0[(0, 0)].norm());
    assert!(h1[(1, 0)].norm() > 1e-2 * h1[(0, 0)].norm());
}

#[test]
fn damping_is_not_proportional() {
    let asm = Machine::nominal().assemble(CENTRE, 0.0);
    // Caughey: proportional damping iff K M⁻¹ C = C M⁻¹ K
    let mi = asm.m.clone().try_inverse().expect("M invertible");
    let a = &asm.k * &mi * &asm.c;
    let b = &asm.c * &mi * &asm.k;
    assert!((&a - &b).norm() > 1e-3 * a.norm());
    let modes = asm.modes();
    let vis = visible(&modes, 0.05);
    let most = vis.iter().map(|&i| modes[i].complexity).fold(0.0, f64::max);
    assert!(most > 0.05, "largest complexity {most}");
    // with C = αM + βK the same structure has real modes
    let mut prop = asm.clone();
    prop.c = &asm.m * 10.0 + &asm.k * 2e-5;
    let pm = prop.modes();
    let worst = pm
        .iter()
        .filter(|m| !m.real)
        .map(|m| m.complexity)
        .fold(0.0, f64::max);
    assert!(worst < 1e-6, "proportional complexity {worst}");
}

#[test]
fn random_machines_are_reproducible_and_differ() {
    let a = Machine::random(3);
    let b = Machine::random(3);
    let c = Machine::random(4);
    assert_eq!(a, b);
    assert_ne!(a, c);
    let fa: Vec<f64> = a.modes(CENTRE).iter().map(|m| m.freq_hz).collect();
    let fc: Vec<f64> = c.modes(CENTRE).iter().map(|m| m.freq_hz).collect();
    assert_ne!(fa, fc);
    let vis = visible(&a.modes(CENTRE), 0.1);
    assert!(vis.len() >= 5, "{}", vis.len());
}

#[test]
fn accelerometer_mass_lowers_the_tool_modes() {
    let m = Machine::nominal();
    let free = m.assemble(CENTRE, 0.0).modes();
    let loaded = m.assemble(CENTRE, 0.05).modes();
    let top = |ms: &[lumped::modal::Mode]| {
        ms.iter()
            .filter(|x| x.freq_hz < 3000.0)
            .map(|x| x.freq_hz)
            .fold(0.0, f64::max)
    };
    assert!(
        top(&loaded) < top(&free) * 0.995,
        "{} vs {}",
        top(&loaded),
        top(&free)
    );
}
