//! Fuzzing the readers: arbitrary bytes and structured mutations of valid files (bytes
//! flipped, inserted, deleted; truncation; lines duplicated, dropped or swapped; numbers
//! replaced by NaN, Inf, 1e308, huge exponents, junk).
//!
//! Property for every reader: it never panics; it returns `Ok` or `Err`; an `Ok` result
//! holds only finite numbers (and a twin passes `validate`); an `Err` names the file.
//!
//! The streamed time-series reader (`scan_timeseries`) agrees with the in-memory one on
//! the same bytes: both read the file (same rows, start and step) or both fail with the
//! same message — except where their typical time step differs by design (median of the
//! first three steps when streamed, of all steps in memory).
//!
//! The default case count is small so `cargo test` stays fast; `PROPTEST_CASES=N` raises
//! it (`scripts/fuzz.sh` does). Fixed inputs that once failed are regression tests at
//! the end of the file.

use identify::axis::{Axis, Channel};
use identify::frf::{Frf, FrfChannel};
use identify::interpolate::TwinEvaluator;
use identify::read::{
    format_frf_csv, format_timeseries, parse_frf_csv, parse_timeseries, read_timeseries,
    scan_timeseries,
};
use identify::timeseries::{ResponseKind, TimeSeries};
use identify::twin::Twin;
use identify::uff::{
    format_uff58, format_uff58b, frf_from_uff, parse_uff58, uff_from_frf, UffFunction, UffSelect,
    DATA_ACCELERATION, DATA_VELOCITY,
};
use num_complex::Complex64;
use proptest::prelude::*;
use std::path::Path;
use std::sync::OnceLock;
use vmachine::structure::ModalMachine;

/// File name every input is parsed under; errors must name it.
const NAME: &str = "fuzz dir/inpüt.dat";

fn path() -> &'static Path {
    Path::new(NAME)
}

/// Cases per property: `PROPTEST_CASES` or `default`.
fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

fn config(default: u32) -> ProptestConfig {
    ProptestConfig {
        cases: cases(default),
        // a failure is minimised, but never for long
        max_shrink_iters: 2000,
        ..ProptestConfig::default()
    }
}

// ---------------------------------------------------------------------------------------
// Properties of the results
// ---------------------------------------------------------------------------------------

fn err_names_file(e: &identify::Error) -> Result<(), String> {
    let m = e.to_string();
    if m.contains("inpüt.dat") {
        Ok(())
    } else {
        Err(format!("error does not name the file: {m}"))
    }
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn check_timeseries(r: &identify::Result<TimeSeries>) -> Result<(), String> {
    let ts = match r {
        Ok(ts) => ts,
        Err(e) => return err_names_file(e),
    };
    let n = ts.len();
    if !(ts.t0.is_finite() && ts.dt.is_finite() && ts.dt > 0.0 && ts.fs().is_finite()) {
        return Err(format!(
            "t0 {} dt {} fs {} not finite/positive",
            ts.t0,
            ts.dt,
            ts.fs()
        ));
    }
    let last = ts.t0 + (n as f64 - 1.0) * ts.dt;
    if !last.is_finite() {
        return Err(format!("time of the last sample {last} is not finite"));
    }
    for v in ts
        .force
        .iter()
        .chain(&ts.response)
        .chain(&ts.position)
        .flatten()
    {
        if v.len() != n {
            return Err(format!("column length {} != {n}", v.len()));
        }
        if !all_finite(v) {
            return Err("non-finite sample".into());
        }
    }
    if ts.force_axes().is_empty() {
        return Err("no force column in an Ok record".into());
    }
    Ok(())
}

/// A time-step error (the typical step differs between the two readers by design).
fn is_step_error(e: &identify::Error) -> bool {
    e.to_string().contains("differs by more than 1 % from the")
}

/// `bytes` as a file read by both time-series readers: see the module docs.
fn check_stream_agrees(bytes: &[u8]) -> Result<(), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let p = dir.path().join("inpüt.dat");
    std::fs::write(&p, bytes).map_err(|e| e.to_string())?;
    match (read_timeseries(&p), scan_timeseries(&p)) {
        (Ok(ts), Ok(scan)) => {
            if (ts.len(), ts.t0.to_bits(), ts.dt.to_bits())
                != (scan.rows, scan.t0.to_bits(), scan.dt.to_bits())
            {
                return Err(format!(
                    "in memory {} rows t0 {} dt {}, streamed {} rows t0 {} dt {}",
                    ts.len(),
                    ts.t0,
                    ts.dt,
                    scan.rows,
                    scan.t0,
                    scan.dt
                ));
            }
            Ok(())
        }
        (Err(a), Err(b)) if a.to_string() == b.to_string() => Ok(()),
        (Err(a), Err(b)) if is_step_error(&a) && is_step_error(&b) => Ok(()),
        (Err(e), Ok(_)) | (Ok(_), Err(e)) if is_step_error(&e) => Ok(()),
        (a, b) => Err(format!(
            "in memory: {:?}\nstreamed: {:?}",
            a.map(|t| t.len()),
            b.map(|s| s.rows)
        )),
    }
}

