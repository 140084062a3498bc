//! Write a complete data set of the lumped machine:
//!
//! ```sh
//! cargo run --release -p lumped --example dump -- --out DIR [--seed N] [--random-machine]
//! ```
//!
//! DIR/campaign (impact tests on a 3×3×2 grid), sweep_centre_x.csv, truth/ (analytic
//! receptances and machine.json), worn_milling/, diagnose/<effect>/ with answers.json,
//! and a README.md describing it. Seed 1 and the nominal machine unless told otherwise.

use lumped::effects::{visible, write_diagnosis_material};
use lumped::excitation::Milling;
use lumped::frf::linspace;
use lumped::measure::{impact_record, log_sweep_record, milling_clean, milling_comments, Setup};
use lumped::modal::pair_modes;
use lumped::record::write_atomic;
use lumped::structure::{Joint, Machine, Pose, CENTRE};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

const AXN: [&str; 3] = ["x", "y", "z"];
const GRID_X: [f64; 3] = [0.1, 0.4, 0.7];
const GRID_Y: [f64; 3] = [0.1, 0.3, 0.5];
const GRID_Z: [f64; 2] = [0.05, 0.25];
const UNMEASURED: [Pose; 3] = [[0.25, 0.2, 0.15], [0.55, 0.45, 0.1], [0.6, 0.15, 0.2]];

