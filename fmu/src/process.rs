//! The regenerative milling process as its own co-simulation slave: the partner of the
//! twin FMU in a milling co-simulation (its inputs are the twin's outputs `dx`, `dy`, its
//! outputs the twin's inputs `Fx`, `Fy`).
//!
//! The model is the linear regenerative one of `mtwin lobes` (and of the Python process
//! model the tests co-simulate): tooth `j` at angle `φ_j(t) = Ω t + 2π j / N − ψ(z)`
//! (clockwise from +y, feed along +x; `ψ(z) = 2 z tan β / D` the helix lag of the axial
//! slice at height `z`) cuts the dynamic chip
//!
//! ```text
//! h_j = sin φ_j (x(t) − x(t − τ)) + cos φ_j (y(t) − y(t − τ)),   τ = 60 / (n N)
//! F_x = Σ_j Σ_slices g(φ_j) a_slice K_t (−cos φ_j − K_r sin φ_j) h_j
//! F_y = Σ_j Σ_slices g(φ_j) a_slice K_t ( sin φ_j − K_r cos φ_j) h_j
//! ```
//!
//! with `g` = 1 inside the engagement (down milling: `acos(2 a_e/D − 1) ≤ φ ≤ π`; up
//! milling: `0 ≤ φ ≤ acos(1 − 2 a_e/D)`). The delay line `x(t − τ)` is kept inside: the
//! displacement is recorded at every communication point and interpolated linearly at
//! `t − τ` (exact when the step divides the tooth period); before the cut started it is
//! zero (the tool at rest). The static feed term adds a periodic force that does not
//! change stability and is left out. An optional tap `kick` (N, along x and y, for
//! `t < kick_duration`) starts the vibration.

use crate::slave::{Life, Phase};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::f64::consts::PI;

/// The model identifier of the process FMU (its shared library's name).
pub const MODEL_IDENTIFIER: &str = "mtwin_cut";

/// The cut: tool, engagement and cutting coefficients (the FMU's parameters).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cut {
    /// Spindle speed \[1/min\].
    pub rpm: f64,
    /// Axial depth of cut \[m\].
    pub ap: f64,
    /// Number of teeth.
    pub teeth: u32,
    /// Tangential cutting coefficient \[N/m²\].
    pub kt: f64,
    /// Radial to tangential force ratio.
    pub kr: f64,
    /// Radial immersion a_e / D (0..1].
    pub immersion: f64,
    /// Down milling (true) or up milling.
    pub down: bool,
    /// Helix angle \[deg\] (0: straight flutes).
    pub helix_deg: f64,
    /// Tool diameter \[m\] (used with a helix).
    pub diameter: f64,
    /// Axial slices with a helix (1 without).
    pub slices: u32,
    /// Tap force along x and y \[N\] at the start.
    pub kick: f64,
    /// How long the tap lasts \[s\].
    pub kick_duration: f64,
}

impl Default for Cut {
    fn default() -> Self {
        Cut {
            rpm: 6000.0,
            ap: 1e-3,
            teeth: 2,
            kt: 6e8,
            kr: 0.3,
            immersion: 1.0,
            down: true,
            helix_deg: 0.0,
            diameter: 0.016,
            slices: 20,
            kick: 0.0,
            kick_duration: 0.0,
        }
    }
}

/// A parameter of the process FMU: its name, unit, description and place in [`Cut`].
#[derive(Debug, Clone, Copy)]
pub struct Param {
    /// Variable name.
    pub name: &'static str,
    /// Unit (FMI unit name), if any.
    pub unit: Option<&'static str>,
    /// FMI quantity, if any.
    pub quantity: Option<&'static str>,
    /// Description for the model description.
    pub description: &'static str,
    /// Its value in a [`Cut`].
    pub get: fn(&Cut) -> f64,
    /// Sets it in a [`Cut`].
    pub set: fn(&mut Cut, f64),
}

