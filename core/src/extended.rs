//! Simulation of a twin with its extensions (delay, disturbance, cubic stiffness).
//!
//! Everything runs through the state-space core ([`crate::simulate::Simulator`], the one
//! the FMU uses): exact discretisation for linear modes, classical Runge–Kutta for a mode
//! with a cubic stiffness term ([`crate::simulate::Simulator::set_cubic`]); a constant delay shifts the response by linear interpolation between
//! samples; an external vibration is added as sinusoids of absolute time.
//!
//! A cubic term acts on each force axis' modal coordinate separately, which is exact
//! for excitation along one axis (impact tests) and an approximation otherwise.

use crate::interpolate::{simulate_twin, TwinEvaluator};
use crate::model::ModalModel;
use crate::simulate::Hold;
use crate::twin::Twin;
use std::f64::consts::PI;

/// Refuses a record with no force column that any of `channels` (a twin's) responds to:
/// its simulation would be all zeros.
pub fn check_force_columns(
    channels: &[crate::axis::Channel],
    ts: &crate::timeseries::TimeSeries,
) -> crate::Result<()> {
    let inputs: Vec<_> = channels.iter().map(|c| c.input).collect();
    if inputs.iter().any(|i| ts.force(*i).is_some()) {
        return Ok(());
    }
    Err(crate::Error::BadInput(format!(
        "{}: no force column the twin responds to (the twin's inputs are {}); add f{} to the file",
        ts.source,
        inputs
            .iter()
            .map(|i| format!("f{i}"))
            .collect::<Vec<_>>()
            .join(", "),
        inputs.first().copied().unwrap_or(crate::axis::Axis::X)
    )))
}

/// Simulates `twin` (with its extensions) for sampled forces at sampled poses.
/// `t0` is the absolute time of sample 0 (for disturbances).
pub fn simulate_extended(
    twin: &Twin,
    forces: &[[f64; 3]],
    pose_at: impl Fn(usize) -> [f64; 3],
    t0: f64,
    dt: f64,
    hold: Hold,
) -> crate::Result<Vec<[f64; 3]>> {
    let mut ev = TwinEvaluator::new(twin)?;
    let ext = &twin.extensions;
    let y = if ext.cubic.is_empty() {
        simulate_twin(&mut ev, forces, &pose_at, dt, hold)
    } else {
        simulate_cubic(&mut ev, forces, &pose_at, dt, hold, &ext.cubic)
    };
    Ok(delay_and_disturb(twin, y, t0, dt))
}

/// The twin's delay and external vibration applied to its simulated response `y`
/// (sample 0 at absolute time `t0`).
fn delay_and_disturb(twin: &Twin, mut y: Vec<[f64; 3]>, t0: f64, dt: f64) -> Vec<[f64; 3]> {
    let ext = &twin.extensions;
    if let Some(tau) = ext.delay_s {
        y = delay(&y, tau / dt);
    }
    for s in &ext.disturbance {
        let w = 2.0 * PI * s.freq_hz;
        for (i, r) in y.iter_mut().enumerate() {
            let t = t0 + i as f64 * dt;
            r[s.axis.index()] += s.a * (w * t).cos() + s.b * (w * t).sin();
        }
    }
    y
}

impl Twin {
    /// The simulation of this twin for a record, the one every command, the Python
    /// package, refit and diagnose run: the record's forces (refused when it has no force
    /// column the twin responds to), its axis positions sample by sample (the model
    /// interpolated at each), its absolute time (for disturbances), the twin's extensions
    /// ([`simulate_extended`]) and the hold `hold` between samples. Displacement per axis
    /// x, y, z at every sample.
    pub fn simulate(
        &self,
        ts: &crate::timeseries::TimeSeries,
        hold: Hold,
    ) -> crate::Result<Vec<[f64; 3]>> {
        check_force_columns(&self.channels, ts)?;
        let f = crate::simulate::force_rows(ts);
        simulate_extended(self, &f, |i| ts.position_at(i), ts.t0, ts.dt, hold)
    }
}

/// The twin's simulation ([`Twin::simulate`]) of a measured record as its sensor saw it:
/// the band-limited hold of a measured record ([`Hold::BandLimited`]); per axis x, y, z
/// the displacement or, for an accelerometer record, its second derivative (a
/// band-limited FIR). What refit and diagnose compare with the measured response.
pub fn simulate_as_measured(
    twin: &Twin,
    ts: &crate::timeseries::TimeSeries,
) -> crate::Result<[Vec<f64>; 3]> {
    let y = twin.simulate(ts, Hold::BandLimited)?;
    Ok(as_measured(&y, ts))
}