fn grid() -> Vec<Pose> {
    let mut g = Vec::new();
    for x in GRID_X {
        for y in GRID_Y {
            for z in GRID_Z {
                g.push([x, y, z]);
            }
        }
    }
    g
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut out = None;
    let mut seed = 1u64;
    let mut random = false;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--out" if i + 1 < args.len() => {
                out = Some(PathBuf::from(&args[i + 1]));
                i += 1;
            }
            "--seed" if i + 1 < args.len() => match args[i + 1].parse() {
                Ok(s) => {
                    seed = s;
                    i += 1;
                }
                Err(_) => {
                    eprintln!("--seed needs a whole number, got {:?}", args[i + 1]);
                    return ExitCode::from(2);
                }
            },
            "--random-machine" => random = true,
            "--help" | "-h" => {
                println!("usage: dump --out DIR [--seed N] [--random-machine]");
                return ExitCode::SUCCESS;
            }
            other => {
                eprintln!("unknown argument {other:?}; usage: dump --out DIR [--seed N] [--random-machine]");
                return ExitCode::from(2);
            }
        }
        i += 1;
    }
    let Some(out) = out else {
        eprintln!("missing --out DIR; usage: dump --out DIR [--seed N] [--random-machine]");
        return ExitCode::from(2);
    };
    match dump(&out, seed, random) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn dump(out: &Path, seed: u64, random: bool) -> Result<(), lumped::Error> {
    let t0 = Instant::now();
    let machine = if random {
        Machine::random(seed)
    } else {
        Machine::nominal()
    };
    let mut rng = StdRng::seed_from_u64(seed);
    let g = grid();

    // campaign: hammer along x and y, 5 hits, accelerations
    let setup = Setup::impact();
    let jobs: Vec<(usize, usize)> = (0..g.len()).flat_map(|k| [(k, 0), (k, 1)]).collect();
    jobs.par_iter()
        .map(|&(k, a)| {
            let r = impact_record(
                &machine,
                &setup,
                g[k],
                a,
                5,
                2.0,
                seed * 1000 + 2 * k as u64 + a as u64,
            );
            r.write_csv(&out.join(format!("campaign/g{k:02}_{}.csv", ["x", "y"][a])))
        })
        .collect::<Result<Vec<()>, _>>()?;
    eprintln!(
        "campaign: {} records, {:.1} s",
        jobs.len(),
        t0.elapsed().as_secs_f64()
    );

    // logarithmic sweep at the centre, displacement
    let disp = Setup::displacement();
    log_sweep_record(&machine, CENTRE, seed * 1000 + 500)
        .write_csv(&out.join("sweep_centre_x.csv"))?;
    eprintln!("sweep: {:.1} s", t0.elapsed().as_secs_f64());

    // truth
    let freqs = linspace(20.0, 3000.0, 1000);
    let acc_note = format!(
        "with the {} kg accelerometer of the campaign at the tool tip",
        setup.tip_mass
    );
    for (k, p) in g.iter().enumerate() {
        machine
            .analytic_frf(*p, &freqs)
            .write_csv(&out.join(format!("truth/g{k:02}.csv")), &[])?;
        machine
            .analytic_frf_loaded(*p, &freqs, setup.tip_mass)
            .write_csv(
                &out.join(format!("truth/g{k:02}_loaded.csv")),
                std::slice::from_ref(&acc_note),
            )?;
    }
    for (k, p) in UNMEASURED.iter().enumerate() {
        machine.analytic_frf(*p, &freqs).write_csv(
            &out.join(format!("truth/u{k}.csv")),
            &["unmeasured pose".into()],
        )?;
        machine
            .analytic_frf_loaded(*p, &freqs, setup.tip_mass)
            .write_csv(
                &out.join(format!("truth/u{k}_loaded.csv")),
                &["unmeasured pose".into(), acc_note.clone()],
            )?;
    }
    machine
        .analytic_frf(CENTRE, &freqs)
        .write_csv(&out.join("truth/centre.csv"), &[])?;
    machine
        .analytic_frf_loaded(CENTRE, &freqs, setup.tip_mass)
        .write_csv(&out.join("truth/centre_loaded.csv"), &[acc_note])?;

    // wear: the front bearing loses preload
    let factor = rng.gen_range(0.6..0.8);
    let worn = machine
        .clone()
        .with_joint_stiffness(Joint::FrontBearing, factor);
    let before = machine.modes(CENTRE);
    let after = worn.modes(CENTRE);
    let vis = visible(&before, 0.05);
    let (wi, wk) = pair_modes(&before, &after)
        .into_iter()
        .filter(|p| vis.contains(&p.0))
        .max_by(|a, b| {
            let da = (after[a.1].freq_hz / before[a.0].freq_hz - 1.0).abs();
            let db = (after[b.1].freq_hz / before[b.0].freq_hz - 1.0).abs();
            da.total_cmp(&db)
        })
        .map(|p| (p.0, p.1))
        .unwrap_or((0, 0));
    worn.analytic_frf(CENTRE, &freqs).write_csv(
        &out.join("truth/centre_worn.csv"),
        &[format!("worn: front bearing stiffness x{factor:.3}")],
    )?;
    let speeds = [6900.0, 7800.0, 8700.0];
    speeds
        .par_iter()
        .enumerate()
        .map(|(k, &rpm)| {
            let mut r = StdRng::seed_from_u64(seed * 1000 + 600 + k as u64);
            let m = Milling::random(rpm, 1.5e-3, &mut r);
            let mut start = CENTRE;
            start[0] -= m.feed_speed() * 1.5;
            let c = milling_clean(&worn, &disp, &m, start, 3.0);
            let rec = c.into_record(&disp, seed * 1000 + 610 + k as u64, milling_comments(&m));
            rec.write_csv(&out.join(format!("worn_milling/mill_{}.csv", rpm as i64)))
        })
        .collect::<Result<Vec<()>, _>>()?;
    eprintln!("worn milling: {:.1} s", t0.elapsed().as_secs_f64());

    let modes: Vec<_> = before
        .iter()
        .enumerate()
        .filter(|(i, _)| vis.contains(i))
        .map(|(_, m)| {
            json!({
                "f0": m.freq_hz, "zeta": m.zeta, "axis": AXN[m.axis()],
                "peak_m_per_n": m.peak(), "complexity": m.complexity,
            })
        })
        .collect();
    let info = json!({
        "generator": "lumped",
        "seed": seed,
        "random_machine": random,
        "grid": g,
        "unmeasured": UNMEASURED,
        "centre": CENTRE,
        "modes": modes,
        "wear": {
            "joint": "front_bearing",
            "stiffness_factor": factor,
            "mode_f0_hz": before[wi].freq_hz,
            "new_f0_hz": after[wk].freq_hz,
            "axis": AXN[before[wi].axis()],
        },
        "machine": machine,
    });
    write_atomic(
        &out.join("truth/machine.json"),
        &serde_json::to_string_pretty(&info).unwrap_or_default(),
    )?;

    // a healthy impact test at the centre (where the hidden effects are): a one-pose twin
    // to judge the detectors on, apart from the campaign's interpolation; the hidden effects
    write_diagnosis_material(out, &machine, seed)?;
    write_atomic(&out.join("README.md"), &readme(seed, random, factor))?;
    eprintln!("done in {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

fn readme(seed: u64, random: bool, factor: f64) -> String {
    format!(
        "# lumped data set (seed {seed}{})

Made by the `lumped` crate: a lumped-mass bridge mill (bed, table, portal, cross-rail,
saddle, ram, spindle, tool; springs and dashpots at guide carriages, ball screws, bolted
joints, bearings, holder interface). Modes, damping, cross coupling and their pose
dependence come out of the structure. Simulated at 8x the sample rate (exact
discretisation), one anti-alias FIR, decimated; white + 1/f noise and 24-bit
quantisation on force and response. Responses are tool - workpiece (relative).

| path | what |
|---|---|
| `campaign/gNN_{{x,y}}.csv` | impact tests at 18 poses (x 0.1/0.4/0.7, y 0.1/0.3/0.5, z 0.05/0.25 m), hammer along x or y, 5 hits, 10240 Hz, accelerations (12 g accelerometer at the tool tip) |
| `sweep_centre_x.csv` | shaker, logarithmic sweep 20-2500 Hz along x in 8 s then 1.5 s rest, at the centre (0.4, 0.3, 0.15), displacement |
| `worn_milling/mill_*.csv` | down-milling at the centre, feed along x (axes move), front bearing stiffness x{factor:.3} |
| `centre_impact/imp_{{x,y}}.csv` | healthy impact test at the centre (5 hits each): a one-pose twin for the diagnose cases |
| `diagnose/<case>/` + `diagnose/answers.json` | one hidden effect per folder at the centre and the expected diagnosis (docs/formats.md, Diagnosis output); `healthy` (milling) and `healthy_impact` (hits at 60, 300 and 1200 N on the machine without the nonlinearity case's spring) expect `none` |
| `truth/gNN.csv`, `truth/u0..u2.csv` | analytic receptance (m/N), 9 channels, 20-3000 Hz, at the measured and 3 unmeasured poses |
| `truth/gNN_loaded.csv`, `truth/uN_loaded.csv` | the same with the campaign's accelerometer mass at the tool tip (what the impact data can show) |
| `truth/centre.csv`, `truth/centre_loaded.csv`, `truth/centre_worn.csv` | at the centre: as is, with the accelerometer mass, worn |
| `truth/machine.json` | grid, poses, visible modes at the centre, the wear, all machine parameters |
",
        if random { ", random machine" } else { ", nominal machine" }
    )
}
