//! Nonlinearity on the second generator (`lumped`): a hardening cubic spring in a joint,
//! one impact record with two hits at each of three force levels (about 60, 300 and
//! 1200 N). The lightest level is buried in the accelerometer's noise at the low modes,
//! so the two-group split (light vs hard) found nothing; the per-level FRFs with the
//! sensor-noise variance (`level_evidence`), compared pairwise, show the levels disagree
//! and the response moving up with the force level. Judged against the generator's
//! answer (cause and kind; the mode it names is the one whose level disagreement the
//! data show, which for these seeds is not the generator's "most strained" mode at the
//! twin's band edge). A healthy impact test from another seed must stay `none`.

use identify::campaign::{identify_campaign, CampaignOptions};
use identify::diagnose::{diagnose, Cause, DiagnoseOptions};
use identify::read::read_timeseries;
use identify::timeseries::TimeSeries;
use identify::twin::Twin;
use lumped::effects::{case, Effect};
use lumped::measure::{impact_record, Setup};
use lumped::record::Record;
use lumped::structure::{Machine, CENTRE};
use std::path::Path;

/// The record as `mtwin` reads it (through its CSV file).
fn as_read(dir: &Path, name: &str, r: &Record) -> TimeSeries {
    let p = dir.join(name);
    r.write_csv(&p).expect("write csv");
    read_timeseries(&p).expect("read csv")
}

/// The healthy impact test at the centre that `bench/confusion.py`'s twin of `seed` is
/// identified from (`lumped::effects::write_diagnosis_material`).
fn centre_impacts(dir: &Path, m: &Machine, seed: u64) -> Vec<TimeSeries> {
    let setup = Setup::impact();
    [(0usize, "x"), (1, "y")]
        .iter()
        .map(|&(a, name)| {
            let r = impact_record(m, &setup, CENTRE, a, 5, 2.0, seed * 1000 + 700 + a as u64);
            as_read(dir, &format!("centre{seed}_{name}.csv"), &r)
        })
        .collect()
}

fn twin_of(recs: &[TimeSeries]) -> Twin {
    identify_campaign(recs, &CampaignOptions::default(), &|_, _| {})
        .expect("identify")
        .twin
}

#[test]
fn lumped_hardening_joint_at_three_force_levels_is_a_nonlinearity() {
    let dir = tempfile::tempdir().expect("tmp");
    let m = Machine::nominal();
    for seed in [4u64, 10] {
        let twin = twin_of(&centre_impacts(dir.path(), &m, seed));
        let c = case(&m, Effect::Nonlinearity, seed);
        let recs: Vec<TimeSeries> = c
            .records
            .iter()
            .map(|(n, r)| as_read(dir.path(), &format!("nl{seed}_{n}"), r))
            .collect();
        let (d, _) = diagnose(&twin, &recs, &DiagnoseOptions::default()).expect("diagnose");
        eprintln!("seed {seed}: {} {:?}", d.cause, d.details);
        assert_eq!(c.answer["cause"], "nonlinearity");
        assert_eq!(d.cause, Cause::Nonlinearity, "seed {seed}: {:?}", d.details);
        assert_eq!(
            d.details["kind"], c.answer["details"]["kind"],
            "seed {seed}"
        );
        assert!(
            d.details["level_disagreement"].as_f64().unwrap_or(0.0) >= 2.5,
            "{:?}",
            d.details
        );
        // a healthy impact test of the same machine (another seed's noise and hits)
        let healthy = centre_impacts(dir.path(), &m, seed + 1);
        let (h, _) = diagnose(&twin, &healthy, &DiagnoseOptions::default()).expect("diagnose");
        assert_eq!(
            h.cause,
            Cause::None,
            "healthy seed {}: {:?}",
            seed + 1,
            h.details
        );
    }
}
