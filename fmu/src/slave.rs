//! The safe co-simulation slave: knows the twin, nothing of C. The FMI 2.0 and the FMI 3.0
//! exports both drive it.
//!
//! **Alignment with `mtwin simulate`** (zero-order hold, the FMI 2.0 co-simulation
//! convention): the master sets the inputs valid at `t`, reads the outputs at `t`
//! (state at `t` plus the direct feedthrough of the force at `t`, with the model at the
//! pose at `t`), then calls `doStep(t, h)`, which advances the state to `t + h` with the
//! force and pose held at their values of `t`. Fed the samples of a record this gives,
//! sample by sample, exactly what `mtwin simulate --hold zoh` writes.

use crate::resources::FmuTwin;
use mtwin_core::axis::{Axis, Channel};
use mtwin_core::interpolate::TwinEvaluator;
use mtwin_core::simulate::{Hold, Simulator};
use mtwin_core::twin::Twin;

/// Value references: inputs Fx, Fy, Fz, x, y, z then outputs dx, dy, dz — only the
/// axes the twin has, numbered in this order from 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Var {
    /// Force along an axis (input).
    Force(Axis),
    /// Axis position (input).
    Pos(Axis),
    /// TCP displacement along an axis (output).
    Disp(Axis),
}

impl Var {
    /// The FMI variable name.
    pub fn name(&self) -> String {
        match self {
            Var::Force(a) => format!("F{a}"),
            Var::Pos(a) => format!("{a}"),
            Var::Disp(a) => format!("d{a}"),
        }
    }
}

/// The variables of a twin's FMU, in value-reference order.
pub fn variables(twin: &Twin) -> Vec<Var> {
    variables_of(&twin.channels)
}

/// The variables of the FMU of a twin with `channels`, in value-reference order.
pub fn variables_of(channels: &[Channel]) -> Vec<Var> {
    let mut ins: Vec<Axis> = channels.iter().map(|c| c.input).collect();
    let mut outs: Vec<Axis> = channels.iter().map(|c| c.output).collect();
    ins.sort();
    ins.dedup();
    outs.sort();
    outs.dedup();
    let mut v: Vec<Var> = ins.iter().map(|a| Var::Force(*a)).collect();
    v.extend(Axis::ALL.iter().map(|a| Var::Pos(*a)));
    v.extend(outs.iter().map(|a| Var::Disp(*a)));
    v
}

/// Start values of the axis positions x, y, z: the origin, or its nearest point of the
/// measured box `lo..hi` (the model there is the same; the start lies within min/max).
pub fn start_pose(lo: &[f64; 3], hi: &[f64; 3]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for a in 0..3 {
        if lo[a] <= hi[a] {
            p[a] = 0.0f64.clamp(lo[a], hi[a]);
        }
    }
    p
}

/// A position in m as a person writes it: to the micrometre, without the rounding
/// noise of the pose arithmetic (0.6000000000000694 -> 0.6).
pub fn metres(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// Life-cycle state of the slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// After instantiate / reset.
    Instantiated,
    /// Between enter and exit initialization mode.
    Initialization,
    /// Stepping.
    StepComplete,
    /// After terminate.
    Terminated,
}

/// A snapshot of the dynamic state (FMU state).
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    time: f64,
    inputs: [f64; 6],
    state: Vec<[f64; 2]>,
    phase_stepping: bool,
}

impl Snapshot {
    /// Flat little-endian bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(8 * (8 + 2 * self.state.len()));
        b.extend_from_slice(b"MTWS");
        b.extend_from_slice(&(self.state.len() as u32).to_le_bytes());
        b.extend_from_slice(&self.time.to_le_bytes());
        b.push(u8::from(self.phase_stepping));
        for v in self.inputs {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for s in &self.state {
            b.extend_from_slice(&s[0].to_le_bytes());
            b.extend_from_slice(&s[1].to_le_bytes());
        }
        b
    }

