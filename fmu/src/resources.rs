//! What the FMU carries in `resources/twin.json`: the lean twin.
//!
//! A twin file holds, besides the pose models, the measured FRFs, the identification
//! plans and an append-only history with every earlier model (tens of MB for a large
//! campaign refitted a few times). The slave evaluates only the pose models, so the FMU
//! carries [`FmuTwin`] (schema [`FMU_TWIN_SCHEMA`]): the poses with their modal models,
//! the interpolation settings, the extensions the slave simulates, the GUID of the twin
//! it was made from, and a provenance summary of constant size (name, number of poses,
//! the kinds of history entries with their first and last date) — never the FRFs, plans
//! or history, so refitting a twin does not make its FMU grow.
//!
//! [`FmuTwin::from_json`] also accepts a full twin file (schema `mtwin-twin`), as FMUs
//! exported before the lean resources carried.

use mtwin_core::axis::Channel;
use mtwin_core::model::ModalModel;
use mtwin_core::twin::{Extensions, InterpolationInfo, Twin, Units, TWIN_SCHEMA};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Schema name of the FMU's lean twin.
pub const FMU_TWIN_SCHEMA: &str = "mtwin-fmu-twin";
/// Schema version of the FMU's lean twin.
pub const FMU_TWIN_VERSION: u32 = 1;

/// One measured pose and its model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FmuPose {
    /// Axis positions x, y, z \[m\].
    pub pose: [f64; 3],
    /// The modal model at this pose.
    pub model: ModalModel,
}

/// Kind of history entries with the date of the first and the last (UTC, ISO 8601).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryKind {
    /// `identify`, `refit`, `extend`, ...
    pub kind: String,
    /// Date of the first entry of this kind.
    pub first: String,
    /// Date of the last entry of this kind.
    pub last: String,
}

/// A short provenance summary of the twin (constant size however long its history).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Summary {
    /// Tool that wrote the twin file.
    pub twin_tool: String,
    /// Schema and version of the twin file, e.g. `mtwin-twin 1`.
    pub twin_schema: String,
    /// Number of measured poses.
    pub poses: usize,
    /// The kinds of history entries, in order of first appearance, with dates.
    pub history: Vec<HistoryKind>,
}

impl Summary {
    /// The summary of `twin`.
    pub fn of(twin: &Twin) -> Summary {
        let mut kinds: Vec<HistoryKind> = Vec::new();
        for h in &twin.history {
            let date = utc_iso(h.unix_time);
            match kinds.iter_mut().find(|k| k.kind == h.kind) {
                Some(k) => k.last = date,
                None => kinds.push(HistoryKind {
                    kind: h.kind.clone(),
                    first: date.clone(),
                    last: date,
                }),
            }
        }
        Summary {
            twin_tool: twin.provenance.tool.clone(),
            twin_schema: format!("{} {}", twin.schema, twin.version),
            poses: twin.poses.len(),
            history: kinds,
        }
    }

    /// One line for people, of the same length however often the twin is refitted:
    /// `18 pose(s); identify 2026-11-25..2026-11-25; refit 2026-11-26..2026-12-01` (the
    /// first and last date of each kind of history entry).
    pub fn line(&self) -> String {
        let mut s = mtwin_core::axis::count(self.poses, "pose");
        for k in &self.history {
            let day = |d: &str| d.get(..10).unwrap_or(d).to_string();
            s += &format!("; {} {}..{}", k.kind, day(&k.first), day(&k.last));
        }
        s
    }
}

/// The lean twin the FMU carries (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FmuTwin {
    /// Always [`FMU_TWIN_SCHEMA`].
    pub schema: String,
    /// Always [`FMU_TWIN_VERSION`] when written by this library.
    pub version: u32,
    /// GUID of the twin it was made from (the FMU's GUID).
    pub guid: String,
    /// Free name of the machine.
    pub name: String,
    /// Units of the numbers.
    pub units: Units,
    /// Channels the twin models.
    pub channels: Vec<Channel>,
    /// The measured poses and their models.
    pub poses: Vec<FmuPose>,
    /// Interpolation settings (the leave-one-out figures are left out).
    pub interpolation: InterpolationInfo,
    /// Extensions the slave simulates (cubic stiffness, external vibrations); a
    /// measuring-chain delay is not part of the TCP and is left out.
    pub extensions: Extensions,
    /// Where the twin came from.
    pub provenance: Summary,
}