fn check_frf_value(frf: &Frf) -> Result<(), String> {
    let n = frf.freqs_hz.len();
    if n == 0 {
        return Err("empty FRF".into());
    }
    if !all_finite(&frf.freqs_hz) || frf.freqs_hz.iter().any(|f| *f < 0.0) {
        return Err("frequency not finite or negative".into());
    }
    if frf.freqs_hz.windows(2).any(|w| w[1] <= w[0]) {
        return Err("frequencies not strictly increasing".into());
    }
    for c in &frf.channels {
        if c.h.len() != n {
            return Err(format!(
                "channel {} has {} values, grid {n}",
                c.channel,
                c.h.len()
            ));
        }
        if !c.h.iter().all(|z| z.re.is_finite() && z.im.is_finite()) {
            return Err(format!("channel {}: non-finite value", c.channel));
        }
        if let Some(g) = &c.coherence {
            if g.len() != n || !g.iter().all(|v| (0.0..=1.0).contains(v)) {
                return Err(format!("channel {}: coherence outside [0, 1]", c.channel));
            }
        }
    }
    Ok(())
}

fn check_frf(r: &identify::Result<Frf>) -> Result<(), String> {
    match r {
        Ok(frf) => check_frf_value(frf),
        Err(e) => err_names_file(e),
    }
}

fn check_uff(r: &identify::Result<Vec<UffFunction>>) -> Result<(), String> {
    let funcs = match r {
        Ok(f) => f,
        Err(e) => return err_names_file(e),
    };
    if funcs.is_empty() {
        return Err("Ok with no function".into());
    }
    for f in funcs {
        if f.abscissa.len() != f.data.len() || f.data.is_empty() {
            return Err("abscissa/data length mismatch".into());
        }
        if !all_finite(&f.abscissa) || !f.z_value.is_finite() {
            return Err(format!("{}: non-finite abscissa", f.line));
        }
        if !f.data.iter().all(|z| z.re.is_finite() && z.im.is_finite()) {
            return Err(format!("{}: non-finite data", f.line));
        }
    }
    // the conversion to receptance must not make numbers infinite either
    for assume in [DATA_ACCELERATION, DATA_VELOCITY] {
        let sel = UffSelect {
            assume_ordinate: Some(assume),
            ..UffSelect::default()
        };
        if let Ok(frf) = frf_from_uff(funcs, &sel) {
            if frf.freqs_hz.is_empty() {
                continue; // nothing left after dropping 0 Hz: the caller reports it
            }
            check_frf_value(&frf).map_err(|e| format!("frf_from_uff: {e}"))?;
        }
    }
    Ok(())
}

