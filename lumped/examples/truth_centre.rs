//! Write the nominal machine's analytic receptance at the centre pose, as it is and with
//! the impact campaign's accelerometer at the tool tip, on a fine grid (for comparing a
//! one-pose twin of `cases` with the truth):
//!
//! ```sh
//! cargo run --release -p lumped --example truth_centre -- DIR
//! ```
use lumped::frf::linspace;
use lumped::measure::Setup;
use lumped::structure::{Machine, CENTRE};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).ok_or("usage: truth_centre DIR")?);
    std::fs::create_dir_all(&out)?;
    let machine = Machine::nominal();
    let freqs = linspace(20.0, 3000.0, 5961);
    let tip = Setup::impact().tip_mass;
    machine
        .analytic_frf(CENTRE, &freqs)
        .write_csv(&out.join("centre.csv"), &[])?;
    machine.analytic_frf_loaded(CENTRE, &freqs, tip).write_csv(
        &out.join("centre_loaded.csv"),
        &[format!("sensor_mass={tip}")],
    )?;
    Ok(())
}