impl FmuTwin {
    /// The lean twin of `twin`.
    pub fn from_twin(twin: &Twin) -> FmuTwin {
        let mut interpolation = twin.interpolation.clone();
        interpolation.leave_one_out.clear();
        let mut extensions = twin.extensions.clone();
        extensions.delay_s = None;
        FmuTwin {
            schema: FMU_TWIN_SCHEMA.into(),
            version: FMU_TWIN_VERSION,
            guid: twin.guid(),
            name: twin.name.clone(),
            units: twin.units.clone(),
            channels: twin.channels.clone(),
            poses: twin
                .poses
                .iter()
                .map(|p| FmuPose {
                    pose: p.pose,
                    model: p.model.clone(),
                })
                .collect(),
            interpolation,
            extensions,
            provenance: Summary::of(twin),
        }
    }

    /// Compact JSON (what the FMU carries).
    pub fn to_json(&self) -> Result<Vec<u8>, String> {
        serde_json::to_vec(self).map_err(|e| format!("lean twin: {e}"))
    }

    /// Parses the FMU's `resources/twin.json`: a lean twin, or a full twin file (FMUs
    /// exported before the lean resources). `path` names the file in messages.
    pub fn from_json(text: &str, path: &Path) -> Result<FmuTwin, String> {
        let v: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| format!("{}: not valid JSON: {e}", path.display()))?;
        match v.get("schema").and_then(|s| s.as_str()) {
            Some(TWIN_SCHEMA) => Twin::from_json(text, path)
                .map(|t| FmuTwin::from_twin(&t))
                .map_err(|e| e.to_string()),
            Some(FMU_TWIN_SCHEMA) => {
                let version = v.get("version").and_then(|s| s.as_u64()).unwrap_or(0);
                if version != u64::from(FMU_TWIN_VERSION) {
                    return Err(format!(
                        "{}: lean twin version {version}, this slave reads version \
                         {FMU_TWIN_VERSION}; export the FMU again with this mtwin",
                        path.display()
                    ));
                }
                let t: FmuTwin =
                    serde_json::from_value(v).map_err(|e| format!("{}: {e}", path.display()))?;
                t.validate()
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                Ok(t)
            }
            other => Err(format!(
                "{}: field \"schema\" is {}, expected \"{FMU_TWIN_SCHEMA}\" or \
                 \"{TWIN_SCHEMA}\"; export the FMU again with `mtwin export`",
                path.display(),
                other
                    .map(|s| format!("\"{s}\""))
                    .unwrap_or_else(|| "missing".into())
            )),
        }
    }

    /// Loads `resources/twin.json` (see [`FmuTwin::from_json`]).
    pub fn load(path: &Path) -> Result<FmuTwin, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        FmuTwin::from_json(&text, path)
    }

    /// The invariants the slave relies on (the twin file's, without the FRFs).
    pub fn validate(&self) -> Result<(), String> {
        let first = self.poses.first().ok_or("the twin has no poses")?;
        for (i, p) in self.poses.iter().enumerate() {
            if !p.pose.iter().all(|v| v.is_finite()) {
                return Err(format!("pose {i}: position is not finite"));
            }
            if !p.model.is_valid() {
                return Err(format!(
                    "pose {i}: model has an unstable mode or a non-finite number"
                ));
            }
        }
        let e = &self.extensions;
        if e.disturbance.iter().any(|d| {
            !(d.freq_hz.is_finite() && d.freq_hz >= 0.0 && d.a.is_finite() && d.b.is_finite())
        }) {
            return Err(
                "extensions.disturbance: every freq_hz (>= 0), a and b must be finite".into(),
            );
        }
        let n = first.model.modes.len();
        if let Some(c) = e.cubic.iter().find(|c| c.mode >= n || !c.kappa.is_finite()) {
            return Err(format!(
                "extensions.cubic: mode {} with kappa {} (the twin has {}; kappa must \
                 be finite)",
                c.mode,
                c.kappa,
                mtwin_core::axis::count(n, "mode")
            ));
        }
        Ok(())
    }

    /// The measured box: lower and upper corner of the poses.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.poses {
            for a in 0..3 {
                lo[a] = lo[a].min(p.pose[a]);
                hi[a] = hi[a].max(p.pose[a]);
            }
        }
        (lo, hi)
    }
}

/// `YYYY-MM-DDTHH:MM:SSZ` of a Unix time (UTC).
pub fn utc_iso(t: u64) -> String {
    humantime::format_rfc3339_seconds(std::time::UNIX_EPOCH + std::time::Duration::from_secs(t))
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::utc_iso;

    #[test]
    fn utc_iso_formats_known_dates() {
        assert_eq!(utc_iso(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_iso(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc_iso(1_764_097_261), "2025-11-25T19:01:01Z");
    }
}
