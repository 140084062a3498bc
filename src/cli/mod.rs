//! Argument definitions and dispatch.

mod cosim;
mod demo;
mod diagnose;
mod eval;
mod export;
mod frf;
mod frf_io;
mod identify_cmd;
mod lobes;
mod refit;
mod simulate;
mod warnings;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};

/// mtwin — a lifetime-adaptive digital twin of a machine tool's tool-center-point
/// dynamics, identified from impact/chirp tests, refitted from operating data and
/// exported as an FMI 2.0 (or 3.0) co-simulation FMU.
#[derive(Debug, Parser)]
#[command(name = "mtwin", version, about, long_about = None)]
pub struct Cli {
    /// Print nothing but errors.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Print the summary as JSON on stdout (with every warning).
    #[arg(long, global = true)]
    pub json: bool,
    /// Print every warning; by default warnings that differ only by pose, file or
    /// numbers are said once, with how many records and poses they concern.
    #[arg(long, short, global = true)]
    pub verbose: bool,
    #[command(subcommand)]
    pub cmd: Cmd,
}

/// The commands (file formats: docs/formats.md).
#[derive(Debug, Subcommand)]
pub enum Cmd {
    /// The whole mission on the built-in virtual machine, no input needed: campaign,
    /// twin, wear and milling, refit, diagnosis, FMUs, lobes, report.
    ///
    /// Example: mtwin demo --out mtwin-demo
    Demo(demo::Args),
    /// FRF estimate (H1 by default) and coherence from force/response time series.
    ///
    /// Example: mtwin frf impact_x.csv impact_y.csv --out frf.csv   (or --out frf.uff for
    /// Universal File Format dataset 58)
    Frf(frf::Args),
    /// The a-priori twin from a measurement campaign (one or more poses).
    ///
    /// Example: mtwin identify campaign/*.csv --out twin.json
    ///
    /// From measured FRFs: mtwin identify meas.uff --uff-ref 1 --pose 0.2,0.1,0 --out twin.json
    Identify(identify_cmd::Args),
    /// The twin's FRF at any pose (interpolated between measured poses).
    ///
    /// Example: mtwin eval --twin twin.json --at 0.2,0.1,0.05 --out frf.csv
    Eval(eval::Args),
    /// Predicted TCP displacement for the forces and axis positions in a data file.
    ///
    /// Example: mtwin simulate --twin twin.json cut.csv --out pred.csv
    Simulate(simulate::Args),
    /// Lifetime update from operating data; keeps the whole history in the twin file.
    ///
    /// Example: mtwin refit --twin twin.json cut1.csv --out twin2.json --fmu twin2.fmu --report refit.html
    Refit(refit::Args),
    /// What the twin gets wrong on measured data, the named cause, the extended model and
    /// the measured gain on held-out data.
    ///
    /// Example: mtwin diagnose --twin twin.json test.csv --out diag/
    Diagnose(diagnose::Args),
    /// FMI 2.0 co-simulation FMU of the twin (`--fmi 3`: FMI 3.0).
    ///
    /// Example: mtwin export --twin twin.json --out machine.fmu [--fmi 3]
    Export(export::Args),
    /// Milling stability lobes from the twin's tool-tip FRF at a pose: zero-order
    /// (Altintas–Budak) and semi-discretisation (Insperger–Stépán).
    ///
    /// Example: mtwin lobes --twin twin.json --at 0.3,0.2,0.1 --teeth 3 --immersion 0.5 --out lobes.csv --plot lobes.svg
    Lobes(lobes::Args),
    /// The regenerative milling process as its own FMI 2.0 co-simulation FMU (inputs dx,
    /// dy from the twin FMU; outputs Fx, Fy for it; the delay line inside).
    ///
    /// Example: mtwin process-fmu --teeth 3 --rpm 8000 --ap 0.002 --out cut.fmu
    ProcessFmu(cosim::FmuArgs),
    /// An SSP package (System Structure and Parameterization 1.0) wiring the twin FMU
    /// to the process FMU at a pose: SystemStructure.ssd with both FMUs inside.
    ///
    /// Example: mtwin ssp --twin twin.json --at 0.3,0.3,0.2 --rpm 7560 --ap 0.001 --out milling.ssp
    Ssp(cosim::SspArgs),
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let out = Output {
        quiet: cli.quiet,
        json: cli.json,
        verbose: cli.verbose,
    };
    match cli.cmd {
        Cmd::Demo(a) => demo::run(a, &out),
        Cmd::Frf(mut a) => {
            a.files = expand_folders(&a.files)?;
            frf::run(a, &out)
        }
        Cmd::Identify(mut a) => {
            a.files = expand_folders(&a.files)?;
            identify_cmd::run(a, &out)
        }
        Cmd::Eval(a) => eval::run(a, &out),
        Cmd::Simulate(a) => simulate::run(a, &out),
        Cmd::Refit(mut a) => {
            a.files = expand_folders(&a.files)?;
            refit::run(a, &out)
        }
        Cmd::Diagnose(mut a) => {
            a.files = expand_folders(&a.files)?;
            diagnose::run(a, &out)
        }
        Cmd::Export(a) => export::run(a, &out),
        Cmd::Lobes(a) => lobes::run(a, &out),
        Cmd::ProcessFmu(a) => cosim::run_fmu(a, &out),
        Cmd::Ssp(a) => cosim::run_ssp(a, &out),
    }
}