/// The parameters, in value-reference order (from [`VR_PARAM0`]).
pub const PARAMS: [Param; 12] = [
    Param {
        name: "rpm",
        unit: Some("1/min"),
        quantity: Some("AngularVelocity"),
        description: "Spindle speed, in revolutions per minute",
        get: |c| c.rpm,
        set: |c, v| c.rpm = v,
    },
    Param {
        name: "ap",
        unit: Some("m"),
        quantity: Some("Length"),
        description: "Axial depth of cut, in m",
        get: |c| c.ap,
        set: |c, v| c.ap = v,
    },
    Param {
        name: "teeth",
        unit: Some("1"),
        quantity: None,
        description: "Number of teeth (a whole number >= 1)",
        get: |c| f64::from(c.teeth),
        set: |c, v| c.teeth = v.round().clamp(0.0, 1e6) as u32,
    },
    Param {
        name: "kt",
        unit: Some("N/m2"),
        quantity: Some("Pressure"),
        description: "Tangential cutting force coefficient, in N/m^2 (force per chip area)",
        get: |c| c.kt,
        set: |c, v| c.kt = v,
    },
    Param {
        name: "kr",
        unit: Some("1"),
        quantity: None,
        description: "Radial to tangential cutting force ratio",
        get: |c| c.kr,
        set: |c, v| c.kr = v,
    },
    Param {
        name: "immersion",
        unit: Some("1"),
        quantity: None,
        description: "Radial immersion a_e/D, in (0, 1] (1: slotting)",
        get: |c| c.immersion,
        set: |c, v| c.immersion = v,
    },
    Param {
        name: "down",
        unit: Some("1"),
        quantity: None,
        description: "1 for down (climb) milling, 0 for up milling",
        get: |c| if c.down { 1.0 } else { 0.0 },
        set: |c, v| c.down = v >= 0.5,
    },
    Param {
        name: "helix_deg",
        unit: Some("deg"),
        quantity: Some("Angle"),
        description: "Helix angle of the flutes, in degrees (0: straight flutes)",
        get: |c| c.helix_deg,
        set: |c, v| c.helix_deg = v,
    },
    Param {
        name: "diameter",
        unit: Some("m"),
        quantity: Some("Length"),
        description: "Tool diameter, in m (sets the helix lag along the depth of cut)",
        get: |c| c.diameter,
        set: |c, v| c.diameter = v,
    },
    Param {
        name: "slices",
        unit: Some("1"),
        quantity: None,
        description: "Axial slices the depth of cut is divided into when the helix angle is \
                      not zero (a whole number >= 1)",
        get: |c| f64::from(c.slices),
        set: |c, v| c.slices = v.round().clamp(0.0, 1e6) as u32,
    },
    Param {
        name: "kick",
        unit: Some("N"),
        quantity: Some("Force"),
        description: "A tap along +x and +y, in N, added for t < kick_duration to start \
                      the vibration (0: none)",
        get: |c| c.kick,
        set: |c, v| c.kick = v,
    },
    Param {
        name: "kick_duration",
        unit: Some("s"),
        quantity: Some("Time"),
        description: "How long the tap lasts from the start time, in s",
        get: |c| c.kick_duration,
        set: |c, v| c.kick_duration = v,
    },
];

/// The parameters' names and units, in value-reference order (from 4).
pub fn param_names() -> impl Iterator<Item = (&'static str, Option<&'static str>)> {
    PARAMS.iter().map(|p| (p.name, p.unit))
}

/// `(name, value)` of every parameter of `cut`, in value-reference order.
pub fn param_values(cut: &Cut) -> Vec<(String, f64)> {
    PARAMS
        .iter()
        .map(|p| (p.name.to_string(), (p.get)(cut)))
        .collect()
}

/// Value references: inputs 0, 1; outputs 2, 3; parameters from 4 in [`PARAMS`] order.
/// Value reference of the input dx.
pub const VR_DX: u32 = 0;
/// Value reference of the input dy.
pub const VR_DY: u32 = 1;
/// Value reference of the output Fx.
pub const VR_FX: u32 = 2;
/// Value reference of the output Fy.
pub const VR_FY: u32 = 3;
/// Value reference of the first parameter ([`param_names`] order).
pub const VR_PARAM0: u32 = 4;

