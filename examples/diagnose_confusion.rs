//! Confusion table of `diagnose` on generated data with one hidden effect per case
//! (`vmachine::hidden`): rows = the effect hidden, columns = the cause found, over many
//! seeds; plus how often the reported numbers were right (frequency within 1 %, delay
//! within 10 %, the right axis/channel).
//!
//! `cargo run --release --example diagnose_confusion -- [SEEDS]` (default 10 per effect).

use identify::diagnose::{diagnose, DiagnoseOptions};
use std::time::Instant;
use vmachine::hidden::{base_twin, case, Effect, AXES};
use vmachine::structure::ModalMachine;

fn numbers_right(
    effect: Effect,
    truth: &serde_json::Map<String, serde_json::Value>,
    got: &serde_json::Map<String, serde_json::Value>,
) -> bool {
    let f =
        |m: &serde_json::Map<String, serde_json::Value>, k: &str| m.get(k).and_then(|v| v.as_f64());
    match effect {
        Effect::None => true,
        Effect::ModeChange => {
            matches!((f(truth, "new_freq_hz"), f(got, "new_freq_hz")), (Some(a), Some(b)) if (a - b).abs() < 0.01 * a)
        }
        Effect::UnmodeledMode => {
            matches!((f(truth, "freq_hz"), f(got, "freq_hz")), (Some(a), Some(b)) if (a - b).abs() < 0.01 * a)
        }
        Effect::TimeDelay => {
            matches!((f(truth, "delay_s"), f(got, "delay_s")), (Some(a), Some(b)) if (a - b).abs() < 0.1 * a)
        }
        Effect::Disturbance => {
            let want = truth["freq_hz"][0].as_f64().unwrap_or(f64::NAN);
            got.get("freq_hz")
                .and_then(|v| v.as_array())
                .is_some_and(|v| {
                    v.iter()
                        .filter_map(|x| x.as_f64())
                        .any(|x| (x - want).abs() < 0.01 * want)
                })
        }
        Effect::CrossCoupling => got.get("channel") == truth.get("channel"),
        Effect::PoseDependence => got.get("axis_of_variation") == truth.get("axis_of_variation"),
        Effect::Nonlinearity => got.get("kind") == truth.get("kind"),
    }
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let t0 = Instant::now();
    let base = base_twin(&ModalMachine::default_machine(), &AXES);
    let causes = [
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
    let mut table = vec![vec![0usize; causes.len()]; Effect::ALL.len()];
    let mut right = vec![0usize; Effect::ALL.len()];
    let opts = DiagnoseOptions::default();
    for (ei, e) in Effect::ALL.iter().enumerate() {
        for s in 0..seeds {
            let c = case(*e, 100 + s, &base);
            let (d, _) = match diagnose(&c.twin, &c.records, &opts) {
                Ok(x) => x,
                Err(err) => {
                    eprintln!("{} seed {s}: error {err}", e.code());
                    continue;
                }
            };
            let code = serde_json::to_value(d.cause)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            let ci = causes
                .iter()
                .position(|c| *c == code)
                .unwrap_or(causes.len() - 1);
            table[ei][ci] += 1;
            if code == e.code() && numbers_right(*e, &c.truth, &d.details) {
                right[ei] += 1;
            } else if std::env::var_os("MTWIN_CONFUSION_VERBOSE").is_some() {
                eprintln!(
                    "{} seed {s}: found {code}, truth {}, details {}",
                    e.code(),
                    serde_json::Value::Object(c.truth.clone()),
                    serde_json::Value::Object(d.details.clone())
                );
            }
        }
    }
    println!("## diagnose confusion table ({seeds} seeds per hidden effect, impact data)\n");
    print!("| hidden \\ found |");
    for c in &causes {
        print!(" {c} |");
    }
    println!(" numbers right |");
    print!("|---|");
    for _ in &causes {
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
        .map(|(ei, e)| table[ei][causes.iter().position(|c| *c == e.code()).unwrap_or(0)])
        .sum();
    println!(
        "\ncause right in {correct}/{} cases; {:.0} s",
        seeds as usize * Effect::ALL.len(),
        t0.elapsed().as_secs_f64()
    );
}