fn check_twin(r: &identify::Result<Twin>) -> Result<(), String> {
    let twin = match r {
        Ok(t) => t,
        Err(e) => return err_names_file(e),
    };
    twin.validate(path())
        .map_err(|e| format!("validate: {e}"))?;
    for p in &twin.poses {
        if !all_finite(&p.pose) || !all_finite(&p.band_hz) {
            return Err("non-finite pose or band".into());
        }
        // the stored FRF is used by later refits: one value per line, lines increasing
        // (an empty FRF is allowed: a twin built in memory may have none)
        if !p.frf.freqs_hz.is_empty() {
            check_frf_value(&p.frf).map_err(|e| format!("stored FRF: {e}"))?;
        }
    }
    // using the twin must not panic either
    if let Ok(mut ev) = TwinEvaluator::new(twin) {
        let m = ev.model_at([0.1, 0.2, 0.3]).clone();
        if !m.is_valid() {
            return Err("interpolated model invalid".into());
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Valid files
// ---------------------------------------------------------------------------------------

fn valid_timeseries(vals: &[f64], t0: f64, dt: f64, disp: bool) -> String {
    let n = vals.len();
    let col = |k: f64| -> Vec<f64> { vals.iter().map(|v| v * k + 0.5 * k).collect() };
    let ts = TimeSeries {
        source: String::new(),
        t0,
        dt,
        force: [Some(col(1.0)), None, Some(col(-3.0))],
        response: [Some(col(1e-3)), Some(col(2e-6)), None],
        response_kind: Some(if disp {
            ResponseKind::Displacement
        } else {
            ResponseKind::Acceleration
        }),
        position: [Some(vec![0.1; n]), None, None],
        comments: vec!["sensor=fuzz".into()],
    };
    format_timeseries(&ts).expect("valid record formats")
}

fn valid_frf(vals: &[f64], f0: f64, df: f64) -> Frf {
    let n = vals.len();
    Frf {
        freqs_hz: (0..n).map(|i| f0 + df * i as f64).collect(),
        channels: vec![
            FrfChannel {
                channel: Channel::new(Axis::X, Axis::X),
                h: vals.iter().map(|v| Complex64::new(*v, -0.5 * v)).collect(),
                coherence: Some(vals.iter().map(|v| v.abs().fract()).collect()),
            },
            FrfChannel {
                channel: Channel::new(Axis::Y, Axis::X),
                h: vals.iter().map(|v| Complex64::new(1e-9 * v, 3.0)).collect(),
                coherence: None,
            },
        ],
    }
}

fn twin_json() -> &'static str {
    static J: OnceLock<String> = OnceLock::new();
    J.get_or_init(|| {
        let twin = ModalMachine::default_machine().exact_twin([2, 2, 1], &[Axis::X, Axis::Y]);
        serde_json::to_string_pretty(&twin).expect("twin serialises")
    })
}

// ---------------------------------------------------------------------------------------
// Mutations
// ---------------------------------------------------------------------------------------

const NUMBERS: &[&str] = &[
    "NaN",
    "nan",
    "-NaN",
    "inf",
    "-inf",
    "Infinity",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e309",
    "-1e400",
    "1e-320",
    "4.9e-324",
    "1e99999999999",
    "9e-99999999999",
    "0",
    "-0",
    "",
    " ",
    "1e+",
    "0x10",
    "1,5",
    "18446744073709551617",
    "-9223372036854775809",
    "2147483648",
    "1.0.0",
    "\"3\"",
    "null",
    "true",
    "[]",
    "{}",
];

#[derive(Debug, Clone)]
enum Mutation {
    Flip(usize, u8),
    Insert(usize, u8),
    Delete(usize, usize),
    Truncate(usize),
    DupLine(usize),
    DropLine(usize),
    SwapLines(usize, usize),
    Number(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(p, b)| Mutation::Flip(p, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Mutation::Insert(p, b)),
        (any::<usize>(), 1usize..40).prop_map(|(p, n)| Mutation::Delete(p, n)),
        any::<usize>().prop_map(Mutation::Truncate),
        any::<usize>().prop_map(Mutation::DupLine),
        any::<usize>().prop_map(Mutation::DropLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        (any::<usize>(), 0..NUMBERS.len()).prop_map(|(k, r)| Mutation::Number(k, r)),
        (any::<usize>(), 0..NUMBERS.len()).prop_map(|(k, r)| Mutation::Number(k, r)),
        (any::<usize>(), 0..NUMBERS.len()).prop_map(|(k, r)| Mutation::Number(k, r)),
    ]
}

/// Byte ranges of the lines (with their `\n`).
fn line_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, &c) in b.iter().enumerate() {
        if c == b'\n' {
            out.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < b.len() {
        out.push((s, b.len()));
    }
    out
}

/// Byte ranges of number-like tokens: a digit run with optional sign, point, exponent.
fn number_spans(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let start = i;
        if matches!(b[i], b'-' | b'+') && b.get(i + 1).is_some_and(|c| c.is_ascii_digit()) {
            i += 1;
        }
        if b[i].is_ascii_digit() {
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                i += 1;
            }
            if i < b.len() && matches!(b[i], b'e' | b'E') {
                i += 1;
                if i < b.len() && matches!(b[i], b'-' | b'+') {
                    i += 1;
                }
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
            }
            out.push((start, i));
        } else {
            i = start + 1;
        }
    }
    out
}

fn apply(mut b: Vec<u8>, muts: &[Mutation]) -> Vec<u8> {
    for m in muts {
        let len = b.len();
        match *m {
            Mutation::Flip(p, bit) if len > 0 => b[p % len] ^= 1 << bit,
            Mutation::Insert(p, c) => b.insert(p % (len + 1), c),
            Mutation::Delete(p, n) if len > 0 => {
                let s = p % len;
                b.drain(s..(s + n).min(len));
            }
            Mutation::Truncate(p) => b.truncate(p % (len + 1)),
            Mutation::DupLine(k) | Mutation::DropLine(k) => {
                let lines = line_spans(&b);
                if lines.is_empty() {
                    continue;
                }
                let (s, e) = lines[k % lines.len()];
                if matches!(m, Mutation::DupLine(_)) {
                    let l = b[s..e].to_vec();
                    b.splice(e..e, l);
                } else {
                    b.drain(s..e);
                }
            }
            Mutation::SwapLines(x, y) => {
                let lines = line_spans(&b);
                if lines.len() < 2 {
                    continue;
                }
                let (mut i, mut j) = (x % lines.len(), y % lines.len());
                if i == j {
                    continue;
                }
                if i > j {
                    std::mem::swap(&mut i, &mut j);
                }
                let (a, c) = (lines[i], lines[j]);
                let mut out = b[..a.0].to_vec();
                out.extend_from_slice(&b[c.0..c.1]);
                out.extend_from_slice(&b[a.1..c.0]);
                out.extend_from_slice(&b[a.0..a.1]);
                out.extend_from_slice(&b[c.1..]);
                b = out;
            }
            Mutation::Number(k, r) => {
                let nums = number_spans(&b);
                if nums.is_empty() {
                    continue;
                }
                let (s, e) = nums[k % nums.len()];
                b.splice(s..e, NUMBERS[r].bytes());
            }
            _ => {}
        }
    }
    b
}

fn lossy(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

// ---------------------------------------------------------------------------------------
// The fuzz properties
// ---------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(config(128))]

    #[test]
    fn timeseries_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..800)) {
        let r = parse_timeseries(&lossy(&bytes), path());
        prop_assert!(check_timeseries(&r).is_ok(), "{:?}", check_timeseries(&r));
        // behind a valid header, so the data path is reached
        let mut t = String::from("t,fx,ay,x\n");
        t.push_str(&lossy(&bytes));
        let r = parse_timeseries(&t, path());
        prop_assert!(check_timeseries(&r).is_ok(), "{:?}", check_timeseries(&r));
        let raw = [&b"t,fx,ay,x\n"[..], &bytes].concat();
        let c = check_stream_agrees(&raw);
        prop_assert!(c.is_ok(), "{:?}", c);
    }

    #[test]
    fn timeseries_mutated(
        vals in proptest::collection::vec(-1e3f64..1e3, 16..60),
        t0 in prop_oneof![Just(0.25), -1e3f64..1e3, Just(-1e306), Just(1e12)],
        dt in prop_oneof![Just(1e-3), 1e-9f64..1.0, Just(1e-300), Just(1e300), Just(1e305)],
        disp in any::<bool>(),
        muts in proptest::collection::vec(mutation(), 1..5),
    ) {
        let good = valid_timeseries(&vals, t0, dt, disp);
        let bad = apply(good.into_bytes(), &muts);
        let r = parse_timeseries(&lossy(&bad), path());
        let c = check_timeseries(&r);
        prop_assert!(c.is_ok(), "{:?}\ninput:\n{}", c, lossy(&bad));
        let c = check_stream_agrees(&bad);
        prop_assert!(c.is_ok(), "{:?}\ninput:\n{}", c, lossy(&bad));
    }

    #[test]
    fn frf_csv_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..800)) {
        let r = parse_frf_csv(&lossy(&bytes), path());
        prop_assert!(check_frf(&r).is_ok(), "{:?}", check_frf(&r));
        let mut t = String::from("f_hz,xx_re,xx_im,xx_coh\n");
        t.push_str(&lossy(&bytes));
        let r = parse_frf_csv(&t, path());
        prop_assert!(check_frf(&r).is_ok(), "{:?}", check_frf(&r));
    }

    #[test]
    fn frf_csv_mutated(
        vals in proptest::collection::vec(-1e3f64..1e3, 1..40),
        f0 in prop_oneof![Just(0.0), 0.0f64..1e4, Just(1e300)],
        df in prop_oneof![Just(0.5), 1e-6f64..1e3, Just(1e300)],
        muts in proptest::collection::vec(mutation(), 1..5),
    ) {
        let Ok(good) = format_frf_csv(&valid_frf(&vals, f0, df)) else {
            return Ok(()); // a grid the writer refuses (not strictly increasing)
        };
        let bad = apply(good.into_bytes(), &muts);
        let r = parse_frf_csv(&lossy(&bad), path());
        let c = check_frf(&r);
        prop_assert!(c.is_ok(), "{:?}\ninput:\n{}", c, lossy(&bad));
    }

    #[test]
    fn uff_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..800)) {
        let r = parse_uff58(&bytes, path());
        prop_assert!(check_uff(&r).is_ok(), "{:?}", check_uff(&r));
        for head in [
            &b"    -1\n    58\n"[..],
            &b"    -1\n    58b     1     2          11        160\n"[..],
        ] {
            let mut v = head.to_vec();
            v.extend_from_slice(&bytes);
            let r = parse_uff58(&v, path());
            prop_assert!(check_uff(&r).is_ok(), "{:?}", check_uff(&r));
        }
    }

    #[test]
    fn uff_mutated(
        vals in proptest::collection::vec(-1e3f64..1e3, 1..30),
        f0 in prop_oneof![Just(0.0), 0.0f64..1e4, Just(1e-300), Just(1e-160)],
        df in prop_oneof![Just(0.5), 1e-6f64..1e3],
        binary in any::<bool>(),
        uneven in any::<bool>(),
        accel in any::<bool>(),
        muts in proptest::collection::vec(mutation(), 1..5),
    ) {
        let mut frf = valid_frf(&vals, f0, df);
        if uneven {
            for (i, f) in frf.freqs_hz.iter_mut().enumerate() {
                *f += df * 0.3 * ((i % 3) as f64);
            }
        }
        let mut funcs = uff_from_frf(&frf, 7);
        if accel {
            // accelerance: the conversion to receptance divides by the frequency
            funcs[0].ordinate_axis.data_type = DATA_ACCELERATION;
        }
        let good = if binary {
            format_uff58b(&funcs).expect("valid functions write")
        } else {
            format_uff58(&funcs).expect("valid functions write").into_bytes()
        };
        let bad = apply(good, &muts);
        let r = parse_uff58(&bad, path());
        let c = check_uff(&r);
        prop_assert!(c.is_ok(), "{:?}\ninput:\n{}", c, lossy(&bad));
    }

    #[test]
    fn twin_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let r = Twin::from_json(&lossy(&bytes), path());
        prop_assert!(check_twin(&r).is_ok(), "{:?}", check_twin(&r));
        let mut t = String::from(r#"{"schema":"mtwin-twin","version":1,"poses":"#);
        t.push_str(&lossy(&bytes));
        let r = Twin::from_json(&t, path());
        prop_assert!(check_twin(&r).is_ok(), "{:?}", check_twin(&r));
    }
}