impl Cut {
    /// Why these parameters cannot cut, if they cannot.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |n: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{n} = {v} must be a positive finite number"))
            }
        };
        pos("rpm", self.rpm)?;
        pos("diameter", self.diameter)?;
        if !(self.ap.is_finite() && self.ap >= 0.0) {
            return Err(format!("ap = {} must be a finite number >= 0", self.ap));
        }
        if self.teeth == 0 || self.slices == 0 {
            return Err("teeth and slices must be whole numbers >= 1".into());
        }
        if !(self.immersion > 0.0 && self.immersion <= 1.0) {
            return Err(format!("immersion = {} must be in (0, 1]", self.immersion));
        }
        if !(self.helix_deg.abs() < 89.0) {
            return Err(format!(
                "helix_deg = {} must be within ±89°",
                self.helix_deg
            ));
        }
        for (n, v) in [
            ("kt", self.kt),
            ("kr", self.kr),
            ("kick", self.kick),
            ("kick_duration", self.kick_duration),
        ] {
            if !v.is_finite() {
                return Err(format!("{n} = {v} is not finite"));
            }
        }
        Ok(())
    }

    /// Tooth passing period τ \[s\].
    pub fn tooth_period(&self) -> f64 {
        60.0 / (self.rpm * f64::from(self.teeth))
    }

    /// Entry and exit angle of the engagement \[rad\].
    pub fn engagement(&self) -> (f64, f64) {
        let i = self.immersion;
        if self.down {
            ((2.0 * i - 1.0).clamp(-1.0, 1.0).acos(), PI)
        } else {
            (0.0, (1.0 - 2.0 * i).clamp(-1.0, 1.0).acos())
        }
    }

    /// Cutting force \[N\] at time `t` (since the cut started) for the dynamic
    /// displacement `d` = r(t) − r(t − τ) (x, y).
    pub fn force(&self, t: f64, d: [f64; 2]) -> [f64; 2] {
        let (st, ex) = self.engagement();
        let om = 2.0 * PI * self.rpm / 60.0;
        let n = self.teeth;
        let slices = if self.helix_deg == 0.0 {
            1
        } else {
            self.slices
        };
        let a = self.ap / f64::from(slices);
        let lag = 2.0 * self.helix_deg.to_radians().tan() / self.diameter;
        let mut f = [0.0, 0.0];
        for l in 0..slices {
            let z = (f64::from(l) + 0.5) * a;
            for j in 0..n {
                let phi = (om * t + 2.0 * PI * f64::from(j) / f64::from(n) - lag * z)
                    .rem_euclid(2.0 * PI);
                if st <= phi && phi <= ex {
                    let (sn, co) = phi.sin_cos();
                    let h = sn * d[0] + co * d[1];
                    f[0] += a * self.kt * (-co - self.kr * sn) * h;
                    f[1] += a * self.kt * (sn - self.kr * co) * h;
                }
            }
        }
        f
    }
}

/// The process slave: life cycle as the twin's [`crate::slave::Slave`], the delay line
/// inside.
#[derive(Debug)]
pub struct ProcessSlave {
    start: Cut,
    cut: Cut,
    /// dx, dy as last set.
    inputs: [f64; 2],
    /// (time, dx, dy) at the communication points, oldest first, kept for one tooth
    /// period.
    history: VecDeque<(f64, f64, f64)>,
    life: Life,
}

impl ProcessSlave {
    /// A slave for the cut `start` (the parameters' start values).
    pub fn new(start: Cut) -> Result<Self, String> {
        start.validate()?;
        Ok(ProcessSlave {
            cut: start.clone(),
            start,
            inputs: [0.0; 2],
            history: VecDeque::new(),
            life: Life::default(),
        })
    }

    /// Current phase.
    pub fn phase(&self) -> Phase {
        self.life.phase
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.life.time
    }

    /// `fmi2SetupExperiment`.
    pub fn setup(&mut self, start_time: f64) -> Result<(), String> {
        self.life.setup(start_time)
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_init(&mut self) -> Result<(), String> {
        self.life.enter_init()
    }

    /// `fmi2ExitInitializationMode`: the parameters are checked here.
    pub fn exit_init(&mut self) -> Result<(), String> {
        if self.life.phase == Phase::Initialization {
            self.cut.validate()?;
        }
        self.life.exit_init()
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), String> {
        self.life.terminate()
    }

    /// `fmi2Reset`.
    pub fn reset(&mut self) {
        self.cut = self.start.clone();
        self.inputs = [0.0; 2];
        self.history.clear();
        self.life = Life::default();
    }

    /// No warnings: the cut has no box to leave.
    pub fn take_warnings(&mut self) -> Vec<String> {
        Vec::new()
    }

    /// `fmi2SetReal`: the displacements at any time, the parameters before the end of
    /// initialization (they are fixed).
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        if self.life.phase == Phase::Terminated {
            return Err("fmi2SetReal after fmi2Terminate".into());
        }
        for (&vr, &v) in vrs.iter().zip(values) {
            if !v.is_finite() {
                return Err(format!("{} = {v} is not finite", name(vr)));
            }
            match vr {
                VR_DX | VR_DY => self.inputs[vr as usize] = v,
                VR_FX | VR_FY => {
                    return Err(format!("{} is an output and cannot be set", name(vr)))
                }
                _ => {
                    let p = param(vr)?;
                    if self.life.phase == Phase::StepComplete {
                        return Err(format!(
                            "{} is a fixed parameter: set it before fmi2ExitInitializationMode",
                            p.name
                        ));
                    }
                    (p.set)(&mut self.cut, v);
                }
            }
        }
        Ok(())
    }

