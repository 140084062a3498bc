//! The lumped-mass machine: rigid bodies joined by point springs and discrete dampers,
//! laid out for a pose, assembled into `M`, `C`, `K` and the TCP map `G`.
//!
//! A bridge-type mill: the [`Body::Table`] travels along x on the [`Body::Bed`], a portal
//! ([`Body::Column`]) carries the [`Body::Rail`], the [`Body::Saddle`] travels along y on
//! the rail, the [`Body::Ram`] travels vertically in the saddle and holds the
//! [`Body::Spindle`] in two bearings; the [`Body::Tool`] (holder and tool) sits in the
//! spindle nose.
//!
//! Every body has six degrees of freedom (translation of its centre, small rotation);
//! a joint is a set of contact points, each a 3×3 spring and a 3×3 dashpot between the
//! two bodies' material points there. The relative displacement at a point `p` of a body
//! with centre `c` is `u − (p − c) × θ`, so stiffness, cross coupling and mode directions
//! follow from where the contacts sit: the guide carriages move with the axes, the ball
//! screws' shaft length to the nut changes, the ram's overhang grows with `z`.
//!
//! Pose `[x, y, z]` in metres: `x` the table, `y` the saddle along the rail, `z` the ram's
//! extension below its upper end (larger `z` = longer overhang). Workspace
//! `x ∈ [0, 0.8]`, `y ∈ [0, 0.6]`, `z ∈ [0, 0.3]`.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// Axis positions `[x, y, z]` in metres.
pub type Pose = [f64; 3];

/// The rigid bodies, in the order of their degrees of freedom.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Body {
    /// The machine bed, on levelling mounts.
    Bed,
    /// The table carrying the workpiece (x axis).
    Table,
    /// The portal uprights, bolted to the bed.
    Column,
    /// The cross-rail on top of the portal.
    Rail,
    /// The saddle / head carriage travelling along the rail (y axis).
    Saddle,
    /// The vertical ram in the saddle (z axis).
    Ram,
    /// Spindle shaft in its bearings.
    Spindle,
    /// Tool holder and tool, clamped in the spindle nose.
    Tool,
}

impl Body {
    /// Every body, in degree-of-freedom order.
    pub const ALL: [Body; 8] = [
        Body::Bed,
        Body::Table,
        Body::Column,
        Body::Rail,
        Body::Saddle,
        Body::Ram,
        Body::Spindle,
        Body::Tool,
    ];

    /// Position in [`Body::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The joints between bodies (each a set of contact points).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Joint {
    /// Bed on the floor: four levelling mounts.
    Foundation,
    /// Table carriages on the bed's rails (stiff across and normal to the rail).
    TableGuide,
    /// Ball screw of the x axis (axial stiffness depends on the nut position).
    TableScrew,
    /// Portal bolted to the bed.
    ColumnBase,
    /// Cross-rail bolted to the portal.
    RailMount,
    /// Saddle carriages on the cross-rail.
    SaddleGuide,
    /// Ball screw of the y axis.
    SaddleScrew,
    /// Ram rails in the saddle's carriages.
    RamGuide,
    /// Ball screw of the z axis.
    RamScrew,
    /// Front spindle bearing (radial and axial).
    FrontBearing,
    /// Rear spindle bearing (radial).
    RearBearing,
    /// Spindle drive (torsion).
    SpindleDrive,
    /// Holder taper and face in the spindle nose (HSK interface).
    ToolInterface,
    /// The spring of an [`ExtraMass`] at the tool tip (not in [`Joint::ALL`]; its
    /// parameters are the extra mass's).
    ExtraMass,
}

impl Joint {
    /// Every joint of the base structure, in the order of [`Machine::joints`].
    pub const ALL: [Joint; 13] = [
        Joint::Foundation,
        Joint::TableGuide,
        Joint::TableScrew,
        Joint::ColumnBase,
        Joint::RailMount,
        Joint::SaddleGuide,
        Joint::SaddleScrew,
        Joint::RamGuide,
        Joint::RamScrew,
        Joint::FrontBearing,
        Joint::RearBearing,
        Joint::SpindleDrive,
        Joint::ToolInterface,
    ];

