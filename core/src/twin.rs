//! The twin file: a versioned JSON document holding every pose's model, the FRFs kept
//! for later refits, interpolation settings, and an append-only history.
//!
//! Schema `mtwin-twin`, version [`TWIN_VERSION`]; documented in the README. Loading a
//! file of another schema or version fails with a message that says what to do.

use crate::atomic::write_atomic;
use crate::axis::Channel;
use crate::error::{Error, Result};
use crate::frf::Frf;
use crate::model::ModalModel;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Schema name written into every twin file.
pub const TWIN_SCHEMA: &str = "mtwin-twin";
/// Schema version this library writes and reads.
pub const TWIN_VERSION: u32 = 1;

/// Units of every quantity in the file (fixed; written for readers of the JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Units {
    /// Frequency unit of FRF grids.
    pub frequency: String,
    /// Receptance unit of FRF values and model outputs.
    pub receptance: String,
    /// Natural frequencies in the models.
    pub natural_frequency: String,
    /// Axis positions.
    pub position: String,
}

impl Default for Units {
    fn default() -> Self {
        Units {
            frequency: "Hz".into(),
            receptance: "m/N".into(),
            natural_frequency: "rad/s (wn)".into(),
            position: "m".into(),
        }
    }
}

/// Fit of one channel of a pose model against its FRF.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelFit {
    /// The channel.
    pub channel: Channel,
    /// Fit in percent (paper's equation 5) within the fitted band; `-inf` when the
    /// measured channel is constant (the metric is undefined). JSON has no infinity:
    /// `-inf` is written as `null` and `null` reads back as `-inf`.
    #[serde(deserialize_with = "fit_or_null")]
    pub fit_pct: f64,
    /// The fit the noise of the measured FRF allows (from its coherence and number of
    /// averages): what the noise-free truth itself would score against this data. A model
    /// near it fits as well as the data can tell, however low both are (a cross channel
    /// that carries mostly noise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_limit_pct: Option<f64>,
    /// The model's fit to the noise-free FRF, estimated from the misfit and the noise
    /// (`100 (1 − √(max(0, misfit² − noise²)) / √(scatter² − noise²))`, all summed over
    /// the band's lines; 100 % when the misfit is all noise): how well the model matches
    /// what the data measure, which a noisy channel's `fit_pct` cannot show.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_free_fit_pct: Option<f64>,
    /// The band \[Hz\] this channel was judged in, when narrower than the pose band (a
    /// channel whose coherence is trustworthy only in part of it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band_hz: Option<[f64; 2]>,
}

/// A fit percentage, `null` (how serde_json writes a non-finite number) read as `-inf`.
fn fit_or_null<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NEG_INFINITY))
}

/// How the model order of a pose was chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct OrderInfo {
    /// Number of modes (pole pairs) of the model.
    pub modes: usize,
    /// True when chosen from the stabilization diagram, false when forced (`--order`).
    pub automatic: bool,
    /// Stable natural frequencies \[Hz\] found in the stabilization diagram.
    #[serde(default)]
    pub stable_freqs_hz: Vec<f64>,
}

/// The model identified at one measured pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseModel {
    /// Axis positions x, y, z \[m\].
    pub pose: [f64; 3],
    /// The modal model (all channels measured at this pose).
    pub model: ModalModel,
    /// The FRF the model was fitted to (kept for refits).
    pub frf: Frf,
    /// Band \[Hz\] the fit used.
    pub band_hz: [f64; 2],
    /// Fit per channel.
    pub fit: Vec<ChannelFit>,
    /// Order selection.
    pub order: OrderInfo,
    /// Data files it came from.
    #[serde(default)]
    pub sources: Vec<String>,
    /// Damping σ \[1/s\] an exponential window added to `frf` (the model is corrected
    /// for it; the stored FRF is as windowed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frf_exp_window_sigma: Option<f64>,
    /// The automatic decisions behind this pose's model (band, channels, excitation,
    /// alternatives tried, quality warnings) with their evidence.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan: Option<crate::plan::PosePlan>,
}

