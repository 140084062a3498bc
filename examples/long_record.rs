//! Writes a long continuous-excitation time-series CSV (docs/formats.md, "Time-series CSV") straight to disk,
//! one row at a time (memory does not grow with the record), for `scripts/bench_memory.sh`.
//!
//! ```sh
//! cargo run --release --example long_record -- 600 rec.csv            # 10 min, 25.6 kHz, fx fy ax ay
//! cargo run --release --example long_record -- 60 rec.csv --fs 25600 --axes x   # fx ax only
//! ```
//!
//! Forces: seeded white noise (a shaker with random drive, one independent force per
//! axis). Responses: two lightly damped modes per axis (discrete resonators), a small
//! direct feedthrough of the other axis's force and additive sensor noise. Times
//! are `i / fs` with 10 decimals, values with 7 significant digits, as a data logger
//! writes them.

use std::f64::consts::PI;
use std::io::{BufWriter, Write};
use std::process::ExitCode;

/// A discrete two-pole resonator `y[n] = a1 y[n-1] + a2 y[n-2] + g x[n-1]`.
#[derive(Debug, Clone, Copy)]
struct Resonator {
    a1: f64,
    a2: f64,
    g: f64,
    y1: f64,
    y2: f64,
    x1: f64,
}

impl Resonator {
    fn new(f_hz: f64, zeta: f64, fs: f64, gain: f64) -> Self {
        let w = 2.0 * PI * f_hz / fs;
        let r = (-zeta * w).exp();
        Resonator {
            a1: 2.0 * r * (w * (1.0 - zeta * zeta).sqrt()).cos(),
            a2: -r * r,
            g: gain,
            y1: 0.0,
            y2: 0.0,
            x1: 0.0,
        }
    }

    fn step(&mut self, x: f64) -> f64 {
        let y = self.a1 * self.y1 + self.a2 * self.y2 + self.g * self.x1;
        self.y2 = self.y1;
        self.y1 = y;
        self.x1 = x;
        y
    }
}

/// xorshift64* uniform numbers and Box–Muller normals (seeded, no dependencies).
#[derive(Debug)]
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn gauss(&mut self) -> f64 {
        (-2.0 * self.uniform().ln()).sqrt() * (2.0 * PI * self.uniform()).cos()
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: long_record SECONDS OUT.csv [--fs HZ] [--axes x|xy]";
    let (Some(secs), Some(out)) = (
        args.first().and_then(|s| s.parse::<f64>().ok()),
        args.get(1),
    ) else {
        eprintln!("{usage}");
        return ExitCode::from(2);
    };
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
    };
    let fs: f64 = opt("--fs").and_then(|s| s.parse().ok()).unwrap_or(25_600.0);
    let two = opt("--axes").is_none_or(|a| a == "xy");
    match write(secs, fs, two, out) {
        Ok(rows) => {
            eprintln!("{out}: {rows} rows, {secs} s at {fs} Hz");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("long_record: {out}: {e}");
            ExitCode::from(1)
        }
    }
}

fn write(secs: f64, fs: f64, two: bool, out: &str) -> std::io::Result<u64> {
    let rows = (secs * fs).round() as u64;
    let mut w = BufWriter::with_capacity(1 << 20, std::fs::File::create(out)?);
    writeln!(
        w,
        "# long_record: {secs} s at {fs} Hz, random force, two modes per axis"
    )?;
    writeln!(w, "{}", if two { "t,fx,fy,ax,ay" } else { "t,fx,ax" })?;
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut modes = [
        [
            Resonator::new(180.0, 0.02, fs, 1.0),
            Resonator::new(1250.0, 0.03, fs, 0.6),
        ],
        [
            Resonator::new(240.0, 0.025, fs, 1.0),
            Resonator::new(2100.0, 0.02, fs, 0.4),
        ],
    ];
    for i in 0..rows {
        let f = [20.0 * rng.gauss(), 15.0 * rng.gauss()];
        let resp: Vec<f64> = (0..2)
            .map(|a| {
                let own = modes[a].iter_mut().map(|m| m.step(f[a])).sum::<f64>();
                own + 0.3 * f[1 - a] * 1e-3
            })
            .collect();
        let t = i as f64 / fs;
        if two {
            writeln!(
                w,
                "{t:.10},{:.6e},{:.6e},{:.6e},{:.6e}",
                f[0],
                f[1],
                resp[0] + 0.01 * rng.gauss(),
                resp[1] + 0.01 * rng.gauss()
            )?;
        } else {
            writeln!(
                w,
                "{t:.10},{:.6e},{:.6e}",
                f[0],
                resp[0] + 0.01 * rng.gauss()
            )?;
        }
    }
    w.flush()?;
    Ok(rows)
}