    /// Position in [`Joint::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// A snake-case name for files and answers.
    pub fn name(self) -> &'static str {
        match self {
            Joint::Foundation => "foundation",
            Joint::TableGuide => "table_guide",
            Joint::TableScrew => "table_screw",
            Joint::ColumnBase => "column_base",
            Joint::RailMount => "rail_mount",
            Joint::SaddleGuide => "saddle_guide",
            Joint::SaddleScrew => "saddle_screw",
            Joint::RamGuide => "ram_guide",
            Joint::RamScrew => "ram_screw",
            Joint::FrontBearing => "front_bearing",
            Joint::RearBearing => "rear_bearing",
            Joint::SpindleDrive => "spindle_drive",
            Joint::ToolInterface => "tool_interface",
            Joint::ExtraMass => "extra_mass",
        }
    }
}

/// Mass and box dimensions of a body (its inertia is that of a solid box).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BodyParams {
    /// Mass (kg).
    pub mass: f64,
    /// Edge lengths along x, y, z (m).
    pub size: [f64; 3],
}

/// Stiffness (N/m) and dashpot (N s/m) of ONE contact point of a joint, along the joint's
/// principal directions (the world axes unless the joint is made oblique). For a ball
/// screw `k` is the bearing-and-nut stiffness in series with the shaft (see
/// [`Machine::screw_ea`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointParams {
    /// Stiffness along the principal directions.
    pub k: [f64; 3],
    /// Dashpot coefficients along the principal directions.
    pub c: [f64; 3],
}

/// A joint turned about a world axis: its principal directions no longer line up with
/// the axes, so forces along one axis move the TCP along another.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Oblique {
    /// The joint.
    pub joint: Joint,
    /// World axis of the rotation (0 = x, 1 = y, 2 = z).
    pub axis: usize,
    /// Angle (rad).
    pub angle_rad: f64,
}

/// A joint whose stiffness changes linearly with one axis position (a worn or uneven
/// guideway): factor `1 + slope · (pose[axis] − centre[axis])`, floored at 0.2.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseGradient {
    /// The joint.
    pub joint: Joint,
    /// The axis position it depends on (0 = x, 1 = y, 2 = z).
    pub axis: usize,
    /// Relative stiffness change per metre.
    pub slope_per_m: f64,
}

/// An extra mass on a spring at the tool tip (a new tool, holder or damper):
/// three translational degrees of freedom.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExtraMass {
    /// Mass (kg).
    pub mass: f64,
    /// Spring stiffness along x, y, z (N/m).
    pub k: [f64; 3],
    /// Dashpot coefficients along x, y, z (N s/m).
    pub c: [f64; 3],
}

/// A hardening cubic spring added at every contact point of a joint along one principal
/// direction: force `k3 δ³` (only in [`crate::sim`]'s nonlinear integration).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CubicSpring {
    /// The joint.
    pub joint: Joint,
    /// Principal direction (0, 1, 2).
    pub dir: usize,
    /// Cubic coefficient (N/m³).
    pub k3: f64,
}

/// Coulomb friction at every contact point of a joint along one direction,
/// force `f_c tanh(v / v0)` opposing the sliding velocity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Friction {
    /// The joint.
    pub joint: Joint,
    /// Principal direction (0, 1, 2).
    pub dir: usize,
    /// Friction force per contact (N).
    pub f_c: f64,
    /// Velocity of the smooth transition (m/s).
    pub v0: f64,
}

/// Geometric parameters (lengths in metres).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Geometry {
    /// Distance between the table's carriages along x.
    pub table_carriage_span: f64,
    /// Distance between the saddle's carriages along y.
    pub saddle_carriage_span: f64,
    /// Distance between the ram's carriages along z.
    pub ram_carriage_span: f64,
    /// Ram length.
    pub ram_length: f64,
    /// Distance between the spindle bearings.
    pub bearing_span: f64,
    /// Tool tip below the front bearing (holder + tool).
    pub stickout: f64,
}