    /// Parses [`Snapshot::to_bytes`].
    pub fn from_bytes(b: &[u8]) -> Result<Self, String> {
        let bad = || "serialized FMU state is corrupt or from another FMU".to_string();
        if b.len() < 17 || &b[..4] != b"MTWS" {
            return Err(bad());
        }
        let n = u32::from_le_bytes(b[4..8].try_into().map_err(|_| bad())?) as usize;
        if b.len() != 17 + 48 + 16 * n {
            return Err(bad());
        }
        let f = |i: usize| f64::from_le_bytes(b[i..i + 8].try_into().unwrap_or([0; 8]));
        let time = f(8);
        let phase_stepping = b[16] != 0;
        let mut inputs = [0.0; 6];
        for (k, v) in inputs.iter_mut().enumerate() {
            *v = f(17 + 8 * k);
        }
        let base = 17 + 48;
        let state: Vec<[f64; 2]> = (0..n)
            .map(|k| [f(base + 16 * k), f(base + 16 * k + 8)])
            .collect();
        // a state that would make the outputs NaN or infinite is corrupt
        let finite = time.is_finite()
            && inputs.iter().all(|v| v.is_finite())
            && state.iter().flatten().all(|v| v.is_finite());
        if !finite {
            return Err(
                "serialized FMU state holds a NaN or infinite number: it is corrupt".into(),
            );
        }
        Ok(Snapshot {
            time,
            inputs,
            state,
            phase_stepping,
        })
    }
}

/// The life cycle every slave of this library shares: phase, time, start time, and the
/// checks of the calls that move them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Life {
    /// Current phase.
    pub phase: Phase,
    /// Current time (the last communication point reached).
    pub time: f64,
    /// Start time of the experiment.
    pub start_time: f64,
}

impl Default for Life {
    fn default() -> Self {
        Life {
            phase: Phase::Instantiated,
            time: 0.0,
            start_time: 0.0,
        }
    }
}

impl Life {
    /// The start time (`fmi2SetupExperiment`; part of `fmi3EnterInitializationMode`).
    pub fn setup(&mut self, start_time: f64) -> Result<(), String> {
        if self.phase != Phase::Instantiated {
            return Err("the start time can only be set right after instantiation or reset".into());
        }
        if !start_time.is_finite() {
            return Err(format!("start time {start_time} is not finite"));
        }
        self.start_time = start_time;
        self.time = start_time;
        Ok(())
    }

    /// `fmi2EnterInitializationMode` / `fmi3EnterInitializationMode`.
    pub fn enter_init(&mut self) -> Result<(), String> {
        if self.phase != Phase::Instantiated {
            return Err("EnterInitializationMode called twice or after initialization".into());
        }
        self.phase = Phase::Initialization;
        Ok(())
    }

    /// `fmi2ExitInitializationMode` / `fmi3ExitInitializationMode` (into Step Mode).
    pub fn exit_init(&mut self) -> Result<(), String> {
        if self.phase != Phase::Initialization {
            return Err("ExitInitializationMode without EnterInitializationMode".into());
        }
        self.phase = Phase::StepComplete;
        Ok(())
    }

    /// `fmi2Terminate` / `fmi3Terminate`.
    pub fn terminate(&mut self) -> Result<(), String> {
        if self.phase != Phase::StepComplete {
            return Err("Terminate is only allowed after initialization".into());
        }
        self.phase = Phase::Terminated;
        Ok(())
    }

    /// A `DoStep(t, h)` is allowed now: stepping, a finite non-negative step, `t` the
    /// time reached.
    pub fn check_step(&self, t: f64, h: f64) -> Result<(), String> {
        if self.phase != Phase::StepComplete {
            return Err(
                "DoStep is only allowed after ExitInitializationMode and before Terminate".into(),
            );
        }
        if !(h >= 0.0 && h.is_finite() && t.is_finite()) {
            return Err(format!(
                "communication step {h} at {t} is not a finite non-negative number"
            ));
        }
        let tol = 1e-9 * (1.0 + t.abs().max(self.time.abs()));
        if (t - self.time).abs() > tol.max(1e-6 * h) {
            return Err(format!(
                "doStep at t = {t} but the slave is at {} (steps must follow each other)",
                self.time
            ));
        }
        Ok(())
    }
}

/// The slave core.
#[derive(Debug)]
pub struct Slave {
    vars: Vec<Var>,
    ev: TwinEvaluator,
    sim: Simulator,
    /// External vibrations of the twin's extensions, added to the outputs at the FMU time.
    disturbance: Vec<mtwin_core::twin::Sinusoid>,
    /// Fx, Fy, Fz, x, y, z.
    inputs: [f64; 6],
    start: [f64; 6],
    life: Life,
    /// The measured box (the model is clamped to it).
    lo: [f64; 3],
    hi: [f64; 3],
    /// True while the axis positions are outside the measured box (one warning per
    /// excursion).
    outside: bool,
    /// Warnings not yet handed to the importer's logger.
    warnings: Vec<String>,
    /// The value reference of the independent variable `time` (FMI 3.0, where the model
    /// description must declare one), if exposed: [`Slave::time_value_reference`].
    time_vr: Option<u32>,
}