/// A sinusoidal vibration from outside the machine, added to the response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sinusoid {
    /// Frequency \[Hz\].
    pub freq_hz: f64,
    /// Response axis it appears on.
    pub axis: crate::axis::Axis,
    /// Cosine amplitude \[m\] (response = a cos(2πft) + b sin(2πft)).
    pub a: f64,
    /// Sine amplitude \[m\].
    pub b: f64,
}

/// A cubic stiffness on one tracked mode: `q̈ + 2ζω q̇ + ω² q (1 + κ q²) = F`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CubicStiffness {
    /// Index of the tracked mode.
    pub mode: usize,
    /// κ [1/(modal coordinate)²]; > 0 hardening, < 0 softening.
    pub kappa: f64,
}

/// Model extensions beyond the linear modal twin (added by `diagnose`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Extensions {
    /// Constant delay \[s\] of the response behind the force (positive = response lags).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_s: Option<f64>,
    /// External vibrations added to the response.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub disturbance: Vec<Sinusoid>,
    /// Nonlinear stiffness terms.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cubic: Vec<CubicStiffness>,
}

impl Extensions {
    /// True when the twin is purely linear time-invariant.
    pub fn is_empty(&self) -> bool {
        self.delay_s.is_none() && self.disturbance.is_empty() && self.cubic.is_empty()
    }
}

/// Leave-one-pose-out accuracy of the interpolation at one measured pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LooEntry {
    /// The pose left out.
    pub pose: [f64; 3],
    /// Fit of the model interpolated from the other poses against this pose's FRF.
    pub fit: Vec<ChannelFit>,
}

/// How the twin interpolates between poses, and how well.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InterpolationInfo {
    /// `single`, `tensor_grid` or `rbf` (see `interpolate`).
    pub method: String,
    /// What happens outside the measured box.
    pub extrapolation: String,
    /// Quantities interpolated.
    pub parameters: String,
    /// Leave-one-pose-out figures (empty with fewer than 3 poses).
    #[serde(default)]
    pub leave_one_out: Vec<LooEntry>,
    /// How the leave-one-out models were interpolated.
    #[serde(default)]
    pub leave_one_out_method: String,
}

impl Default for InterpolationInfo {
    fn default() -> Self {
        InterpolationInfo {
            method: "single".into(),
            extrapolation: "clamped to the measured box on each axis".into(),
            parameters: "tracked modes: wn linear, ln(zeta) linear, b0/b1/d linear".into(),
            leave_one_out: Vec::new(),
            leave_one_out_method: String::new(),
        }
    }
}

/// One entry of the append-only history.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryEntry {
    /// Seconds since the Unix epoch when the entry was made.
    pub unix_time: u64,
    /// What happened: `identify`, `refit`, `extend`, ...
    pub kind: String,
    /// Data files used.
    #[serde(default)]
    pub files: Vec<String>,
    /// What changed, in words.
    pub summary: String,
    /// Numbers worth keeping (fits, drift figures ...).
    #[serde(default)]
    pub figures: serde_json::Map<String, serde_json::Value>,
    /// The pose models as they were BEFORE this entry's change (empty for `identify`),
    /// so no earlier model is ever lost.
    #[serde(default)]
    pub previous_poses: Vec<PoseModel>,
}

/// Where the twin came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Provenance {
    /// Tool and version that wrote the file.
    pub tool: String,
    /// Command line or API call that produced it.
    #[serde(default)]
    pub command: String,
}

