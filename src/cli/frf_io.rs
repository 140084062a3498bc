//! The command line's options for measured FRF inputs; reading, format detection and
//! writing are the library's (`identify::io::measured`).

use super::parse_pose;
use anyhow::Result;
use identify::campaign::MeasuredFrf;
use identify::io::measured::{read_frf_file, ReadOptions};
use identify::plan::MeasuredAs;
use std::path::Path;

/// Options for reading measured FRFs (UFF selection, pose).
#[derive(Debug, Clone, clap::Args)]
pub struct FrfInputArgs {
    /// Pose X,Y,Z in metres of FRF inputs (UFF or FRF CSV) that do not carry one; an FRF CSV
    /// may carry it as a comment `# pose=X,Y,Z`. Default 0,0,0.
    #[arg(long, value_parser = parse_pose, allow_hyphen_values = true)]
    pub pose: Option<[f64; 3]>,
    /// UFF input: use only FRFs with this reference (excitation) node.
    #[arg(long)]
    pub uff_ref: Option<i64>,
    /// UFF input: use only FRFs with this response node.
    #[arg(long)]
    pub uff_resp: Option<i64>,
    /// UFF input: what the ordinate is when the file leaves it unknown
    /// (accel, vel, disp).
    #[arg(long, value_parser = ["accel", "vel", "disp"])]
    pub uff_ordinate: Option<String>,
}

impl FrfInputArgs {
    /// The library's reading options.
    pub fn read_options(&self) -> ReadOptions {
        ReadOptions {
            pose: self.pose,
            uff_ref: self.uff_ref,
            uff_resp: self.uff_resp,
            uff_ordinate: self.uff_ordinate.as_deref().map(|o| match o {
                "accel" => MeasuredAs::Accelerance,
                "vel" => MeasuredAs::Mobility,
                _ => MeasuredAs::Receptance,
            }),
        }
    }
}

/// Reads one measured FRF file (UFF or FRF CSV) as one pose.
pub fn read_measured(path: &Path, a: &FrfInputArgs) -> Result<MeasuredFrf> {
    let file = read_frf_file(path, &a.read_options())?;
    Ok(MeasuredFrf::from_file(path, file))
}