/// [`simulate_as_measured`] at the record's own rate where the twin is linear time
/// invariant over the record (the axes stand still, no cubic stiffness): the model at that
/// pose through [`crate::simulate::band_limited_lti`], the same response up to rounding
/// in a fraction of the time. Otherwise exactly [`simulate_as_measured`].
pub fn simulate_as_measured_lti(
    twin: &Twin,
    ts: &crate::timeseries::TimeSeries,
) -> crate::Result<[Vec<f64>; 3]> {
    let pose = ts.position_at(0);
    let still = stands_still(ts);
    if !still || !twin.extensions.cubic.is_empty() || ts.len() < 2 {
        return simulate_as_measured(twin, ts);
    }
    check_force_columns(&twin.channels, ts)?;
    let f = crate::simulate::force_rows(ts);
    let model = TwinEvaluator::new(twin)?.model_at(pose).clone();
    let y = crate::simulate::band_limited_lti(&model, &f, ts.dt);
    let y = delay_and_disturb(twin, y, ts.t0, ts.dt);
    Ok(as_measured(&y, ts))
}

/// Whether the record's axes stay at their first position throughout.
fn stands_still(ts: &crate::timeseries::TimeSeries) -> bool {
    let pose = ts.position_at(0);
    (0..3).all(|a| {
        ts.position[a]
            .as_ref()
            .is_none_or(|v| v.iter().all(|&p| p == pose[a]))
    })
}

/// [`simulate_as_measured_lti`] of `after` for a record whose simulation by `before` is
/// `sim_before`, where the two twins differ at the record's pose only in some modes (a
/// refit): the simulation of `before` plus the response of the modes (and feedthroughs)
/// that changed, new minus old — linear time invariance, the same response up to
/// rounding for the cost of the changed modes. Records or twins where the shortcut does
/// not hold (moving axes, cubic terms, other extensions or another model layout) are
/// simulated afresh.
pub fn resimulate_as_measured_lti(
    before: &Twin,
    after: &Twin,
    ts: &crate::timeseries::TimeSeries,
    sim_before: &[Vec<f64>; 3],
) -> crate::Result<[Vec<f64>; 3]> {
    let pose = ts.position_at(0);
    let still = stands_still(ts);
    let n = ts.len();
    let same_shape = before.extensions == after.extensions
        && before.extensions.cubic.is_empty()
        && before.channels == after.channels
        && sim_before.iter().all(|v| v.len() == n);
    if !still || !same_shape || n < 2 {
        return simulate_as_measured_lti(after, ts);
    }
    let old = TwinEvaluator::new(before)?.model_at(pose).clone();
    let new = TwinEvaluator::new(after)?.model_at(pose).clone();
    if old.modes.len() != new.modes.len() || old.channels.len() != new.channels.len() {
        return simulate_as_measured_lti(after, ts);
    }
    let changed: Vec<usize> = (0..old.modes.len())
        .filter(|&k| {
            old.modes[k] != new.modes[k]
                || old
                    .channels
                    .iter()
                    .zip(&new.channels)
                    .any(|(a, b)| a.num[k] != b.num[k])
        })
        .collect();
    // one model whose response is new minus old: the changed modes of both, the old
    // ones with their numerators negated, the feedthroughs' difference
    let diff = ModalModel {
        modes: (changed.iter().map(|&k| new.modes[k]))
            .chain(changed.iter().map(|&k| old.modes[k]))
            .collect(),
        channels: (new.channels.iter().zip(&old.channels))
            .map(|(cn, co)| crate::model::ChannelModel {
                channel: cn.channel,
                num: (changed.iter().map(|&k| cn.num[k]))
                    .chain(changed.iter().map(|&k| crate::model::ModeNum {
                        b0: -co.num[k].b0,
                        b1: -co.num[k].b1,
                    }))
                    .collect(),
                d: cn.d - co.d,
            })
            .collect(),
    };
    check_force_columns(&after.channels, ts)?;
    let f = crate::simulate::force_rows(ts);
    let mut d = crate::simulate::band_limited_lti(&diff, &f, ts.dt);
    if let Some(tau) = after.extensions.delay_s {
        d = delay(&d, tau / ts.dt);
    }
    let d = as_measured(&d, ts);
    Ok(std::array::from_fn(|a| {
        sim_before[a]
            .iter()
            .zip(&d[a])
            .map(|(s, x)| s + x)
            .collect()
    }))
}

/// Per axis x, y, z the displacement `y` or, for an accelerometer record, its second
/// derivative.
fn as_measured(y: &[[f64; 3]], ts: &crate::timeseries::TimeSeries) -> [Vec<f64>; 3] {
    let accel = ts.response_kind == Some(crate::timeseries::ResponseKind::Acceleration);
    std::array::from_fn(|a| {
        let d: Vec<f64> = y.iter().map(|r| r[a]).collect();
        if accel {
            crate::signal::second_derivative(&d, ts.dt)
        } else {
            d
        }
    })
}