proptest! {
    // the twin is ~100 kB of JSON: fewer cases by default
    #![proptest_config(config(48))]

    #[test]
    fn twin_mutated(muts in proptest::collection::vec(mutation(), 1..5)) {
        let bad = apply(twin_json().as_bytes().to_vec(), &muts);
        let r = Twin::from_json(&lossy(&bad), path());
        let c = check_twin(&r);
        prop_assert!(c.is_ok(), "{:?}\nmutations: {:?}", c, muts);
    }
}

// ---------------------------------------------------------------------------------------
// The valid files themselves read back (the mutations start from something that works)
// ---------------------------------------------------------------------------------------

#[test]
fn valid_inputs_read_back() {
    let vals: Vec<f64> = (0..32).map(|i| (i as f64).sin()).collect();
    let ts = parse_timeseries(&valid_timeseries(&vals, 0.25, 1e-3, false), path()).unwrap();
    assert_eq!(ts.len(), 32);
    let frf = valid_frf(&vals, 1.0, 0.5);
    let back = parse_frf_csv(&format_frf_csv(&frf).unwrap(), path()).unwrap();
    assert_eq!(back.freqs_hz, frf.freqs_hz);
    let funcs = uff_from_frf(&frf, 7);
    assert_eq!(
        parse_uff58(&format_uff58b(&funcs).unwrap(), path())
            .unwrap()
            .len(),
        funcs.len()
    );
    let twin = Twin::from_json(twin_json(), path()).unwrap();
    assert_eq!(twin.poses.len(), 4);
}