impl Slave {
    /// A slave for `twin` (through its lean form, [`FmuTwin::from_twin`]).
    pub fn new(twin: &Twin) -> Result<Self, String> {
        Self::from_lean(&FmuTwin::from_twin(twin))
    }

    /// A slave for the lean twin the FMU carries.
    pub fn from_lean(twin: &FmuTwin) -> Result<Self, String> {
        let poses: Vec<([f64; 3], &mtwin_core::model::ModalModel)> =
            twin.poses.iter().map(|p| (p.pose, &p.model)).collect();
        let ev = TwinEvaluator::from_poses(&poses).map_err(|e| e.to_string())?;
        let (lo, hi) = ev.bounds();
        let p0 = start_pose(&lo, &hi);
        let start = [0.0, 0.0, 0.0, p0[0], p0[1], p0[2]];
        let n = ev.n_modes();
        // the twin's extensions: a cubic modal stiffness and external vibrations are part of
        // the machine and go into the FMU; a delay between the force and response channels
        // belongs to the measuring chain, not to the tool centre point, and stays out
        let mut sim = Simulator::new(n, Hold::Zoh);
        let kappa: Vec<f64> = (0..n)
            .map(|k| {
                twin.extensions
                    .cubic
                    .iter()
                    .filter(|c| c.mode == k)
                    .map(|c| c.kappa)
                    .sum()
            })
            .collect();
        if !sim.set_cubic(&kappa) {
            return Err("the twin's cubic stiffness terms are not finite".into());
        }
        Ok(Slave {
            vars: variables_of(&twin.channels),
            ev,
            sim,
            disturbance: twin.extensions.disturbance.clone(),
            inputs: start,
            start,
            life: Life::default(),
            lo,
            hi,
            outside: false,
            warnings: Vec::new(),
            time_vr: None,
        })
    }

    /// The value reference of the independent variable `time` when it is exposed: the
    /// one after the last variable of [`Slave::vars`], so the others keep the value
    /// references they have without it.
    pub fn time_value_reference(&self) -> u32 {
        self.vars.len() as u32
    }

    /// Exposes the independent variable `time` (read only) at
    /// [`Slave::time_value_reference`], as FMI 3.0 model descriptions declare it.
    pub fn expose_time(&mut self) {
        self.time_vr = Some(self.time_value_reference());
    }