    /// `x(t − τ)`, `y(t − τ)` from the delay line (zero before the cut started).
    fn delayed(&self, t: f64) -> [f64; 2] {
        // before the cut started the tool was at rest; a point older than the delay line
        // keeps (only by rounding: it holds one step more than a tooth period) is its
        // oldest
        let first = self.history.front().map_or(self.life.time, |s| s.0);
        let rounding = 1e-9 * (self.life.time - self.life.start_time).abs().max(1e-12);
        if t < self.life.start_time - rounding || (self.history.is_empty() && t < first) {
            return [0.0, 0.0];
        }
        let t = t.max(first);
        if self.history.is_empty() {
            return [self.inputs[0], self.inputs[1]];
        }
        let k = self.history.partition_point(|s| s.0 <= t).max(1);
        let (ta, xa, ya) = self.history[k - 1];
        match self.history.get(k) {
            Some(&(tb, xb, yb)) if tb > ta => {
                let w = (t - ta) / (tb - ta);
                [xa + w * (xb - xa), ya + w * (yb - ya)]
            }
            // t at or after the last recorded point: the current displacement is the
            // next point, not recorded yet
            _ => {
                let (tb, xb, yb) = (self.life.time, self.inputs[0], self.inputs[1]);
                if tb > ta {
                    let w = (t - ta) / (tb - ta);
                    [xa + w * (xb - xa), ya + w * (yb - ya)]
                } else {
                    [xa, ya]
                }
            }
        }
    }

    /// The cutting force now (from the inputs as set and the delay line).
    pub fn outputs(&self) -> [f64; 2] {
        let tau = self.cut.tooth_period();
        let old = self.delayed(self.life.time - tau);
        let d = [self.inputs[0] - old[0], self.inputs[1] - old[1]];
        let t = self.life.time - self.life.start_time;
        let mut f = self.cut.force(t, d);
        if t < self.cut.kick_duration {
            f[0] += self.cut.kick;
            f[1] += self.cut.kick;
        }
        f
    }

    /// `fmi2GetReal`.
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        let mut f: Option<[f64; 2]> = None;
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            *o = match vr {
                VR_DX | VR_DY => self.inputs[vr as usize],
                VR_FX | VR_FY => {
                    if self.cut.validate().is_err() {
                        0.0
                    } else {
                        f.get_or_insert_with(|| self.outputs())[(vr - VR_FX) as usize]
                    }
                }
                _ => (param(vr)?.get)(&self.cut),
            };
        }
        Ok(())
    }

    /// `fmi2DoStep`: records the displacement at the communication point.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), String> {
        self.life.check_step(t, h)?;
        if h > 0.0 {
            self.history
                .push_back((self.life.time, self.inputs[0], self.inputs[1]));
            // keep what t + h − τ can still reach, and one step more (rounding)
            let keep_from = self.life.time - self.cut.tooth_period();
            while self.history.len() > 2 && self.history[1].0 <= keep_from {
                self.history.pop_front();
            }
            self.life.time = t + h;
        }
        Ok(())
    }
}

fn param(vr: u32) -> Result<&'static Param, String> {
    vr.checked_sub(VR_PARAM0)
        .and_then(|i| PARAMS.get(i as usize))
        .ok_or_else(|| crate::slave::unknown_vr(vr, VR_PARAM0 as usize + PARAMS.len(), ""))
}

/// The name of value reference `vr` ("dx", "Fx", "rpm", …; "?" when there is none).
pub fn name(vr: u32) -> &'static str {
    match vr {
        VR_DX => "dx",
        VR_DY => "dy",
        VR_FX => "Fx",
        VR_FY => "Fy",
        _ => param(vr).map_or("?", |p| p.name),
    }
}