// ---------------------------------------------------------------------------------------
// Regressions: inputs the fuzzers found
// ---------------------------------------------------------------------------------------

/// A UFF coherence function outside [0, 1] (a value replaced by 1e308) was passed on as
/// the channel's coherence.
#[test]
fn regression_uff_coherence_out_of_range() {
    let vals = vec![0.0; 19];
    let funcs = uff_from_frf(&valid_frf(&vals, 0.0, 0.5), 7);
    let good = format_uff58(&funcs).unwrap();
    // the first value of the coherence function (the dataset with 'coherence' in its id)
    let at = good.find("mtwin coherence").expect("a coherence function");
    let data = at + good[at..].find("\n 0.0000000000000E+00").expect("data") + 1;
    let mut bad = good.clone();
    bad.replace_range(data..data + 20, "              1e308 ");
    let funcs = parse_uff58(bad.as_bytes(), path()).expect("parses: a finite number");
    for assume in [DATA_ACCELERATION, DATA_VELOCITY] {
        let sel = UffSelect {
            assume_ordinate: Some(assume),
            ..UffSelect::default()
        };
        let e = frf_from_uff(&funcs, &sel).expect_err("coherence 1e308");
        assert!(e.to_string().contains("outside [0, 1]"), "{e}");
    }
    assert!(check_uff(&Ok(funcs)).is_ok());
}