    /// The variables in value-reference order.
    pub fn vars(&self) -> &[Var] {
        &self.vars
    }

    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.life.phase
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.life.time
    }

    fn slot(v: Var) -> Option<usize> {
        match v {
            Var::Force(a) => Some(a.index()),
            Var::Pos(a) => Some(3 + a.index()),
            Var::Disp(_) => None,
        }
    }

    fn var(&self, vr: u32) -> Result<Var, String> {
        self.vars.get(vr as usize).copied().ok_or_else(|| {
            let time = match self.time_vr {
                Some(t) => format!(" and {t} (time)"),
                None => String::new(),
            };
            unknown_vr(vr, self.vars.len(), &time)
        })
    }

    /// The start time (`fmi2SetupExperiment`; part of `fmi3EnterInitializationMode`).
    pub fn setup(&mut self, start_time: f64) -> Result<(), String> {
        self.life.setup(start_time)
    }

    /// `fmi2EnterInitializationMode` / `fmi3EnterInitializationMode`.
    pub fn enter_init(&mut self) -> Result<(), String> {
        self.life.enter_init()
    }

    /// `fmi2ExitInitializationMode` / `fmi3ExitInitializationMode` (into Step Mode).
    pub fn exit_init(&mut self) -> Result<(), String> {
        self.life.exit_init()
    }

    /// `fmi2Terminate` / `fmi3Terminate`.
    pub fn terminate(&mut self) -> Result<(), String> {
        self.life.terminate()
    }

    /// `fmi2Reset` / `fmi3Reset`: back to the state right after instantiation.
    pub fn reset(&mut self) {
        self.sim.reset();
        self.inputs = self.start;
        self.life = Life::default();
        self.outside = false;
        self.warnings.clear();
    }

    /// Warnings since the last call (for the importer's logger): one when the axis
    /// positions leave the measured box, none while they stay out.
    pub fn take_warnings(&mut self) -> Vec<String> {
        std::mem::take(&mut self.warnings)
    }

    /// The measured box: lower and upper corner \[m\].
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        (self.lo, self.hi)
    }

    /// The pose the model is evaluated at; notes the start of an excursion outside the
    /// measured box (where the model is clamped to the box).
    fn checked_pose(&mut self) -> [f64; 3] {
        let pose = self.pose();
        // 0.1 mm, as the evaluator's own inside test
        const TOL: f64 = 1e-4;
        let out: Vec<String> = (0..3)
            .filter(|&a| !(pose[a] >= self.lo[a] - TOL && pose[a] <= self.hi[a] + TOL))
            .map(|a| {
                format!(
                    "{} = {} m (measured {}..{} m)",
                    Axis::ALL[a],
                    pose[a],
                    metres(self.lo[a]),
                    metres(self.hi[a])
                )
            })
            .collect();
        if out.is_empty() {
            self.outside = false;
        } else if !self.outside {
            self.outside = true;
            self.warnings.push(format!(
                "t = {} s: axis position outside the measured box ({}): the twin is \
                 evaluated at the nearest point of the box (clamped, not extrapolated); \
                 warned once until the axes come back into the box",
                self.life.time,
                out.join(", ")
            ));
        }
        pose
    }

    /// `fmi2SetReal` / `fmi3SetFloat64`.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        if self.life.phase == Phase::Terminated {
            return Err("setting a variable after Terminate".into());
        }
        for (vr, v) in vrs.iter().zip(values) {
            if self.time_vr == Some(*vr) {
                return Err("time is the independent variable and cannot be set".into());
            }
            let var = self.var(*vr)?;
            let Some(i) = Self::slot(var) else {
                return Err(format!("{} is an output and cannot be set", var.name()));
            };
            if !v.is_finite() {
                return Err(format!("{} = {v} is not finite", var.name()));
            }
            self.inputs[i] = *v;
        }
        Ok(())
    }

    fn pose(&self) -> [f64; 3] {
        [self.inputs[3], self.inputs[4], self.inputs[5]]
    }

    fn force(&self) -> [f64; 3] {
        [self.inputs[0], self.inputs[1], self.inputs[2]]
    }

    /// The outputs dx, dy, dz now (state plus feedthrough at the current pose).
    pub fn outputs(&mut self) -> [f64; 3] {
        let pose = self.checked_pose();
        let u = self.force();
        let model = self.ev.model_at(pose);
        let mut y = self.sim.output(model, &u);
        for d in &self.disturbance {
            let ph = 2.0 * std::f64::consts::PI * d.freq_hz * self.life.time;
            y[d.axis.index()] += d.a * ph.cos() + d.b * ph.sin();
        }
        y
    }

    /// `fmi2GetReal` / `fmi3GetFloat64`.
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        // outputs only when asked for (inputs are read back as set)
        let mut y: Option<[f64; 3]> = None;
        for (vr, o) in vrs.iter().zip(out.iter_mut()) {
            if self.time_vr == Some(*vr) {
                *o = self.life.time;
                continue;
            }
            let var = self.var(*vr)?;
            *o = match var {
                Var::Disp(a) => {
                    let v = y.get_or_insert_with(|| self.outputs())[a.index()];
                    if !v.is_finite() {
                        return Err(format!(
                            "{} is not finite: the forces or the restored FMU state are far \
                             out of range",
                            var.name()
                        ));
                    }
                    v
                }
                other => self.inputs[Self::slot(other).unwrap_or(0)],
            };
        }
        Ok(())
    }

    /// `fmi2DoStep` / `fmi3DoStep`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), String> {
        self.life.check_step(t, h)?;
        if h > 0.0 {
            let pose = self.checked_pose();
            let u = self.force();
            let model = self.ev.model_at(pose);
            self.sim.step(model, &u, &u, h);
            if !self.sim.state().iter().flatten().all(|v| v.is_finite()) {
                // only absurd forces or a corrupt restored state get here
                self.sim.reset();
                return Err(format!(
                    "doStep at t = {t}: the modal state overflowed (forces or a restored \
                     FMU state far out of range); the structure was put back to rest"
                ));
            }
        }
        self.life.time = t + h;
        Ok(())
    }

    /// Snapshot for `fmi2GetFMUstate` / `fmi3GetFMUState`.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            time: self.life.time,
            inputs: self.inputs,
            state: self.sim.state().to_vec(),
            phase_stepping: self.life.phase == Phase::StepComplete,
        }
    }

    /// `fmi2SetFMUstate` / `fmi3SetFMUState`.
    pub fn restore(&mut self, s: &Snapshot) -> Result<(), String> {
        if !self.sim.set_state(&s.state) {
            return Err("FMU state belongs to another FMU (state size differs)".into());
        }
        self.life.time = s.time;
        self.inputs = s.inputs;
        if s.phase_stepping {
            self.life.phase = Phase::StepComplete;
        }
        Ok(())
    }
}