/// The resource the process FMU carries (`resources/cut.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CutResource {
    /// Always "mtwin-cut".
    pub kind: String,
    /// The GUID of the model description.
    pub guid: String,
    /// The parameters' start values.
    pub cut: Cut,
}

impl CutResource {
    /// The resource for `cut`, with a GUID derived from its parameters.
    pub fn new(cut: Cut) -> Self {
        let text = serde_json::to_string(&cut).unwrap_or_default();
        // FNV-1a over the parameters: the same cut gives the same GUID
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in text.bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        CutResource {
            kind: "mtwin-cut".into(),
            guid: format!("{{mtwin-cut-{h:016x}}}"),
            cut,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stepping(cut: Cut) -> ProcessSlave {
        let mut s = ProcessSlave::new(cut).unwrap();
        s.setup(0.0).unwrap();
        s.enter_init().unwrap();
        s.exit_init().unwrap();
        s
    }

    #[test]
    fn a_vanishing_helix_is_the_straight_tool() {
        let straight = Cut::default();
        let helix = Cut {
            helix_deg: 1e-9,
            slices: 40,
            ..Cut::default()
        };
        for t in [0.7e-3, 1.3e-3, 4.1e-3] {
            let a = straight.force(t, [1e-5, -2e-5]);
            let b = helix.force(t, [1e-5, -2e-5]);
            for k in 0..2 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-6 * a[k].abs().max(1.0),
                    "{a:?} {b:?}"
                );
            }
        }
    }

    #[test]
    fn a_helix_smooths_the_force_over_the_tooth_pass() {
        // slotting with two straight teeth: the force jumps when a tooth enters; with a
        // helix it rises over the lag angle
        let d = [1e-5, 0.0];
        let steps = 400;
        let tau = Cut::default().tooth_period();
        let jumps = |c: &Cut| {
            (1..steps)
                .map(|i| {
                    let t0 = tau * (i - 1) as f64 / steps as f64;
                    let t1 = tau * i as f64 / steps as f64;
                    (c.force(t1, d)[0] - c.force(t0, d)[0]).abs()
                })
                .fold(0.0, f64::max)
        };
        let straight = Cut {
            immersion: 0.5,
            ..Cut::default()
        };
        let helix = Cut {
            helix_deg: 30.0,
            ..straight.clone()
        };
        assert!(jumps(&helix) < 0.2 * jumps(&straight));
    }

    #[test]
    fn the_delay_line_returns_the_displacement_one_tooth_period_ago() {
        let cut = Cut {
            kt: 1.0,
            ..Cut::default()
        };
        let tau = cut.tooth_period();
        let h = tau / 8.0;
        let mut s = stepping(cut);
        for i in 0..40 {
            let x = (i as f64 * 0.37).sin();
            s.set_real(&[VR_DX, VR_DY], &[x, 2.0 * x]).unwrap();
            if i >= 8 {
                let want = ((i - 8) as f64 * 0.37).sin();
                let got = s.delayed(s.time() - tau);
                assert!((got[0] - want).abs() < 1e-9, "{i}: {got:?} vs {want}");
                assert!((got[1] - 2.0 * want).abs() < 1e-9);
            } else {
                assert_eq!(s.delayed(s.time() - tau), [0.0, 0.0]);
            }
            s.do_step(s.time(), h).unwrap();
        }
        assert!(s.history.len() <= 10, "{}", s.history.len());
    }

    #[test]
    fn parameters_are_fixed_after_initialization_and_checked() {
        let mut s = ProcessSlave::new(Cut::default()).unwrap();
        s.setup(0.0).unwrap();
        s.enter_init().unwrap();
        s.set_real(&[VR_PARAM0], &[0.0]).unwrap(); // rpm 0
        assert!(s.exit_init().unwrap_err().contains("rpm"));
        let mut s = stepping(Cut::default());
        assert!(s
            .set_real(&[VR_PARAM0], &[1000.0])
            .unwrap_err()
            .contains("fixed"));
        assert!(s.set_real(&[VR_FX], &[1.0]).unwrap_err().contains("output"));
        assert!(s.set_real(&[99], &[1.0]).unwrap_err().contains("unknown"));
        let mut out = [0.0; 2];
        s.get_real(&[VR_PARAM0 + 2, VR_PARAM0], &mut out).unwrap();
        assert_eq!(out, [2.0, 6000.0]);
    }
}