/// Times from -1.6e308 to 1.6e308: every step is finite but the span overflows, and the
/// mean step came out infinite (dt = inf, sample rate 0).
#[test]
fn regression_timeseries_span_overflows() {
    let mut csv = String::from("t,fx,ax\n");
    for i in 0..17 {
        let t = (i as f64 - 8.0) * 2e307;
        csv.push_str(&format!("{t:e},1,2\n"));
    }
    let r = parse_timeseries(&csv, path());
    assert!(check_timeseries(&r).is_ok(), "{:?}", check_timeseries(&r));
    assert!(r.is_err(), "{:?}", r.map(|t| t.dt));
    println!("{}", r.unwrap_err());
}

/// An even abscissa whose last point overflows: minimum 1e308, increment 1e307.
#[test]
fn regression_uff_even_abscissa_overflows() {
    let f = UffFunction {
        func_type: identify::uff::FUNC_FRF,
        abscissa: (0..30).map(|i| 1.0 + i as f64).collect(),
        data: vec![Complex64::new(1.0, 0.0); 30],
        ..Default::default()
    };
    let good = format_uff58(&[f]).unwrap();
    let mut lines: Vec<String> = good.lines().map(str::to_owned).collect();
    // record 7 is line 9 (delimiter, number, 5 id lines, record 6)
    let r7 = &lines[8];
    lines[8] = format!(
        "{}{:>13}{:>13}{}",
        &r7[..30],
        "1.00000E+308",
        "1.00000E+307",
        &r7[56..]
    );
    let bad = lines.join("\n") + "\n";
    let r = parse_uff58(bad.as_bytes(), path());
    assert!(check_uff(&r).is_ok(), "{:?}", check_uff(&r));
}

