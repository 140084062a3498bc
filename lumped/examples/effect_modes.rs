//! The modes at the centre of the nominal machine and of the machine one hidden effect of
//! `cases` made (same seed), with each direct channel's peak: what an effect did to the
//! structure, for reading a diagnosis against it.
//!
//! ```sh
//! cargo run --release -p lumped --example effect_modes -- SEED EFFECT
//! ```
//! (EFFECT: a folder name of `cases`, e.g. `unmodeled_mode`.)
use lumped::effects::{case, Effect};
use lumped::structure::{Machine, CENTRE};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: effect_modes SEED EFFECT";
    let seed: u64 = args.first().ok_or(usage)?.parse()?;
    let name = args.get(1).ok_or(usage)?;
    let effect = Effect::ALL
        .into_iter()
        .find(|e| e.folder() == name)
        .ok_or_else(|| format!("no effect {name:?}; {usage}"))?;
    let base = Machine::nominal();
    let c = case(&base, effect, seed);
    println!("answer: {}", c.answer);
    for (what, m) in [("nominal", &base), ("with the effect", &c.machine)] {
        println!("{what}: f [Hz], zeta, peak x/y/z [m/N]");
        for md in m
            .modes(CENTRE)
            .iter()
            .filter(|d| !d.real && d.freq_hz < 3000.0)
        {
            let p = md.peak();
            println!(
                "  {:8.1} {:.4}  {:.2e} {:.2e} {:.2e}",
                md.freq_hz, md.zeta, p[0], p[1], p[2]
            );
        }
    }
    Ok(())
}
