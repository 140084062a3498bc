//! The null of the force-level test: for each seed, the impact record of `lumped`'s
//! `nonlinearity` case (the same hammer axis, hits at the same three force levels, the
//! same noise) made on the machine without its cubic spring
//! (`CaseOptions::linear_control`). Diagnosed against a healthy twin these data must come
//! back `none`: the force levels' FRFs disagree only by noise.
//!
//! Run: `cargo run --release -p lumped --example linear_levels -- OUT_DIR 1 2 3` (seeds):
//! writes `OUT_DIR/sSEED/imp_AXIS.csv`.
use lumped::effects::{case_with, CaseOptions, Effect};
use lumped::structure::Machine;

fn main() {
    let mut args = std::env::args().skip(1);
    let out = std::path::PathBuf::from(args.next().expect("OUT_DIR"));
    let seeds: Vec<u64> = args.filter_map(|s| s.parse().ok()).collect();
    let o = CaseOptions {
        linear_control: true,
        ..CaseOptions::default()
    };
    for s in seeds {
        let c = case_with(&Machine::nominal(), Effect::Nonlinearity, s, &o);
        let dir = out.join(format!("s{s}"));
        std::fs::create_dir_all(&dir).expect("mkdir");
        for (name, r) in &c.records {
            r.write_csv(&dir.join(name)).expect("write");
        }
    }
}
