//! Writes the data the Python FMU tests start from (generated on the virtual machine):
//! a 2×2×1 impact campaign (hammer along x and y) and a record with forces and MOVING
//! axes for comparing the FMU with `mtwin simulate`.
//!
//! Run: `cargo run --release --example fmu_fixture -- OUTDIR`

use identify::axis::Axis;
use identify::read::write_timeseries;
use vmachine::daq::{impact_record, Daq};
use vmachine::excitation::noise;
use vmachine::structure::ModalMachine;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: fmu_fixture OUTDIR")?);
    std::fs::create_dir_all(dir.join("campaign"))?;
    let machine = ModalMachine::default_machine();
    let daq = Daq::default();
    let axes = [Axis::X, Axis::Y];
    for (i, p) in machine.grid([2, 2, 1]).iter().enumerate() {
        for a in axes {
            let ts = impact_record(&machine, *p, a, &axes, 3, &daq, 40 + i as u64);
            write_timeseries(&dir.join(format!("campaign/pose{i}_{a}.csv")), &ts)?;
        }
    }
    // forces and moving axes, 0.5 s at 6400 Hz
    let n = 3200;
    let dt = 1.0 / daq.fs;
    let fx = noise(n, 50.0, 1);
    let fy = noise(n, 50.0, 2);
    let mut text = String::from("# forces and moving axes for the FMU tests\nt,fx,fy,x,y,z\n");
    for i in 0..n {
        let t = i as f64 * dt;
        let x = 0.3 + 0.25 * (2.0 * std::f64::consts::PI * 1.0 * t).sin();
        let y = 0.1 + 0.8 * t;
        text.push_str(&format!("{t},{},{},{x},{y},0.2\n", fx[i], fy[i]));
    }
    std::fs::write(dir.join("moving.csv"), text)?;
    println!("{}", dir.display());
    Ok(())
}