/// The machine: bodies, joints, geometry and any hidden modifications.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// Per [`Body::ALL`].
    pub bodies: Vec<BodyParams>,
    /// Per [`Joint::ALL`].
    pub joints: Vec<JointParams>,
    /// Axial rigidity `E·A` of the x, y, z ball screws (N) (fixed–fixed mounting).
    pub screw_ea: [f64; 3],
    /// Geometry.
    pub geometry: Geometry,
    /// An oblique joint, if any.
    pub oblique: Option<Oblique>,
    /// A pose-dependent joint stiffness, if any.
    pub pose_gradient: Option<PoseGradient>,
    /// An extra tool-tip mass, if any.
    pub extra_mass: Option<ExtraMass>,
    /// A cubic spring, if any (time simulation only).
    pub cubic: Option<CubicSpring>,
    /// Coulomb friction, if any (time simulation only).
    pub friction: Option<Friction>,
}

/// Lower and upper limits of the workspace per axis (m).
pub const WORKSPACE: [[f64; 2]; 3] = [[0.0, 0.8], [0.0, 0.6], [0.0, 0.3]];

/// The workspace centre.
pub const CENTRE: Pose = [0.4, 0.3, 0.15];

/// One contact point of a joint at a pose.
#[derive(Clone, Debug)]
pub struct Contact {
    /// The joint it belongs to.
    pub joint: Joint,
    /// Body on one side (`None` = the floor).
    pub a: Option<usize>,
    /// Body on the other side.
    pub b: usize,
    /// World position (m).
    pub point: Vector3<f64>,
    /// Principal directions (columns) of the contact.
    pub frame: Matrix3<f64>,
    /// Stiffness along the principal directions.
    pub k: [f64; 3],
    /// Dashpots along the principal directions.
    pub c: [f64; 3],
}

/// The machine laid out at one pose.
#[derive(Clone, Debug)]
pub struct Layout {
    /// The pose.
    pub pose: Pose,
    /// Body centres (world) in degree-of-freedom order; the extra mass last if present.
    pub centres: Vec<Vector3<f64>>,
    /// Degrees of freedom per body (6, or 3 for the extra point mass).
    pub dofs: Vec<usize>,
    /// Every contact point.
    pub contacts: Vec<Contact>,
    /// The tool tip (world); the workpiece point on the table is the same point.
    pub tip: Vector3<f64>,
}

/// `M`, `C`, `K` and the TCP map at a pose.
#[derive(Clone, Debug)]
pub struct Assembly {
    /// The layout they come from.
    pub layout: Layout,
    /// Mass matrix.
    pub m: DMatrix<f64>,
    /// Damping matrix (discrete dashpots).
    pub c: DMatrix<f64>,
    /// Stiffness matrix.
    pub k: DMatrix<f64>,
    /// 3×n: relative displacement tool − workpiece at the TCP; a force pair `F` on the
    /// tool and `−F` on the workpiece is the generalised force `Gᵀ F`.
    pub g: DMatrix<f64>,
}

impl Assembly {
    /// Number of degrees of freedom.
    pub fn n(&self) -> usize {
        self.m.nrows()
    }
}

fn skew(r: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -r.z, r.y, r.z, 0.0, -r.x, -r.y, r.x, 0.0)
}

fn box_inertia(p: &BodyParams) -> [f64; 3] {
    let [a, b, c] = p.size;
    let m = p.mass / 12.0;
    [
        m * (b * b + c * c),
        m * (a * a + c * c),
        m * (a * a + b * b),
    ]
}

/// Fixed–fixed screw: shaft stiffness `EA/L1 + EA/L2` in series with bearings and nut.
fn screw_stiffness(k_bn: f64, ea: f64, l1: f64, total: f64) -> f64 {
    let l1 = l1.clamp(0.05, total - 0.05);
    let shaft = ea / l1 + ea / (total - l1);
    1.0 / (1.0 / k_bn + 1.0 / shaft)
}

impl Layout {
    /// Offset of a body's first degree of freedom.
    pub fn offset(&self, body: usize) -> usize {
        self.dofs[..body].iter().sum()
    }

    /// Total degrees of freedom.
    pub fn n(&self) -> usize {
        self.dofs.iter().sum()
    }

    /// 3×n map from the generalised coordinates to the displacement of the material
    /// point of `body` at world position `p`.
    pub fn point_map(&self, body: usize, p: &Vector3<f64>) -> DMatrix<f64> {
        let mut t = DMatrix::zeros(3, self.n());
        let o = self.offset(body);
        for i in 0..3 {
            t[(i, o + i)] = 1.0;
        }
        if self.dofs[body] == 6 {
            let s = -skew(&(p - self.centres[body]));
            t.view_mut((0, o + 3), (3, 3)).copy_from(&s);
        }
        t
    }

