//! `simulate_twin` (the core of `mtwin simulate` and the FMU) against the virtual machine
//! at MOVING axes: the twin built from the machine's exact models at a 3×3×2 grid, the
//! record simulated by the machine at 8× the rate with the axes travelling through the
//! workspace and recorded through the anti-alias filter; the twin's prediction from the
//! recorded forces and positions matches the recorded displacement.

use identify::axis::Axis;
use identify::frf::fit_percent_real;
use identify::interpolate::{simulate_twin, TwinEvaluator};
use identify::simulate::{force_rows, Hold};
use identify::timeseries::ResponseKind;
use vmachine::daq::{acquire, simulate_machine, Daq};
use vmachine::excitation::noise;
use vmachine::structure::ModalMachine;

#[test]
fn twin_simulation_follows_the_machine_while_the_axes_move() {
    let m = ModalMachine::default_machine();
    let axes = [Axis::X, Axis::Y];
    let twin = m.exact_twin([3, 3, 2], &axes);
    let daq = Daq {
        force_noise: 0.0,
        response_noise: 0.0,
        response: ResponseKind::Displacement,
        ..Daq::default()
    };
    let fs = daq.fs_sim();
    let dur = 2.0;
    let n = (dur * fs) as usize;
    // band-limited force (the anti-alias filter keeps it below 2560 Hz)
    let forces = [Some(noise(n, 100.0, 3)), Some(noise(n, 100.0, 4)), None];
    // the axes travel diagonally through the workspace, 0.25 m/s in x and y
    let path = |t: f64| [0.05 + 0.25 * t, 0.55 - 0.25 * t, 0.1 + 0.1 * t];
    let resp = simulate_machine(&m, &forces, fs, &path, &axes, ResponseKind::Displacement);
    // (1) at the simulation rate: the twin's interpolation against the machine's own
    // pose dependence, the state carried across pose changes
    let mut ev = TwinEvaluator::new(&twin).unwrap();
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| [0, 1, 2].map(|a| forces[a].as_ref().map_or(0.0, |f| f[i])))
        .collect();
    let y_hi = simulate_twin(&mut ev, &rows, |i| path(i as f64 / fs), 1.0 / fs, Hold::Foh);
    for a in axes {
        let meas = resp[a.index()].as_ref().unwrap();
        let sim: Vec<f64> = y_hi.iter().map(|r| r[a.index()]).collect();
        let fit = fit_percent_real(meas, &sim);
        eprintln!("simulation rate d{a}: {fit:.5} %");
        assert!(fit > 99.99, "d{a}: {fit}");
    }
    // (2) through the DAQ (anti-alias filter, decimation to 6400 Hz): the twin on the
    // recorded samples; first-order hold between samples is the only approximation
    let ts = acquire(forces, resp, &path, &daq, "moving");
    let f = force_rows(&ts);
    let y = simulate_twin(&mut ev, &f, |i| ts.position_at(i), ts.dt, Hold::Foh);
    for a in axes {
        let meas = ts.response(a).unwrap();
        let sim: Vec<f64> = y.iter().map(|r| r[a.index()]).collect();
        // skip the filter's edge at the start
        let fit = fit_percent_real(&meas[200..], &sim[200..]);
        eprintln!("d{a}: {fit:.3} %");
        assert!(fit > 98.0, "d{a}: {fit}");
    }
}