/// `out[i] = y(t_i - shift·dt)` by linear interpolation (held at the ends).
fn delay(y: &[[f64; 3]], shift: f64) -> Vec<[f64; 3]> {
    let n = y.len();
    (0..n)
        .map(|i| {
            let x = (i as f64 - shift).clamp(0.0, (n - 1) as f64);
            let k = (x.floor() as usize).min(n.saturating_sub(2));
            let a = x - k as f64;
            let mut r = [0.0; 3];
            for c in 0..3 {
                r[c] = y[k][c] * (1.0 - a) + y[(k + 1).min(n - 1)][c] * a;
            }
            r
        })
        .collect()
}

/// The twin's simulation with the cubic modal stiffnesses of `cubic` summed per mode.
fn simulate_cubic(
    ev: &mut TwinEvaluator,
    forces: &[[f64; 3]],
    pose_at: &impl Fn(usize) -> [f64; 3],
    dt: f64,
    hold: Hold,
    cubic: &[crate::twin::CubicStiffness],
) -> Vec<[f64; 3]> {
    let kappa: Vec<f64> = (0..ev.n_modes())
        .map(|k| cubic.iter().filter(|c| c.mode == k).map(|c| c.kappa).sum())
        .collect();
    crate::interpolate::simulate_twin_cubic(ev, forces, pose_at, dt, hold, &kappa)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::{Axis, Channel};
    use crate::frf::Frf;
    use crate::model::{ChannelModel, ModalModel, Mode, ModeNum};
    use crate::twin::{CubicStiffness, PoseModel, Sinusoid};

    fn twin() -> Twin {
        let model = ModalModel {
            modes: vec![Mode::from_hz(50.0, 0.02)],
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num: vec![ModeNum { b0: 1.0, b1: 0.0 }],
                d: 0.0,
            }],
        };
        Twin::new(
            "t",
            vec![PoseModel {
                pose: [0.0; 3],
                model,
                frf: Frf::default(),
                band_hz: [1.0, 100.0],
                fit: vec![],
                order: Default::default(),
                sources: vec![],
                frf_exp_window_sigma: None,
                plan: None,
            }],
        )
    }

    #[test]
    fn zero_cubic_term_matches_the_linear_core_and_delay_shifts() {
        let mut t = twin();
        let dt = 1e-3;
        let f: Vec<[f64; 3]> = (0..400)
            .map(|i| [((i as f64) * 0.37).sin(), 0.0, 0.0])
            .collect();
        let lin = simulate_extended(&t, &f, |_| [0.0; 3], 0.0, dt, Hold::Foh).unwrap();
        t.extensions.cubic.push(CubicStiffness {
            mode: 0,
            kappa: 0.0,
        });
        // kappa = 0 takes the exact path too; a tiny kappa must agree closely with RK4
        t.extensions.cubic[0].kappa = 1e-30;
        let nl = simulate_extended(&t, &f, |_| [0.0; 3], 0.0, dt, Hold::Foh).unwrap();
        let scale = lin.iter().map(|r| r[0].abs()).fold(0.0, f64::max);
        for (a, b) in lin.iter().zip(&nl) {
            assert!((a[0] - b[0]).abs() < 1e-6 * scale);
        }
        t.extensions.cubic.clear();
        t.extensions.delay_s = Some(3.0 * dt);
        let del = simulate_extended(&t, &f, |_| [0.0; 3], 0.0, dt, Hold::Foh).unwrap();
        for i in 10..400 {
            assert!((del[i][0] - lin[i - 3][0]).abs() < 1e-15);
        }
        t.extensions.delay_s = None;
        t.extensions.disturbance.push(Sinusoid {
            freq_hz: 10.0,
            axis: Axis::X,
            a: 1.0,
            b: 0.0,
        });
        let dis = simulate_extended(&t, &f, |_| [0.0; 3], 0.0, dt, Hold::Foh).unwrap();
        assert!((dis[25][0] - lin[25][0] - (2.0 * PI * 10.0 * 0.025).cos()).abs() < 1e-12);
    }

    #[test]
    fn hardening_raises_the_free_vibration_frequency() {
        let mut t = twin();
        let dt = 1e-4;
        // a strong impulse, then free vibration: count zero crossings
        let mut f = vec![[0.0; 3]; 20000];
        f[1] = [5e6, 0.0, 0.0];
        let crossings = |y: &[[f64; 3]]| y.windows(2).filter(|w| w[0][0] * w[1][0] < 0.0).count();
        let lin = simulate_extended(&t, &f, |_| [0.0; 3], 0.0, dt, Hold::Foh).unwrap();
        t.extensions.cubic.push(CubicStiffness {
            mode: 0,
            kappa: 1.0,
        });
        let hard = simulate_extended(&t, &f, |_| [0.0; 3], 0.0, dt, Hold::Foh).unwrap();
        assert!(
            crossings(&hard) > crossings(&lin),
            "{} vs {}",
            crossings(&hard),
            crossings(&lin)
        );
    }
}