/// The schema name and version a twin file must carry.
fn check_schema(schema: Option<&str>, version: u64, path: &Path) -> Result<()> {
    if schema != Some(TWIN_SCHEMA) {
        return Err(Error::Schema {
            file: path.into(),
            msg: format!(
                "not an mtwin twin file (field \"schema\" is {}, expected \"{TWIN_SCHEMA}\"); \
                 create one with `mtwin identify DATA.csv --out TWIN.json`",
                schema
                    .map(|s| format!("\"{s}\""))
                    .unwrap_or("missing".into())
            ),
        });
    }
    if version > TWIN_VERSION as u64 {
        return Err(Error::Schema {
            file: path.into(),
            msg: format!(
                "twin schema version {version} was written by a newer mtwin; this mtwin \
                 ({}) reads up to version {TWIN_VERSION}: upgrade mtwin",
                env!("CARGO_PKG_VERSION")
            ),
        });
    }
    if version < 1 {
        return Err(Error::Schema {
            file: path.into(),
            msg: format!(
                "twin schema version {version} is not supported (this mtwin reads version \
                 {TWIN_VERSION}); re-identify the twin from its data"
            ),
        });
    }
    Ok(())
}

/// A digital twin of the TCP dynamics over the workspace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Twin {
    /// Always [`TWIN_SCHEMA`].
    pub schema: String,
    /// Always [`TWIN_VERSION`] when written by this library.
    pub version: u32,
    /// Units of the numbers in the file.
    pub units: Units,
    /// Free name of the machine.
    pub name: String,
    /// Channels the twin models (e.g. `xx`, `yy`, `yx`).
    pub channels: Vec<Channel>,
    /// The measured poses and their models.
    pub poses: Vec<PoseModel>,
    /// Settings and figures of the interpolation between poses.
    #[serde(default)]
    pub interpolation: InterpolationInfo,
    /// Model extensions added by `diagnose` (delay, disturbance, nonlinear terms).
    #[serde(default)]
    pub extensions: Extensions,
    /// Append-only history of identifications, refits and extensions.
    pub history: Vec<HistoryEntry>,
    /// Tool and command that wrote the file.
    pub provenance: Provenance,
}

impl Twin {
    /// A new twin from pose models.
    pub fn new(name: &str, poses: Vec<PoseModel>) -> Twin {
        let mut channels: Vec<Channel> = poses
            .iter()
            .flat_map(|p| p.model.channels.iter().map(|c| c.channel))
            .collect();
        channels.sort();
        channels.dedup();
        Twin {
            schema: TWIN_SCHEMA.into(),
            version: TWIN_VERSION,
            units: Units::default(),
            name: name.into(),
            channels,
            poses,
            interpolation: InterpolationInfo::default(),
            extensions: Extensions::default(),
            history: Vec::new(),
            provenance: Provenance {
                tool: format!("mtwin {}", env!("CARGO_PKG_VERSION")),
                command: String::new(),
            },
        }
    }

    /// Parses a twin from JSON text; `path` names the source in messages.
    ///
    /// The text is parsed straight into a [`Twin`], so a field of the wrong type or a
    /// missing field is reported at its line and column (`file:line:column`). When that
    /// fails, the schema name and version are checked first: a file of another kind or
    /// of a newer version is named as such rather than by its first odd field.
    pub fn from_json(text: &str, path: &Path) -> Result<Twin> {
        let twin: Twin = match serde_json::from_str(text) {
            Ok(t) => t,
            Err(e) => {
                let v: serde_json::Value =
                    serde_json::from_str(text).map_err(|e| Error::json(path, &e))?;
                check_schema(
                    v.get("schema").and_then(|s| s.as_str()),
                    v.get("version").and_then(|s| s.as_u64()).unwrap_or(0),
                    path,
                )?;
                return Err(Error::json(path, &e));
            }
        };
        check_schema(Some(&twin.schema), u64::from(twin.version), path)?;
        twin.validate(path)?;
        Ok(twin)
    }

