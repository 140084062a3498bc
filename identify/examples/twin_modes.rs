//! The modes of a twin at a pose (interpolated as `mtwin eval` does): frequency, damping
//! and each channel's peak contribution `|N(jωn)| / |den(jωn)|` (the mode's receptance at
//! its own frequency), to see what the interpolation makes of tracked and frozen modes.
//!
//! Run: `cargo run --release -p identify --example twin_modes -- TWIN.json X,Y,Z [FMIN FMAX]`

use identify::twin::Twin;
use num_complex::Complex64;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let twin = Twin::load(std::path::Path::new(&a[1])).expect("twin loads");
    let p: Vec<f64> = a[2].split(',').map(|x| x.parse().expect("pose")).collect();
    let lo: f64 = a.get(3).map_or(0.0, |x| x.parse().expect("fmin"));
    let hi: f64 = a.get(4).map_or(f64::INFINITY, |x| x.parse().expect("fmax"));
    let m = twin.model_at([p[0], p[1], p[2]]).expect("model");
    for (k, md) in m.modes.iter().enumerate() {
        let f = md.freq_hz();
        if f < lo || f > hi {
            continue;
        }
        let s = Complex64::new(0.0, md.wn);
        let peaks: Vec<String> = m
            .channels
            .iter()
            .map(|c| {
                let n = c.num[k];
                let v = (Complex64::new(n.b0, 0.0) + s * n.b1) / md.den(s);
                format!(
                    "{} {:.2e} {:+4.0}°",
                    c.channel.name(),
                    v.norm(),
                    v.arg().to_degrees()
                )
            })
            .collect();
        println!("[{k:2}] {f:8.2} Hz {:6.4}  {}", md.zeta, peaks.join("  "));
    }
}
