//! The time simulation (exact discretisation at 8×, anti-alias FIR, decimation) agrees
//! with the analytic receptance.
mod common;

use lumped::excitation::{random_force, sweep, Sweep};
use lumped::measure::{run, unit, Setup};
use lumped::sim::Hold;
use lumped::structure::{Machine, CENTRE};
use lumped::Response;
use rand::rngs::StdRng;
use rand::SeedableRng;

/// Full-record ratio of a random-force record that starts and ends at rest
/// (2 s of force 20–3000 Hz, 1.5 s of decay), judged on the lines where the force
/// has ≥ 10 % of its mean line amplitude, 30–2500 Hz.
fn ratio_errors(hold: Hold, input_axis: usize) -> (f64, f64, f64) {
    let m = Machine::nominal();
    let mut setup = Setup::clean(Response::Displacement);
    setup.hold = hold;
    let fs = setup.daq.fs_sim();
    let n_force = (2.0 * fs) as usize;
    let n = (3.5 * fs) as usize;
    let mut rng = StdRng::seed_from_u64(7);
    let mut f = random_force(
        fs,
        n_force,
        (20.0, 3000.0),
        20.0,
        unit(input_axis),
        &mut rng,
    );
    f.resize(n, [0.0; 3]);
    let c = run(&m, &setup, &f, &[CENTRE]);
    let fx = common::dft(&c.force[input_axis]);
    let nd = c.force[0].len();
    let df = c.fs / nd as f64;
    let mean: f64 = fx.iter().take(nd / 2).map(|v| v.norm()).sum::<f64>() / (nd / 2) as f64;
    let mut worst_direct: f64 = 0.0;
    let mut sum_direct = 0.0;
    let mut worst_cross: f64 = 0.0;
    let mut count = 0usize;
    let freqs: Vec<(usize, f64)> = (1..nd / 2)
        .map(|k| (k, k as f64 * df))
        .filter(|&(k, f)| (30.0..=2500.0).contains(&f) && fx[k].norm() > 0.1 * mean)
        .step_by(7)
        .collect();
    let truth = m.analytic_frf(CENTRE, &freqs.iter().map(|p| p.1).collect::<Vec<_>>());
    let resp: Vec<_> = (0..3).map(|d| common::dft(&c.response[d])).collect();
    for (i, &(k, _)) in freqs.iter().enumerate() {
        let h = truth.h[i];
        let scale = (0..3).map(|o| h[(o, o)].norm()).fold(0.0, f64::max);
        for o in 0..3 {
            let est = resp[o][k] / fx[k];
            let t = h[(o, input_axis)];
            if o == input_axis {
                let e = (est - t).norm() / t.norm();
                worst_direct = worst_direct.max(e);
                sum_direct += e;
                count += 1;
            } else {
                // cross channels judged against the largest direct channel
                worst_cross = worst_cross.max((est - t).norm() / scale);
            }
        }
    }
    (sum_direct / count as f64, worst_direct, worst_cross)
}

#[test]
fn first_order_hold_matches_analytic_frf() {
    for axis in [0, 1] {
        let (mean, worst, cross) = ratio_errors(Hold::First, axis);
        eprintln!(
            "FOH axis {axis}: direct mean {mean:.2e} worst {worst:.2e}, cross worst {cross:.2e}"
        );
        // mean 0.19 %: the first-order hold's sinc² (0.3 % at 2.5 kHz) and the decay
        // left at the record's end; worst 1.5 % at the deepest anti-resonances, where
        // |h| is 1/200 of the peaks
        assert!(
            mean < 3e-3 && worst < 2.5e-2 && cross < 1e-2,
            "{mean} {worst} {cross}"
        );
    }
}

#[test]
fn zero_order_hold_lags_half_a_step() {
    let (mean_zoh, _, _) = ratio_errors(Hold::Zero, 0);
    let (mean_foh, _, _) = ratio_errors(Hold::First, 0);
    eprintln!("ZOH mean {mean_zoh:.2e} vs FOH {mean_foh:.2e}");
    assert!(mean_zoh > mean_foh);
}

#[test]
fn log_sweep_ratio_matches_at_the_centre() {
    let m = Machine::nominal();
    let setup = Setup::clean(Response::Displacement);
    let fs = setup.daq.fs_sim();
    let n = (4.0 * fs) as usize;
    let f = sweep(Sweep::Logarithmic, fs, n, 20.0, 3000.0, 2.5, 50.0, unit(1));
    let c = run(&m, &setup, &f, &[CENTRE]);
    let fy = common::dft(&c.force[1]);
    let dy = common::dft(&c.response[1]);
    let df = c.fs / c.force[1].len() as f64;
    let ks: Vec<usize> = (1..c.force[1].len() / 2)
        .filter(|&k| (50.0..=2500.0).contains(&(k as f64 * df)))
        .step_by(11)
        .collect();
    let truth = m.analytic_frf(
        CENTRE,
        &ks.iter().map(|&k| k as f64 * df).collect::<Vec<_>>(),
    );
    let mut worst: f64 = 0.0;
    for (i, &k) in ks.iter().enumerate() {
        let t = truth.h[i][(1, 1)];
        worst = worst.max((dy[k] / fy[k] - t).norm() / t.norm());
    }
    eprintln!("log sweep yy worst {worst:.2e}");
    assert!(worst < 1e-2);
}