/// Input files with each folder replaced by the data files in it (`*.csv`, `*.uff`,
/// `*.unv`, sorted by name; not recursive), so `mtwin identify campaign/` reads a
/// campaign folder. A folder without such files is an error that names it.
pub fn expand_folders(files: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for f in files {
        if !f.is_dir() {
            out.push(f.clone());
            continue;
        }
        let mut inside: Vec<PathBuf> = std::fs::read_dir(f)
            .with_context(|| format!("{}: cannot list the folder", f.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.is_file()
                    && p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                        ["csv", "uff", "unv"].contains(&e.to_ascii_lowercase().as_str())
                    })
            })
            .collect();
        if inside.is_empty() {
            return Err(BadInput(format!(
                "{}: a folder without data files (*.csv, *.uff, *.unv)",
                f.display()
            ))
            .into());
        }
        inside.sort();
        out.extend(inside);
    }
    Ok(out)
}

/// How to print.
#[derive(Debug, Clone, Copy)]
pub struct Output {
    /// Errors only.
    pub quiet: bool,
    /// JSON summary on stdout.
    pub json: bool,
    /// Every warning, not a summary per kind.
    pub verbose: bool,
}

impl Output {
    /// A human line on stderr unless quiet or JSON.
    pub fn say(&self, msg: impl AsRef<str>) {
        if !self.quiet && !self.json {
            eprintln!("{}", msg.as_ref());
        }
    }

    /// Warnings on stderr unless quiet or JSON: each one with `--verbose`, else those
    /// that differ only by pose, file or numbers said once (see [`warnings::summarise`]).
    pub fn warnings(&self, warnings: &[String]) {
        if self.quiet || self.json {
            return;
        }
        for line in warnings::summarise(warnings, self.verbose) {
            eprintln!("{line}");
        }
    }

    /// The JSON summary on stdout when `--json`.
    pub fn json(&self, v: &serde_json::Value) {
        if self.json {
            println!("{}", serde_json::to_string_pretty(v).unwrap_or_default());
        }
    }
}

/// Marks an error as the user's input (exit code 2).
#[derive(Debug)]
pub struct BadInput(pub String);

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// The error and its causes, each said once: a cause whose text the message already
/// holds (an I/O error the message quotes) is not repeated.
pub fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for c in e.chain() {
        let s = c.to_string();
        if text.contains(&s) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&s);
    }
    text
}

/// True when the error chain holds a bad-input error.
pub fn is_bad_input(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<BadInput>().is_some()
            || c.downcast_ref::<identify::Error>()
                .is_some_and(identify::Error::is_bad_input)
    })
}

/// Refuses to overwrite one of the inputs with an output.
pub fn check_output_not_input(out: &Path, inputs: &[PathBuf]) -> Result<()> {
    let canon = |p: &Path| std::fs::canonicalize(p).ok();
    if let Some(o) = canon(out) {
        if inputs
            .iter()
            .any(|i| canon(i).as_deref() == Some(o.as_path()))
        {
            return Err(BadInput(format!(
                "{}: the output would overwrite an input file; choose another --out",
                out.display()
            ))
            .into());
        }
    }
    Ok(())
}

pub use identify::axis::parse_pose;

/// The twin file and the pose where it is evaluated (`eval`, `lobes`, `cosim`).
#[derive(Debug, Clone, clap::Args)]
pub struct TwinAt {
    /// The twin file.
    #[arg(long)]
    pub twin: PathBuf,
    /// Pose X,Y,Z in metres where the twin is evaluated (the tool-tip FRF; for `cosim`
    /// the twin FMU's start x, y, z).
    #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
    pub at: [f64; 3],
}

impl TwinAt {
    /// The twin, after checking that `out` would not overwrite the twin file.
    pub fn load(&self, out: &Path) -> Result<identify::twin::Twin> {
        check_output_not_input(out, std::slice::from_ref(&self.twin))?;
        Ok(identify::twin::Twin::load(&self.twin)?)
    }
}

/// Reads time-series files in parallel, printing reader warnings (summarised, see
/// [`Output::warnings`]).
pub fn read_series(
    files: &[PathBuf],
    out: &Output,
) -> Result<Vec<identify::timeseries::TimeSeries>> {
    use rayon::prelude::*;
    let res: Vec<identify::Result<(identify::timeseries::TimeSeries, Vec<String>)>> = files
        .par_iter()
        .map(|f| identify::read::read_timeseries_with_warnings(f))
        .collect();
    let mut series = Vec::with_capacity(res.len());
    let mut warnings = Vec::new();
    for r in res {
        let (ts, warns) = r?;
        warnings.extend(warns.into_iter().map(|w| format!("{}: {w}", ts.source)));
        series.push(ts);
    }
    out.warnings(&warnings);
    Ok(series)
}