/// Accelerance at 1e-300 Hz: dividing by -ω² overflowed to an infinite receptance.
#[test]
fn regression_uff_accelerance_near_zero_hz() {
    let mut abscissa = vec![1e-300, 1e-200];
    abscissa.extend((1..20).map(|i| i as f64));
    let f = UffFunction {
        func_type: identify::uff::FUNC_FRF,
        response_dir: 1,
        reference_dir: 1,
        ordinate_axis: identify::uff::UffAxis::new(DATA_ACCELERATION, "acc", "m/s^2"),
        data: vec![Complex64::new(1.0, 0.5); abscissa.len()],
        abscissa,
        ..Default::default()
    };
    let text = format_uff58(&[f]).unwrap();
    let r = parse_uff58(text.as_bytes(), path());
    assert!(check_uff(&r).is_ok(), "{:?}", check_uff(&r));
}

/// A twin whose stored FRF lost a frequency line (a line of the pretty JSON deleted)
/// loaded: the FRF of a later refit would have had values on the wrong lines.
#[test]
fn regression_twin_with_inconsistent_stored_frf() {
    let twin = Twin::from_json(twin_json(), path()).unwrap();
    let mut v: serde_json::Value = serde_json::to_value(&twin).unwrap();
    // swap the two frequencies of pose 0; then drop one value of channel 0
    v["poses"][0]["frf"]["freqs_hz"] = serde_json::json!([20.0, 10.0]);
    let e = Twin::from_json(&v.to_string(), path()).expect_err("unsorted lines");
    assert!(e.to_string().contains("strictly"), "{e}");
    let mut v: serde_json::Value = serde_json::to_value(&twin).unwrap();
    v["poses"][1]["frf"]["channels"][0]["h"]
        .as_array_mut()
        .unwrap()
        .pop();
    let e = Twin::from_json(&v.to_string(), path()).expect_err("a value missing");
    assert!(e.to_string().contains("one value"), "{e}");
    assert!(e.to_string().contains("inpüt.dat"), "{e}");
}
