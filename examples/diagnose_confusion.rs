//! Confusion tables of `diagnose` on generated data with one hidden effect per case
//! (`vmachine::hidden`): rows = the effect hidden, columns = the cause found, over many
//! seeds; plus how often the reported numbers were right (frequencies within 1 %, 2 %
//! for the nonlinear mode, delay within 10 %, a pose-dependence rate within 20 % or
//! 5 %/m, the right kind/axis/channel).
//!
//! `cargo run --release --example diagnose_confusion -- [SEEDS] [impact|milling|both]`
//! (default 10 seeds per effect, both tables: impact tests, then milling).
//! `MTWIN_CONFUSION_VERBOSE=1` prints every miss with its numbers;
//! `MTWIN_CONFUSION_ONLY=mode_change,none` runs only those rows.

use identify::diagnose::{diagnose, DiagnoseOptions};
use serde_json::{Map, Value};
use std::time::Instant;
use vmachine::hidden::{case, milling_case, Case, Effect};

// the base twins, identified as the tests identify them
#[path = "../identify/tests/common/hidden_base.rs"]
mod hidden_base;

const CAUSES: [&str; 9] = [
    "none",
    "mode_change",
    "unmodeled_mode",
    "time_delay",
    "disturbance",
    "cross_coupling",
    "pose_dependence",
    "nonlinearity",
    "unexplained",
];

/// Every number the truth holds, checked against what diagnose reported.
fn numbers_right(truth: &Map<String, Value>, got: &Map<String, Value>) -> bool {
    let num = |m: &Map<String, Value>, k: &str| m.get(k).and_then(Value::as_f64);
    let close = |a: f64, b: f64, rel: f64| (a - b).abs() < rel * a.abs();
    truth.iter().all(|(k, want)| match (k.as_str(), want) {
        ("freq_hz", Value::Array(v)) => {
            // disturbance: each true frequency among the found ones
            let found: Vec<f64> = got
                .get(k)
                .and_then(Value::as_array)
                .map(|g| g.iter().filter_map(Value::as_f64).collect())
                .unwrap_or_default();
            v.iter()
                .filter_map(Value::as_f64)
                .all(|w| found.iter().any(|g| close(w, *g, 0.01)))
        }
        ("channel", Value::Array(v)) => got.get(k).is_some_and(|g| v.contains(g)),
        ("freq_shift_pct_per_m", Value::Array(v)) => {
            // the true rate of the mode diagnose names
            let mode = got.get("mode").and_then(Value::as_u64);
            match (mode.and_then(|m| v.get(m as usize)?.as_f64()), num(got, k)) {
                (Some(w), Some(g)) => (w - g).abs() < (0.2 * w.abs()).max(5.0),
                _ => false,
            }
        }
        ("freq_hz", _) if truth.contains_key("kind") => {
            matches!((want.as_f64(), num(got, k)), (Some(w), Some(g)) if close(w, g, 0.02))
        }
        ("freq_hz" | "new_freq_hz", _) => {
            matches!((want.as_f64(), num(got, k)), (Some(w), Some(g)) if close(w, g, 0.01))
        }
        ("delay_s", _) => {
            matches!((want.as_f64(), num(got, k)), (Some(w), Some(g)) if close(w, g, 0.1))
        }
        ("channel" | "axis_of_variation" | "kind", _) => got.get(k) == Some(want),
        // damping and the axis a mode moves along are reported, not scored
        _ => true,
    })
}

fn table(kind: &str, seeds: u64, make: &dyn Fn(Effect, u64) -> Case) {
    let t0 = Instant::now();
    let mut table = vec![vec![0usize; CAUSES.len()]; Effect::ALL.len()];
    let mut right = vec![0usize; Effect::ALL.len()];
    let opts = DiagnoseOptions::default();
    let only = std::env::var("MTWIN_CONFUSION_ONLY").ok();
    for (ei, e) in Effect::ALL.iter().enumerate() {
        if only
            .as_ref()
            .is_some_and(|o| !o.split(',').any(|c| c == e.code()))
        {
            continue;
        }
        for s in 0..seeds {
            let c = make(*e, 100 + s);
            let (d, _) = match diagnose(&c.twin, &c.records, &opts) {
                Ok(x) => x,
                Err(err) => {
                    eprintln!("{kind} {} seed {s}: error {err}", e.code());
                    continue;
                }
            };
            let code = serde_json::to_value(d.cause)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            let ci = CAUSES
                .iter()
                .position(|c| *c == code)
                .unwrap_or(CAUSES.len() - 1);
            table[ei][ci] += 1;
            if code == e.code() && numbers_right(&c.truth, &d.details) {
                right[ei] += 1;
            } else if std::env::var_os("MTWIN_CONFUSION_VERBOSE").is_some() {
                eprintln!(
                    "{kind} {} seed {s}: found {code} (held-out fit {:.1} -> {:.1} %), truth {}, details {}",
                    e.code(),
                    d.fit_before_pct,
                    d.fit_after_pct,
                    Value::Object(c.truth.clone()),
                    Value::Object(d.details.clone())
                );
            }
        }
    }
    println!("## diagnose confusion table ({seeds} seeds per hidden effect, {kind} data)\n");
    print!("| hidden \\ found |");
    for c in &CAUSES {
        print!(" {c} |");
    }
    println!(" numbers right |");
    print!("|---|");
    for _ in &CAUSES {
        print!("---:|");
    }
    println!("---:|");
    for (ei, e) in Effect::ALL.iter().enumerate() {
        print!("| {} |", e.code());
        for n in &table[ei] {
            print!(" {n} |");
        }
        println!(" {}/{} |", right[ei], seeds);
    }
    let correct: usize = Effect::ALL
        .iter()
        .enumerate()
        .map(|(ei, e)| table[ei][CAUSES.iter().position(|c| *c == e.code()).unwrap_or(0)])
        .sum();
    println!(
        "\ncause right in {correct}/{} cases; {:.0} s\n",
        seeds as usize * Effect::ALL.len(),
        t0.elapsed().as_secs_f64()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10);
    let which = args.get(2).map_or("both", String::as_str);
    let base = hidden_base::base_twins();
    if matches!(which, "impact" | "both") {
        table("impact", seeds, &|e, s| case(e, s, &base));
    }
    if matches!(which, "milling" | "both") {
        table("milling", seeds, &|e, s| milling_case(e, s, &base.xy));
    }
}
