//! What one FMU instance evaluates: the twin (the TCP dynamics FMU) or the milling process
//! (the process FMU). Both FMUs carry the same slave library; the resource the FMU
//! carries (`resources/twin.json` or `resources/cut.json`) decides at instantiation.

use crate::process::{CutResource, ProcessSlave};
use crate::resources::FmuTwin;
use crate::slave::{Phase, Slave, Snapshot};
use std::path::Path;

/// One instance's model.
#[derive(Debug)]
pub enum Model {
    /// The twin at the current axis positions.
    Twin(Box<Slave>),
    /// The regenerative milling process.
    Cut(Box<ProcessSlave>),
}

macro_rules! both {
    ($self:ident, $s:ident => $e:expr) => {
        match $self {
            Model::Twin($s) => $e,
            Model::Cut($s) => $e,
        }
    };
}

impl Model {
    /// The model of the FMU whose resources are in `dir`, checked against the token the
    /// importer passed (`what`: "GUID" or "instantiation token").
    pub fn load(dir: &Path, name: &str, guid: Option<String>, what: &str) -> Result<Model, String> {
        let cut = dir.join("cut.json");
        let (model, want) = if cut.is_file() {
            let text = std::fs::read_to_string(&cut)
                .map_err(|e| format!("instance '{name}': cannot read {}: {e}", cut.display()))?;
            let r: CutResource = serde_json::from_str(&text).map_err(|e| {
                format!(
                    "instance '{name}': {} is not a process model: {e}",
                    cut.display()
                )
            })?;
            (
                Model::Cut(Box::new(ProcessSlave::new(r.cut.clone())?)),
                r.guid,
            )
        } else {
            let twin = FmuTwin::load(&dir.join("twin.json"))
                .map_err(|e| format!("instance '{name}': cannot read the twin: {e}"))?;
            (Model::Twin(Box::new(Slave::from_lean(&twin)?)), twin.guid)
        };
        match guid {
            Some(g) if g == want => Ok(model),
            Some(g) => Err(format!(
                "{what} mismatch: the importer passed {g}, the FMU's resources have {want} \
                 (modelDescription.xml and resources differ)"
            )),
            None => Err(format!("the {what} is NULL")),
        }
    }

    /// Exposes the independent variable `time` (FMI 3.0, the twin only: the process FMU
    /// is FMI 2.0).
    pub fn expose_time(&mut self) -> Result<(), String> {
        match self {
            Model::Twin(s) => {
                s.expose_time();
                Ok(())
            }
            Model::Cut(_) => Err("the process FMU is an FMI 2.0 FMU".into()),
        }
    }

    /// Current phase.
    pub fn phase(&self) -> Phase {
        both!(self, s => s.phase())
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        both!(self, s => s.time())
    }

    /// `fmi2SetupExperiment`.
    pub fn setup(&mut self, start_time: f64) -> Result<(), String> {
        both!(self, s => s.setup(start_time))
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_init(&mut self) -> Result<(), String> {
        both!(self, s => s.enter_init())
    }

    /// `fmi2ExitInitializationMode`.
    pub fn exit_init(&mut self) -> Result<(), String> {
        both!(self, s => s.exit_init())
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), String> {
        both!(self, s => s.terminate())
    }

    /// `fmi2Reset`.
    pub fn reset(&mut self) {
        both!(self, s => s.reset())
    }

    /// Warnings for the importer's logger.
    pub fn take_warnings(&mut self) -> Vec<String> {
        both!(self, s => s.take_warnings())
    }

    /// `fmi2SetReal`.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        both!(self, s => s.set_real(vrs, values))
    }

    /// `fmi2GetReal`.
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        both!(self, s => s.get_real(vrs, out))
    }

    /// `fmi2DoStep`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), String> {
        both!(self, s => s.do_step(t, h))
    }

    /// Snapshot for `fmi2GetFMUstate` (the twin only; the process model does not
    /// declare canGetAndSetFMUstate).
    pub fn snapshot(&self) -> Result<Snapshot, String> {
        match self {
            Model::Twin(s) => Ok(s.snapshot()),
            Model::Cut(_) => Err("the process FMU cannot get or set its state".into()),
        }
    }

    /// `fmi2SetFMUstate`.
    pub fn restore(&mut self, snap: &Snapshot) -> Result<(), String> {
        match self {
            Model::Twin(s) => s.restore(snap),
            Model::Cut(_) => Err("the process FMU cannot get or set its state".into()),
        }
    }
}