    /// Loads a twin file.
    pub fn load(path: &Path) -> Result<Twin> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Twin::from_json(&text, path)
    }

    /// Writes the twin atomically as pretty JSON, after checking that the loader accepts
    /// exactly what is written (the text is read back and validated first): a twin that
    /// [`Twin::load`] would refuse is never written, and the error names what is wrong.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::json(path, &e))?;
        Twin::from_json(&text, path)
            .map_err(|e| Error::Numerical(format!("not written, the twin would not load: {e}")))?;
        write_atomic(path, text.as_bytes())
    }

    /// Checks the invariants a loaded twin must satisfy (no NaN, stable modes, ...).
    pub fn validate(&self, path: &Path) -> Result<()> {
        let bad = |msg: String| Error::Schema {
            file: path.into(),
            msg,
        };
        if self.poses.is_empty() {
            return Err(bad("the twin has no poses".into()));
        }
        for (i, p) in self.poses.iter().enumerate() {
            // poses count from 1 as in the reports; the file's array index beside it
            let i = format!("{} (`poses[{i}]`)", i + 1);
            if !p.pose.iter().all(|v| v.is_finite()) {
                return Err(bad(format!("pose {i}: position is not finite")));
            }
            if !p.model.is_valid() {
                return Err(bad(format!(
                    "pose {i}: model has an unstable mode or a non-finite number"
                )));
            }
            // the stored FRF feeds later refits: it must be a well-formed FRF
            let f = &p.frf.freqs_hz;
            if f.iter().any(|v| !v.is_finite() || *v < 0.0) || f.windows(2).any(|w| w[1] <= w[0]) {
                return Err(bad(format!(
                    "pose {i}: the stored FRF's frequencies are not non-negative and strictly \
                     increasing; re-identify the twin from its data"
                )));
            }
            for c in &p.frf.channels {
                let coh_ok = c.coherence.as_ref().is_none_or(|g| {
                    g.len() == f.len() && g.iter().all(|v| (0.0..=1.0).contains(v))
                });
                if c.h.len() != f.len() || !coh_ok {
                    return Err(bad(format!(
                        "pose {i}: stored FRF channel {} does not have one value (and a \
                         coherence in [0, 1]) per frequency line; re-identify the twin",
                        c.channel
                    )));
                }
            }
        }
        // extensions: finite numbers, cubic terms on modes the twin has
        let e = &self.extensions;
        if e.delay_s.is_some_and(|d| !d.is_finite() || d.abs() > 1.0) {
            return Err(bad(
                "extensions.delay_s must be a finite delay of at most 1 s".into(),
            ));
        }
        if e.disturbance.iter().any(|d| {
            !(d.freq_hz.is_finite() && d.freq_hz >= 0.0 && d.a.is_finite() && d.b.is_finite())
        }) {
            return Err(bad(
                "extensions.disturbance: every freq_hz (>= 0), a and b must be finite".into(),
            ));
        }
        let n_modes = self.poses[0].model.modes.len();
        if let Some(c) = e
            .cubic
            .iter()
            .find(|c| c.mode >= n_modes || !c.kappa.is_finite())
        {
            return Err(bad(format!(
                "extensions.cubic: mode {} with kappa {} (the twin has modes 0..{}; kappa must \
                 be finite)",
                c.mode,
                c.kappa,
                n_modes.saturating_sub(1)
            )));
        }
        Ok(())
    }

    /// A GUID that changes whenever the models change (used for the FMU).
    pub fn guid(&self) -> String {
        use std::hash::{Hash, Hasher};
        let text = serde_json::to_string(&(&self.poses, &self.interpolation, &self.extensions))
            .unwrap_or_default();
        let mut h1 = std::collections::hash_map::DefaultHasher::new();
        text.hash(&mut h1);
        let a = h1.finish();
        let mut h2 = std::collections::hash_map::DefaultHasher::new();
        (a, text.len()).hash(&mut h2);
        let b = h2.finish();
        format!(
            "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
            (a >> 32) as u32,
            (a >> 16) as u16,
            a as u16,
            (b >> 48) as u16,
            b & 0xffff_ffff_ffff
        )
    }
}

/// Seconds since the Unix epoch, now.
pub fn now_unix() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}