    /// 3×n map to the relative displacement (b − a) at a contact.
    pub fn contact_map(&self, c: &Contact) -> DMatrix<f64> {
        let mut t = self.point_map(c.b, &c.point);
        if let Some(a) = c.a {
            t -= self.point_map(a, &c.point);
        }
        t
    }
}

impl Machine {
    /// The fixed reference machine (about 9 modes at the TCP between 50 Hz and 3 kHz).
    pub fn nominal() -> Self {
        let b = |mass: f64, size: [f64; 3]| BodyParams { mass, size };
        let bodies = vec![
            b(4200.0, [2.4, 1.6, 0.6]),
            b(650.0, [1.2, 0.7, 0.25]),
            b(2600.0, [0.5, 2.0, 1.3]),
            b(1100.0, [0.4, 1.8, 0.45]),
            b(480.0, [0.3, 0.5, 0.7]),
            b(300.0, [0.26, 0.26, 1.2]),
            b(65.0, [0.16, 0.16, 0.5]),
            b(3.0, [0.06, 0.06, 0.23]),
        ];
        // k per contact point; c as loss time constant tau per joint: c = tau * k.
        let j = |k: [f64; 3], tau: f64| JointParams {
            k,
            c: [tau * k[0], tau * k[1], tau * k[2]],
        };
        let mut joints = vec![
            j([1.2e8, 1.2e8, 3.0e8], 4.0e-4),
            j([0.0, 5.0e8, 8.0e8], 3.5e-5),
            j([2.6e8, 0.0, 0.0], 6.0e-5),
            j([2.0e9, 2.0e9, 2.5e9], 1.2e-5),
            j([1.5e9, 1.5e9, 1.5e9], 1.0e-5),
            j([6.0e8, 0.0, 6.0e8], 2.5e-5),
            j([0.0, 2.4e8, 0.0], 5.0e-5),
            j([5.0e8, 5.0e8, 0.0], 2.0e-5),
            j([0.0, 0.0, 2.8e8], 4.0e-5),
            j([8.0e8, 8.0e8, 5.0e8], 1.0e-5),
            j([4.0e8, 4.0e8, 0.0], 1.4e-5),
            j([0.0, 2.0e6, 0.0], 1.0e-3),
            j([1.5e9, 1.5e9, 2.0e9], 4.0e-6),
        ];
        // rolling guides still have a little damping along their travel
        joints[Joint::TableGuide.index()].c[0] = 2.0e3;
        joints[Joint::SaddleGuide.index()].c[1] = 1.5e3;
        joints[Joint::RamGuide.index()].c[2] = 1.0e3;
        Machine {
            bodies,
            joints,
            screw_ea: [2.6e8, 2.6e8, 1.7e8],
            geometry: Geometry {
                table_carriage_span: 0.7,
                saddle_carriage_span: 0.4,
                ram_carriage_span: 0.5,
                ram_length: 1.2,
                bearing_span: 0.3,
                stickout: 0.15,
            },
            oblique: None,
            pose_gradient: None,
            extra_mass: None,
            cubic: None,
            friction: None,
        }
    }

    /// A machine drawn at random around [`Machine::nominal`] from `seed`: masses ±15 %,
    /// stiffnesses ×0.7…1.4, dashpots ×0.6…1.6 (independently, so the damping stays
    /// non-proportional), geometry ±10 %, screw rigidity ±20 %.
    pub fn random(seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut m = Self::nominal();
        let mut logu = |lo: f64, hi: f64| rng.gen_range(lo.ln()..hi.ln()).exp();
        for b in &mut m.bodies {
            b.mass *= logu(0.85, 1.15);
        }
        for j in &mut m.joints {
            for d in 0..3 {
                j.k[d] *= logu(0.7, 1.4);
                j.c[d] *= logu(0.6, 1.6);
            }
        }
        for e in &mut m.screw_ea {
            *e *= logu(0.8, 1.2);
        }
        let g = &mut m.geometry;
        for v in [
            &mut g.table_carriage_span,
            &mut g.saddle_carriage_span,
            &mut g.ram_carriage_span,
            &mut g.ram_length,
            &mut g.bearing_span,
            &mut g.stickout,
        ] {
            *v *= logu(0.9, 1.1);
        }
        m
    }