/// The message for a value reference that is not one of the `n` variables (value
/// references `0` to `n − 1`; `extra` names any other, e.g. ` and 8 (time)`): in the
/// words of the model description, not a Rust range.
pub(crate) fn unknown_vr(vr: u32, n: usize, extra: &str) -> String {
    let known = match n {
        0 => return format!("unknown value reference {vr}: this FMU has no variables"),
        1 => "is 0".to_string(),
        n => format!("are 0 to {}", n - 1),
    };
    format!(
        "unknown value reference {vr}: this FMU's value references {known}{extra} \
         (listed in modelDescription.xml)"
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_unknown_value_reference_is_said_in_model_description_words() {
        let m = super::unknown_vr(9, 8, " and 8 (time)");
        assert_eq!(
            m,
            "unknown value reference 9: this FMU's value references are 0 to 7 and 8 (time) \
             (listed in modelDescription.xml)"
        );
        assert!(!m.contains("..="));
    }

    use super::{Slave, Snapshot};
    use mtwin_core::axis::Axis;
    use vmachine::structure::ModalMachine;

    /// Found by `scripts/fuzz.sh` (MTWIN_FUZZ_SEED=0x6f232d33687b3532): a restored
    /// state with huge (finite) numbers, or absurd forces, overflowed in doStep and
    /// fmi2GetReal returned NaN.
    #[test]
    fn overflow_is_an_error_never_a_nan_output() {
        let twin = ModalMachine::default_machine().exact_twin([2, 1, 1], &[Axis::X, Axis::Y]);
        let mut s = Slave::new(&twin).unwrap();
        s.setup(0.0).unwrap();
        s.enter_init().unwrap();
        s.exit_init().unwrap();
        // value references: Fx Fy, x y z, dx dy
        let outs = [5u32, 6];
        let mut y = [0.0; 2];
        let mut snap = s.snapshot();
        snap.state[0] = [1e307, -1e307];
        s.restore(&snap).unwrap();
        let e = s.do_step(0.0, 1e-3).expect_err("overflow");
        assert!(e.contains("overflowed"), "{e}");
        s.get_real(&outs, &mut y).unwrap();
        assert!(y.iter().all(|v| v.is_finite()), "{y:?}");
        // restored huge state read right away: an error, not inf
        s.restore(&snap).unwrap();
        match s.get_real(&outs, &mut y) {
            Ok(()) => assert!(y.iter().all(|v| v.is_finite()), "{y:?}"),
            Err(e) => assert!(e.contains("not finite"), "{e}"),
        }
        // the largest finite force
        s.reset();
        s.setup(0.0).unwrap();
        s.enter_init().unwrap();
        s.exit_init().unwrap();
        s.set_real(&[0, 1], &[f64::MAX, -f64::MAX]).unwrap();
        let mut t = 0.0;
        for _ in 0..10 {
            if s.do_step(t, 1e-3).is_ok() {
                t += 1e-3;
            }
            match s.get_real(&outs, &mut y) {
                Ok(()) => assert!(y.iter().all(|v| v.is_finite()), "{y:?}"),
                Err(e) => assert!(e.contains("not finite"), "{e}"),
            }
        }
    }

    /// Found by the random C-API test (fmu/tests/ffi.rs): a serialized state with a NaN
    /// written over one of its numbers deserialized fine, and after fmi2SetFMUstate the
    /// outputs were NaN.
    #[test]
    fn corrupt_state_with_non_finite_numbers_is_refused() {
        let s = Snapshot {
            time: 0.5,
            inputs: [1.0, 2.0, 0.0, 0.1, 0.2, 0.3],
            state: vec![[1e-6, -2e-3]; 3],
            phase_stepping: true,
        };
        let good = s.to_bytes();
        assert!(Snapshot::from_bytes(&good).is_ok());
        // the time, every input and every state number
        let offsets = std::iter::once(8).chain((0..(good.len() - 17) / 8).map(|k| 17 + 8 * k));
        for at in offsets {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut b = good.clone();
                b[at..at + 8].copy_from_slice(&bad.to_le_bytes());
                let e = Snapshot::from_bytes(&b).expect_err("non-finite number");
                assert!(e.contains("corrupt"), "{e}");
            }
        }
    }
}
