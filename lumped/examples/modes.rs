//! Print the modes of the nominal machine at a few poses (with the body that moves most
//! and the joint strained most), for tuning.
use lumped::structure::{Body, Machine, CENTRE};
use nalgebra::DMatrix;
use num_complex::Complex64;
fn main() {
    let seed: Option<u64> = std::env::args().nth(1).and_then(|s| s.parse().ok());
    let m = seed.map(Machine::random).unwrap_or_else(Machine::nominal);
    for pose in [CENTRE, [0.0, 0.0, 0.0], [0.8, 0.6, 0.3]] {
        println!("pose {pose:?}");
        let asm = m.assemble(pose, 0.0);
        let modes = asm.modes();
        let top = modes.iter().map(|m| m.max_peak()).fold(0.0, f64::max);
        for md in &modes {
            if md.freq_hz > 6000.0 || md.max_peak() < 0.01 * top {
                continue;
            }
            let p = md.peak();
            // kinetic energy per body, strain energy per joint
            let mut ke = vec![0.0; asm.layout.dofs.len()];
            for b in 0..ke.len() {
                let o = asm.layout.offset(b);
                let d = asm.layout.dofs[b];
                let v = md.shape.rows(o, d);
                let mb = asm.m.view((o, o), (d, d)).map(|x| Complex64::new(x, 0.0));
                ke[b] = (v.adjoint() * mb * v)[(0, 0)].re;
            }
            let mut se = std::collections::BTreeMap::new();
            for c in &asm.layout.contacts {
                let t = asm.layout.contact_map(c).map(|x| Complex64::new(x, 0.0));
                let d = t * &md.shape;
                let kl = c.frame
                    * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::from(c.k))
                    * c.frame.transpose();
                let kd = DMatrix::from_iterator(3, 3, kl.iter().map(|&x| Complex64::new(x, 0.0)));
                *se.entry(c.joint.name()).or_insert(0.0) += (d.adjoint() * kd * &d)[(0, 0)].re;
            }
            let bmax = (0..ke.len())
                .max_by(|&a, &b| ke[a].total_cmp(&ke[b]))
                .unwrap();
            let bname = if bmax < 8 {
                format!("{:?}", Body::ALL[bmax])
            } else {
                "extra".into()
            };
            let tot: f64 = se.values().sum();
            let (jn, je) = se.iter().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
            println!(
                "{:8.1} Hz z {:5.2}% cx {:.3} ax {} pk {:8.2e} {:8.2e} {:8.2e} rel {:.3} {:8} {:14} {:.2}",
                md.freq_hz, 100.0 * md.zeta, md.complexity, md.axis(), p[0], p[1], p[2], md.max_peak() / top, bname, jn, je / tot
            );
        }
        println!(
            "{} modes total, max {:.0} Hz",
            modes.len(),
            modes.last().unwrap().freq_hz
        );
    }
}