    /// This machine with one joint's stiffness scaled by `factor` (all directions).
    pub fn with_joint_stiffness(mut self, joint: Joint, factor: f64) -> Self {
        for k in &mut self.joints[joint.index()].k {
            *k *= factor;
        }
        self
    }

    /// This machine with one joint's dashpots scaled by `factor`.
    pub fn with_joint_damping(mut self, joint: Joint, factor: f64) -> Self {
        for c in &mut self.joints[joint.index()].c {
            *c *= factor;
        }
        self
    }

    /// Lay the machine out at `pose`.
    pub fn layout(&self, pose: Pose) -> Layout {
        let [x, y, z] = pose;
        let g = &self.geometry;
        let v = Vector3::new;
        let xt = x - 0.4; // table centre along x
        let ys = y - 0.3; // saddle centre along y
        let zr = 1.95 - z; // ram centre height
        let zb = zr - g.ram_length / 2.0; // front bearing (ram nose)
        let centres = vec![
            v(0.0, 0.0, 0.3),
            v(xt, 0.0, 0.775),
            v(-0.5, 0.0, 1.25),
            v(-0.35, 0.0, 2.0),
            v(0.0, ys, 2.0),
            v(0.28, ys, zr),
            v(0.28, ys, zb + g.bearing_span / 2.0),
            v(0.28, ys, zb + (0.08 - g.stickout) / 2.0),
        ];
        let mut dofs = vec![6; 8];
        let tip = v(0.28, ys, zb - g.stickout);
        let mut contacts = Vec::new();
        let mut add = |joint: Joint, a: Option<Body>, b: Body, p: Vector3<f64>, kf: f64| {
            let jp = &self.joints[joint.index()];
            let mut factor = kf;
            if let Some(pg) = &self.pose_gradient {
                if pg.joint == joint {
                    factor *= (1.0 + pg.slope_per_m * (pose[pg.axis] - CENTRE[pg.axis])).max(0.2);
                }
            }
            let frame = match &self.oblique {
                Some(o) if o.joint == joint => {
                    let ax = match o.axis {
                        0 => Vector3::x_axis(),
                        1 => Vector3::y_axis(),
                        _ => Vector3::z_axis(),
                    };
                    *Rotation3::from_axis_angle(&ax, o.angle_rad).matrix()
                }
                _ => Matrix3::identity(),
            };
            contacts.push(Contact {
                joint,
                a: a.map(Body::index),
                b: b.index(),
                point: p,
                frame,
                k: jp.k.map(|k| k * factor),
                c: jp.c,
            });
        };
        use Body::*;
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                add(
                    Joint::Foundation,
                    None,
                    Bed,
                    v(1.0 * sx, 0.65 * sy, 0.0),
                    1.0,
                );
                let tx = xt + sx * g.table_carriage_span / 2.0;
                add(
                    Joint::TableGuide,
                    Some(Bed),
                    Table,
                    v(tx, 0.25 * sy, 0.65),
                    1.0,
                );
                add(
                    Joint::ColumnBase,
                    Some(Bed),
                    Column,
                    v(-0.5 + 0.25 * sx, 0.9 * sy, 0.6),
                    1.0,
                );
                add(
                    Joint::RailMount,
                    Some(Column),
                    Rail,
                    v(-0.45, 0.85 * sy, 2.0 + 0.15 * sx),
                    1.0,
                );
                let gy = ys + sy * g.saddle_carriage_span / 2.0;
                add(
                    Joint::SaddleGuide,
                    Some(Rail),
                    Saddle,
                    v(-0.15, gy, 2.0 + 0.2 * sx),
                    1.0,
                );
                let gz = 2.0 + sx * g.ram_carriage_span / 2.0;
                add(
                    Joint::RamGuide,
                    Some(Saddle),
                    Ram,
                    v(0.15, ys + 0.1 * sy, gz),
                    1.0,
                );
            }
        }
        // ball screws, fixed-fixed; the factor turns k_bn into the series stiffness
        let ea = self.screw_ea;
        let kx = self.joints[Joint::TableScrew.index()].k[0];
        let fx = screw_stiffness(kx, ea[0], xt + 0.9, 1.8) / kx.max(f64::MIN_POSITIVE);
        add(Joint::TableScrew, Some(Bed), Table, v(xt, 0.0, 0.65), fx);
        let ky = self.joints[Joint::SaddleScrew.index()].k[1];
        let fy = screw_stiffness(ky, ea[1], ys + 0.9, 1.8) / ky.max(f64::MIN_POSITIVE);
        add(
            Joint::SaddleScrew,
            Some(Rail),
            Saddle,
            v(-0.15, ys, 2.0),
            fy,
        );
        let kz = self.joints[Joint::RamScrew.index()].k[2];
        let fz = screw_stiffness(kz, ea[2], 0.3 + z, 1.0) / kz.max(f64::MIN_POSITIVE);
        add(Joint::RamScrew, Some(Saddle), Ram, v(0.28, ys, 2.35), fz);
        add(
            Joint::FrontBearing,
            Some(Ram),
            Spindle,
            v(0.28, ys, zb),
            1.0,
        );
        add(
            Joint::RearBearing,
            Some(Ram),
            Spindle,
            v(0.28, ys, zb + g.bearing_span),
            1.0,
        );
        add(
            Joint::SpindleDrive,
            Some(Ram),
            Spindle,
            v(0.33, ys, zb + g.bearing_span + 0.05),
            1.0,
        );
        add(
            Joint::ToolInterface,
            Some(Spindle),
            Tool,
            v(0.28, ys, zb),
            1.0,
        );
        add(
            Joint::ToolInterface,
            Some(Spindle),
            Tool,
            v(0.28, ys, zb + 0.08),
            1.0,
        );
        // drive key, off the axis: holds the holder's rotation about z
        add(
            Joint::ToolInterface,
            Some(Spindle),
            Tool,
            v(0.31, ys, zb + 0.01),
            0.05,
        );
        let mut centres = centres;
        if let Some(e) = &self.extra_mass {
            centres.push(tip);
            dofs.push(3);
            contacts.push(Contact {
                joint: Joint::ExtraMass,
                a: Some(Tool.index()),
                b: 8,
                point: tip,
                frame: Matrix3::identity(),
                k: e.k,
                c: e.c,
            });
        }
        Layout {
            pose,
            centres,
            dofs,
            contacts,
            tip,
        }
    }

    /// `M`, `C`, `K` and the TCP map at `pose`, with a point mass `tip_mass` (kg) at the
    /// tool tip (an accelerometer; 0 for none).
    pub fn assemble(&self, pose: Pose, tip_mass: f64) -> Assembly {
        let layout = self.layout(pose);
        let n = layout.n();
        let mut m = DMatrix::zeros(n, n);
        for (i, bp) in self.bodies.iter().enumerate() {
            let o = layout.offset(i);
            for d in 0..3 {
                m[(o + d, o + d)] = bp.mass;
            }
            let inertia = box_inertia(bp);
            for d in 0..3 {
                m[(o + 3 + d, o + 3 + d)] = inertia[d];
            }
        }
        if let Some(e) = &self.extra_mass {
            let o = layout.offset(8);
            for d in 0..3 {
                m[(o + d, o + d)] = e.mass;
            }
        }
        if tip_mass > 0.0 {
            let t = layout.point_map(Body::Tool.index(), &layout.tip);
            m += t.transpose() * &t * tip_mass;
        }
        let mut k = DMatrix::zeros(n, n);
        let mut c = DMatrix::zeros(n, n);
        for ct in &layout.contacts {
            let t = layout.contact_map(ct);
            let kl = ct.frame * Matrix3::from_diagonal(&Vector3::from(ct.k)) * ct.frame.transpose();
            let cl = ct.frame * Matrix3::from_diagonal(&Vector3::from(ct.c)) * ct.frame.transpose();
            let kd = DMatrix::from_iterator(3, 3, kl.iter().copied());
            let cd = DMatrix::from_iterator(3, 3, cl.iter().copied());
            k += t.transpose() * kd * &t;
            c += t.transpose() * cd * &t;
        }
        let g = layout.point_map(Body::Tool.index(), &layout.tip)
            - layout.point_map(Body::Table.index(), &layout.tip);
        Assembly { layout, m, c, k, g }
    }
}
