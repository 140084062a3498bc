//! The modes of a twin at a pose (interpolated as `mtwin eval` does): frequency, damping
//! and each channel's peak (`ModalModel::mode_peak`: the mode's receptance at its own
//! frequency), to see what the interpolation makes of tracked and frozen modes.
//!
//! Run: `cargo run --release -p identify --example twin_modes -- TWIN.json X,Y,Z [FMIN FMAX]`

use identify::twin::Twin;

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
        let peaks: Vec<String> = (0..m.channels.len())
            .map(|ci| {
                format!(
                    "{} {:.2e}",
                    m.channels[ci].channel.name(),
                    m.mode_peak(ci, k)
                )
            })
            .collect();
        println!("[{k:2}] {f:8.2} Hz {:6.4}  {}", md.zeta, peaks.join("  "));
    }
}
