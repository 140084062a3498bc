//! Reading and writing the data files of docs/formats.md.
//!
//! * Time-series CSV ([`read_timeseries`], [`parse_timeseries`], [`write_timeseries`]):
//!   `#` comment lines, a header with `t`, forces `fx fy fz`, responses `ax ay az`
//!   (acceleration) or `dx dy dz` (displacement) and axis positions `x y z`.
//! * The same time-series CSV row by row in constant memory, for records too long to
//!   hold ([`RowReader`], [`scan_timeseries`]; module `stream`'s docs say where it
//!   differs: the typical time step is judged from the first three steps).
//! * FRF CSV ([`read_frf_csv`], [`write_frf_csv`]): `f_hz` then `<out><in>_re`,
//!   `<out><in>_im` and optionally `<out><in>_coh` per channel.
//! * Text FRFs with one Python complex per line, as in the pyuff example data
//!   ([`read_complex_lines`]).
//!
//! The readers are strict: every violation of the format is an [`Error::BadFile`] naming
//! the file, the 1-based line and the column, with a message that says what to fix.
//! They parse byte lines directly (no regex, no CSV crate): a 1 MB file takes a few
//! milliseconds in a release build.

use crate::atomic::write_atomic;
use crate::axis::{Axis, Channel};
use crate::error::{Error, Result};
use crate::frf::{Frf, FrfChannel};
use crate::timeseries::{ResponseKind, TimeSeries};
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::Path;

mod stream;
pub(crate) use stream::changed_while_read;
pub use stream::{
    scan_timeseries, subsample_stride, ColumnStats, RecordEnd, RecordScan, RowReader, MAX_COMMENTS,
    SUBSAMPLE_CAP,
};

/// Minimum number of samples of a time-series record.
pub const MIN_SAMPLES: usize = 16;

/// Relative tolerance of every time step against the mean step (docs/formats.md, "Time-series CSV").
pub const TIME_STEP_TOLERANCE: f64 = 0.01;

fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    String::from_utf8(bytes).map_err(|e| {
        let pos = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..pos].iter().filter(|&&b| b == b'\n').count() + 1;
        not_utf8(path, line)
    })
}

/// Line `line` of `file` is not UTF-8.
fn not_utf8(file: &Path, line: usize) -> Error {
    Error::bad_file(
        file,
        line,
        None,
        "the file is not UTF-8 text; save it as plain UTF-8 (or ASCII) CSV",
    )
}

/// Lines of `text` with their 1-based numbers; `\r\n` and `\n` line ends.
fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l))
}

/// Parses one numeric cell; `column` names it in the error.
#[cold]
fn parse_cell(cell: &str, file: &Path, line: usize, column: &str) -> Result<f64> {
    let s = cell.trim();
    if s.is_empty() {
        return Err(Error::bad_file(
            file,
            line,
            Some(column),
            "empty cell; every row needs a number in every column (remove the row or fill it in)",
        ));
    }
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(Error::bad_file(
            file,
            line,
            Some(column),
            format!("value '{s}' is not finite (NaN or Inf); replace it by a measured number or cut the record before it"),
        )),
        Err(_) => Err(Error::bad_file(
            file,
            line,
            Some(column),
            format!("'{s}' is not a number; use plain decimal numbers with '.' as decimal point (e.g. 1.5e-3)"),
        )),
    }
}

/// Exact powers of ten representable in an f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Clinger's fast path: plain decimals (`-12.5`, `3.9e-5`) whose digits fit in 2⁵³ and
/// whose decimal exponent is within ±22 are converted exactly (one correctly rounded
/// multiplication or division of two exact values). `None` = use the full parser.
#[inline]
fn fast_f64(s: &str) -> Option<f64> {
    let b = s.as_bytes();
    let (neg, mut i) = match b.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let mut mant: u64 = 0;
    let mut digits = 0;
    let mut exp10: i32 = 0;
    let start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        mant = mant.wrapping_mul(10).wrapping_add((b[i] - b'0') as u64);
        digits += 1;
        i += 1;
    }
    if i < b.len() && b[i] == b'.' {
        i += 1;
        while i < b.len() && b[i].is_ascii_digit() {
            mant = mant.wrapping_mul(10).wrapping_add((b[i] - b'0') as u64);
            digits += 1;
            exp10 -= 1;
            i += 1;
        }
    }
    if digits == 0 || i == start {
        return None;
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        i += 1;
        let eneg = match b.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let es = i;
        let mut e: i32 = 0;
        while i < b.len() && b[i].is_ascii_digit() && i - es < 4 {
            e = e * 10 + (b[i] - b'0') as i32;
            i += 1;
        }
        if i == es {
            return None;
        }
        exp10 += if eneg { -e } else { e };
    }
    if i != b.len() || digits > 19 || mant > (1u64 << 53) || exp10.unsigned_abs() > 22 {
        return None;
    }
    let m = mant as f64;
    let v = if exp10 >= 0 {
        m * POW10[exp10 as usize]
    } else {
        m / POW10[(-exp10) as usize]
    };
    Some(if neg { -v } else { v })
}

/// What a time-series column holds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Time,
    Force(Axis),
    Response(Axis, ResponseKind),
    Position(Axis),
    Ignored,
}

fn role_of(name: &str) -> Role {
    let lower = name.to_ascii_lowercase();
    let mut ch = lower.chars();
    match (ch.next(), ch.next(), ch.next()) {
        (Some('t'), None, None) => Role::Time,
        (Some(c), None, None) => Axis::from_letter(c).map_or(Role::Ignored, Role::Position),
        (Some(k), Some(c), None) => match (k, Axis::from_letter(c)) {
            ('f', Some(a)) => Role::Force(a),
            ('a', Some(a)) => Role::Response(a, ResponseKind::Acceleration),
            ('d', Some(a)) => Role::Response(a, ResponseKind::Displacement),
            _ => Role::Ignored,
        },
        _ => Role::Ignored,
    }
}

/// Reads a time-series CSV (docs/formats.md, "Time-series CSV"). Warnings (ignored columns) are dropped; use
/// [`read_timeseries_with_warnings`] to show them.
pub fn read_timeseries(path: &Path) -> Result<TimeSeries> {
    read_timeseries_with_warnings(path).map(|(ts, _)| ts)
}

/// Reads a time-series CSV and returns the warnings (e.g. unknown columns ignored); the
/// warnings do not repeat the file name (it is in [`TimeSeries::source`]).
pub fn read_timeseries_with_warnings(path: &Path) -> Result<(TimeSeries, Vec<String>)> {
    let text = read_text(path)?;
    parse_timeseries_with_warnings(&text, path)
}

/// Parses time-series CSV text; `source` names the file in messages and in
/// [`TimeSeries::source`].
pub fn parse_timeseries(text: &str, source: &Path) -> Result<TimeSeries> {
    parse_timeseries_with_warnings(text, source).map(|(ts, _)| ts)
}

/// Parses time-series CSV text and returns the warnings as well.
pub fn parse_timeseries_with_warnings(
    text: &str,
    source: &Path,
) -> Result<(TimeSeries, Vec<String>)> {
    let file = source;
    let mut comments = Vec::new();
    let mut warnings = Vec::new();
    let mut lines = numbered_lines(text);

    // Header: first line that is neither a comment nor blank.
    let header = loop {
        let Some((n, l)) = lines.next() else {
            return Err(no_header(file));
        };
        match LineKind::of(l) {
            LineKind::Comment => comments.push(comment_text(l)),
            LineKind::Blank => {}
            LineKind::Content => break Header::parse(n, l, file, &mut warnings)?,
        }
    };

    // Data rows, one column vector per used column.
    let ncol = header.names.len();
    let est_rows = text.len() / (8 * ncol).max(1);
    let mut cols: Vec<Vec<f64>> = header
        .roles
        .iter()
        .map(|r| {
            if *r == Role::Ignored {
                Vec::new()
            } else {
                Vec::with_capacity(est_rows)
            }
        })
        .collect();
    let mut row_lines: Vec<usize> = Vec::with_capacity(est_rows);
    for (n, l) in lines {
        match LineKind::of(l) {
            LineKind::Blank => {}
            LineKind::Comment => comments.push(comment_text(l)),
            LineKind::Content => {
                header.parse_row(l, n, file, |j, v| cols[j].push(v))?;
                row_lines.push(n);
            }
        }
    }

    let ts = assemble(file, &header, cols, &row_lines, comments)?;
    Ok((ts, warnings))
}

/// A record from columns in memory (the Python package's arrays), named as in the header
/// of a time-series CSV (`t`, `fx`, `dx`, `ax`, `x`, ...; docs/formats.md): the same
/// checks and the same record as [`parse_timeseries_with_warnings`] on a file with these
/// columns. `source` names the record in messages, where sample `i` (0-based) is "line"
/// `i + 1`. Returns the warnings (unknown columns ignored) as well.
pub fn timeseries_from_columns(
    source: &Path,
    columns: Vec<(String, Vec<f64>)>,
) -> Result<(TimeSeries, Vec<String>)> {
    let file = source;
    let mut warnings = Vec::new();
    let names: Vec<&str> = columns.iter().map(|(n, _)| n.as_str()).collect();
    if let Some(bad) = names
        .iter()
        .find(|n| n.contains(',') || n.trim().is_empty())
    {
        return Err(Error::bad_file(
            file,
            0,
            None,
            format!(
                "'{bad}' is not a column name (t, fx, fy, fz, ax, ay, az, dx, dy, dz, x, y, z)"
            ),
        ));
    }
    let header = Header::parse(0, &names.join(","), file, &mut warnings)?;
    let n = columns.iter().map(|(_, c)| c.len()).max().unwrap_or(0);
    for (name, col) in &columns {
        if col.len() != n {
            return Err(Error::bad_file(
                file,
                0,
                Some(name),
                format!("{} samples, but another column has {n}; every column needs one value per sample", col.len()),
            ));
        }
        if let Some(i) = col.iter().position(|v| !v.is_finite()) {
            return Err(Error::bad_file(
                file,
                i + 1,
                Some(name),
                format!("value {} is not finite (NaN or Inf); replace it by a measured number or cut the record before it", col[i]),
            ));
        }
    }
    let cols: Vec<Vec<f64>> = columns
        .into_iter()
        .zip(&header.roles)
        .map(|((_, c), r)| if *r == Role::Ignored { Vec::new() } else { c })
        .collect();
    let row_lines: Vec<usize> = (1..=n).collect();
    let ts = assemble(file, &header, cols, &row_lines, Vec::new())?;
    Ok((ts, warnings))
}

/// The record from the parsed columns `cols` of `header` (data row `i` at line
/// `row_lines[i]`): at least [`MIN_SAMPLES`] rows, time increasing and uniformly sampled.
fn assemble(
    file: &Path,
    header: &Header,
    cols: Vec<Vec<f64>>,
    row_lines: &[usize],
    comments: Vec<String>,
) -> Result<TimeSeries> {
    let n = row_lines.len();
    check_row_count(file, header, n)?;
    let t = &cols[header.time_col];
    let tname = header.time_name();
    for i in 1..n {
        if t[i] <= t[i - 1] {
            return Err(not_increasing(
                file,
                tname,
                (row_lines[i], t[i]),
                (row_lines[i - 1], t[i - 1]),
            ));
        }
    }
    // Uniform sampling: first against the typical (median) step, which points at the
    // row where a sample is missing or doubled, then against the mean step (the SPEC
    // rule), which also catches a slow drift of the rate.
    let mean = mean_step(file, tname, (t[0], t[n - 1]), n, row_lines[n - 1])?;
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mid = steps.len() / 2;
    let typical = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
    for (reference, kind) in [(typical, StepRef::Typical), (mean, StepRef::Mean)] {
        for i in 1..n {
            let step = t[i] - t[i - 1];
            if off_step(step, reference) {
                return Err(irregular_step(
                    file,
                    row_lines[i],
                    tname,
                    step,
                    reference,
                    kind,
                ));
            }
        }
    }

    let mut ts = TimeSeries {
        source: file.display().to_string(),
        t0: t[0],
        dt: mean,
        response_kind: header.kind,
        comments,
        ..TimeSeries::default()
    };
    for (role, col) in header.roles.iter().zip(cols) {
        match *role {
            Role::Force(a) => ts.force[a.index()] = Some(col),
            Role::Response(a, _) => ts.response[a.index()] = Some(col),
            Role::Position(a) => ts.position[a.index()] = Some(col),
            Role::Time | Role::Ignored => {}
        }
    }
    Ok(ts)
}

/// What a line of a time-series CSV is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LineKind {
    /// Empty or only whitespace: skipped.
    Blank,
    /// Starts with `#` (after whitespace).
    Comment,
    /// The header or a data row.
    Content,
}

impl LineKind {
    #[inline]
    fn of(line: &str) -> Self {
        let t = line.trim();
        if t.is_empty() {
            LineKind::Blank
        } else if t.starts_with('#') {
            LineKind::Comment
        } else {
            LineKind::Content
        }
    }
}

/// The parsed header of a time-series CSV: column names and what each holds.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    /// 1-based line of the header.
    line: usize,
    names: Vec<String>,
    roles: Vec<Role>,
    time_col: usize,
    kind: Option<ResponseKind>,
}

impl Header {
    /// Parses the header line `text` (line `line`); unknown columns add a warning.
    fn parse(line: usize, text: &str, file: &Path, warnings: &mut Vec<String>) -> Result<Header> {
        // a spreadsheet's export with another separator: say so, not "no column t"
        for (sep, name) in [(';', "semicolons"), ('\t', "tabs")] {
            if !text.contains(',') && text.split(sep).count() > 1 {
                return Err(Error::bad_file(
                    file,
                    line,
                    None,
                    format!(
                        "the header is separated by {name}; mtwin reads comma-separated files \
                         (decimal point '.'): export as CSV with ',' between columns"
                    ),
                ));
            }
        }
        let names: Vec<&str> = text.split(',').map(str::trim).collect();
        let mut roles = Vec::with_capacity(names.len());
        let mut time_col = None;
        let mut kind: Option<(ResponseKind, &str)> = None;
        for (i, &name) in names.iter().enumerate() {
            if names[..i].iter().any(|n| n.eq_ignore_ascii_case(name)) {
                return Err(Error::bad_file(
                    file,
                    line,
                    Some(name),
                    format!("column '{name}' appears twice in the header; keep one of them"),
                ));
            }
            let role = role_of(name);
            match role {
                Role::Time => time_col = Some(i),
                Role::Response(_, k) => match kind {
                    Some((k0, first)) if k0 != k => {
                        return Err(Error::bad_file(
                            file,
                            line,
                            Some(name),
                            format!("column '{name}' mixes response kinds with '{first}': use either accelerations ax,ay,az or displacements dx,dy,dz in one file"),
                        ))
                    }
                    None => kind = Some((k, name)),
                    _ => {}
                },
                Role::Ignored => warnings.push(format!(
                    "line {line}: unknown column '{name}' ignored (known: t, fx, fy, fz, ax, ay, az, dx, dy, dz, x, y, z)"
                )),
                _ => {}
            }
            roles.push(role);
        }
        let Some(time_col) = time_col else {
            return Err(Error::bad_file(
                file,
                line,
                None,
                "no time column 't' in the header; add a column 't' with the sample times in seconds",
            ));
        };
        if !roles.iter().any(|r| matches!(r, Role::Force(_))) {
            return Err(Error::bad_file(
                file,
                line,
                None,
                "no force column in the header; add at least one of fx, fy, fz (newtons)",
            ));
        }
        Ok(Header {
            line,
            names: names.iter().map(|s| s.to_string()).collect(),
            roles,
            time_col,
            kind: kind.map(|(k, _)| k),
        })
    }

    /// Name of the time column as written in the header.
    fn time_name(&self) -> &str {
        &self.names[self.time_col]
    }

    /// Parses data row `l` (line `n`), handing every used column's value to
    /// `put(column, value)`; ignored columns are not parsed.
    #[inline]
    fn parse_row(
        &self,
        l: &str,
        n: usize,
        file: &Path,
        mut put: impl FnMut(usize, f64),
    ) -> Result<()> {
        let ncol = self.names.len();
        let mut count = 0;
        for (j, cell) in l.split(',').enumerate() {
            count = j + 1;
            if j >= ncol {
                continue;
            }
            if self.roles[j] != Role::Ignored {
                // fast path inline; errors, NaN/Inf and long numbers in parse_cell
                let v = match fast_f64(cell.trim_ascii()) {
                    Some(v) => v,
                    None => parse_cell(cell, file, n, &self.names[j])?,
                };
                put(j, v);
            }
        }
        if count != ncol {
            return Err(Error::bad_file(
                file,
                n,
                None,
                format!("this row has {} but the header (line {}) has {}; every row needs exactly one value per column", crate::axis::count(count, "cell"), self.line, crate::axis::count(ncol, "column")),
            ));
        }
        Ok(())
    }
}

/// The file ended before a header.
fn no_header(file: &Path) -> Error {
    Error::bad_file(
        file,
        0,
        None,
        "the file has no header and no data; expected a header such as 't,fx,ax' followed by one row per sample",
    )
}

/// At least [`MIN_SAMPLES`] data rows.
fn check_row_count(file: &Path, header: &Header, n: usize) -> Result<()> {
    if n == 0 {
        return Err(Error::bad_file(
            file,
            header.line,
            None,
            "header only, no data rows; add one row per sample below the header",
        ));
    }
    if n < MIN_SAMPLES {
        return Err(Error::bad_file(
            file,
            0,
            None,
            format!(
                "only {}; a record needs at least {MIN_SAMPLES} (measure longer)",
                crate::axis::count(n, "sample")
            ),
        ));
    }
    Ok(())
}

/// Time `t` at line `line` is not after the previous row's time.
fn not_increasing(file: &Path, tname: &str, (line, t): (usize, f64), prev: (usize, f64)) -> Error {
    Error::bad_file(
        file,
        line,
        Some(tname),
        format!(
            "time {t} does not increase (previous row {} at line {}); remove repeated rows and sort by time",
            prev.1, prev.0
        ),
    )
}

/// The mean step of `n` samples from `first` to `last` (times), or an error at
/// `last_line` when it gives no usable sample rate.
fn mean_step(
    file: &Path,
    tname: &str,
    (first, last): (f64, f64),
    n: usize,
    last_line: usize,
) -> Result<f64> {
    let mean = (last - first) / (n - 1) as f64;
    // Finite times can still span more than an f64 holds (or step by less than the
    // smallest normal number): no usable sample rate.
    if !(mean.is_finite() && mean > 0.0 && (1.0 / mean).is_finite()) {
        return Err(Error::bad_file(
            file,
            last_line,
            Some(tname),
            format!("the times from {first:e} s to {last:e} s give no usable sample period (the span or the step is beyond the range of a double); give times in seconds"),
        ));
    }
    Ok(mean)
}

/// Which step a time step is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StepRef {
    /// The typical step (median of all steps in memory; of the first three when
    /// streamed).
    Typical,
    /// The mean step `(t_last - t_first) / (n - 1)` (the SPEC rule).
    Mean,
}

/// True when `step` is more than [`TIME_STEP_TOLERANCE`] away from `reference`.
#[inline]
fn off_step(step: f64, reference: f64) -> bool {
    (step - reference).abs() > TIME_STEP_TOLERANCE * reference
}

/// The step ending at line `line` is off the reference step.
fn irregular_step(
    file: &Path,
    line: usize,
    tname: &str,
    step: f64,
    reference: f64,
    kind: StepRef,
) -> Error {
    let which = match kind {
        StepRef::Typical => "typical",
        StepRef::Mean => "mean",
    };
    Error::bad_file(
        file,
        line,
        Some(tname),
        format!(
            "time step {} differs by more than 1 % from the {which} step {}; the record must be uniformly sampled (a row is missing or repeated here, or the sampling rate changed)",
            seconds_text(step),
            seconds_text(reference)
        ),
    )
}

/// A duration for people: four significant digits in s, ms, µs or ns, trailing zeros
/// dropped (`2.0000000000000018e-3` → `2 ms`, `1.0204e-3` → `1.02 ms`).
pub fn seconds_text(t: f64) -> String {
    if !t.is_finite() || t == 0.0 {
        return format!("{t} s");
    }
    let (scale, unit) = match t.abs() {
        a if a >= 1.0 => (1.0, "s"),
        a if a >= 1e-3 => (1e3, "ms"),
        a if a >= 1e-6 => (1e6, "µs"),
        _ => (1e9, "ns"),
    };
    let v = t * scale;
    // 4 significant digits: decimals left after the integer digits
    let int_digits = (v.abs().log10().floor() as i32 + 1).max(1);
    let decimals = (4 - int_digits).max(0) as usize;
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    format!("{s} {unit}")
}

/// Comment text: the line without its `#` and one following space.
fn comment_text(line: &str) -> String {
    let s = line.trim_start().trim_end_matches('\r');
    let s = s.strip_prefix('#').unwrap_or(s);
    s.strip_prefix(' ').unwrap_or(s).to_string()
}

/// Formats a record as time-series CSV text (shortest round-trip number formatting).
///
/// Fails when columns have different lengths or hold NaN/Inf (the file would not read
/// back).
pub fn format_timeseries(ts: &TimeSeries) -> Result<String> {
    let mut cols: Vec<(String, &[f64])> = Vec::new();
    for a in Axis::ALL {
        if let Some(v) = ts.force(a) {
            cols.push((format!("f{a}"), v));
        }
    }
    let prefix = match ts.response_kind {
        Some(ResponseKind::Displacement) => 'd',
        _ => 'a',
    };
    for a in Axis::ALL {
        if let Some(v) = ts.response(a) {
            cols.push((format!("{prefix}{a}"), v));
        }
    }
    for a in Axis::ALL {
        if let Some(v) = ts.position[a.index()].as_deref() {
            cols.push((a.letter().to_string(), v));
        }
    }
    let n = ts.len();
    for (name, v) in &cols {
        if v.len() != n {
            return Err(Error::BadInput(format!(
                "cannot write {}: column {name} has {} samples, others {n}",
                ts.source,
                v.len()
            )));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(Error::Numerical(format!(
                "cannot write {}: column {name} sample {i} is not finite",
                ts.source
            )));
        }
    }
    if !(ts.dt.is_finite() && ts.dt > 0.0 && ts.t0.is_finite()) {
        return Err(Error::BadInput(format!(
            "cannot write {}: invalid time axis (t0 {}, dt {})",
            ts.source, ts.t0, ts.dt
        )));
    }
    let mut out = String::with_capacity(n * (cols.len() + 1) * 20 + 64);
    for c in &ts.comments {
        out.push_str("# ");
        out.push_str(c);
        out.push('\n');
    }
    out.push('t');
    for (name, _) in &cols {
        out.push(',');
        out.push_str(name);
    }
    out.push('\n');
    for i in 0..n {
        let _ = write!(out, "{}", ts.t0 + i as f64 * ts.dt);
        for (_, v) in &cols {
            let _ = write!(out, ",{}", v[i]);
        }
        out.push('\n');
    }
    Ok(out)
}

/// Writes a record as time-series CSV (atomically; numbers round-trip exactly).
pub fn write_timeseries(path: &Path, ts: &TimeSeries) -> Result<()> {
    write_atomic(path, format_timeseries(ts)?.as_bytes())
}

/// Formats an FRF as FRF CSV text (docs/formats.md, "FRF CSV").
///
/// Fails when a channel's length differs from the grid, a value is NaN/Inf or the
/// frequencies are not strictly increasing (the file would not read back).
pub fn format_frf_csv(frf: &Frf) -> Result<String> {
    let n = frf.freqs_hz.len();
    if frf.freqs_hz.windows(2).any(|w| w[1] <= w[0])
        || frf.freqs_hz.iter().any(|f| !f.is_finite() || *f < 0.0)
    {
        return Err(Error::BadInput(
            "cannot write FRF: frequencies must be finite, non-negative and strictly increasing"
                .into(),
        ));
    }
    for c in &frf.channels {
        let bad_len = c.h.len() != n || c.coherence.as_ref().is_some_and(|g| g.len() != n);
        if bad_len {
            return Err(Error::BadInput(format!(
                "cannot write FRF: channel {} does not have one value per frequency ({n})",
                c.channel
            )));
        }
        if let Some(i) =
            c.h.iter()
                .position(|z| !(z.re.is_finite() && z.im.is_finite()))
        {
            return Err(Error::Numerical(format!(
                "cannot write FRF: channel {} is not finite at {} Hz",
                c.channel, frf.freqs_hz[i]
            )));
        }
    }
    let mut out = String::from("f_hz");
    for c in &frf.channels {
        let n = c.channel.name();
        let _ = write!(out, ",{n}_re,{n}_im");
        if c.coherence.is_some() {
            let _ = write!(out, ",{n}_coh");
        }
    }
    out.push('\n');
    for (i, f) in frf.freqs_hz.iter().enumerate() {
        let _ = write!(out, "{f}");
        for c in &frf.channels {
            let h = c.h[i];
            let _ = write!(out, ",{},{}", h.re, h.im);
            if let Some(g) = &c.coherence {
                // NaN coherence (undefined) is written as 0
                let v = if g[i].is_nan() {
                    0.0
                } else {
                    g[i].clamp(0.0, 1.0)
                };
                let _ = write!(out, ",{v}");
            }
        }
        out.push('\n');
    }
    Ok(out)
}

/// Writes an FRF CSV (docs/formats.md, "FRF CSV") atomically.
pub fn write_frf_csv(path: &Path, frf: &Frf) -> Result<()> {
    write_atomic(path, format_frf_csv(frf)?.as_bytes())
}

/// Reads an FRF CSV (docs/formats.md, "FRF CSV").
pub fn read_frf_csv(path: &Path) -> Result<Frf> {
    let text = read_text(path)?;
    parse_frf_csv(&text, path)
}

#[derive(Clone, Copy, PartialEq)]
enum Part {
    Re,
    Im,
    Coh,
}

/// Parses FRF CSV text; `source` names the file in messages.
///
/// Strict: `f_hz` first, strictly increasing and non-negative; per channel both `_re`
/// and `_im`, `_coh` optional and in [0, 1]; any other column is an error.
pub fn parse_frf_csv(text: &str, source: &Path) -> Result<Frf> {
    let file = source;
    let mut lines = numbered_lines(text)
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(Error::bad_file(
            file,
            0,
            None,
            "empty FRF file; expected a header such as 'f_hz,xx_re,xx_im,xx_coh' and one row per frequency",
        ));
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    if !names[0].eq_ignore_ascii_case("f_hz") {
        return Err(Error::bad_file(
            file,
            header_line,
            Some(names[0]),
            "the first column of an FRF CSV must be 'f_hz' (frequency in hertz)",
        ));
    }
    // (channel, part) per column, and the channel order of first appearance.
    let mut map: Vec<(Channel, Part)> = Vec::new();
    let mut order: Vec<Channel> = Vec::new();
    for (i, &name) in names.iter().enumerate().skip(1) {
        if names[..i].iter().any(|n| n.eq_ignore_ascii_case(name)) {
            return Err(Error::bad_file(
                file,
                header_line,
                Some(name),
                format!("column '{name}' appears twice in the header; keep one of them"),
            ));
        }
        let lower = name.to_ascii_lowercase();
        let parsed = lower.rsplit_once('_').and_then(|(c, p)| {
            let part = match p {
                "re" => Part::Re,
                "im" => Part::Im,
                "coh" => Part::Coh,
                _ => return None,
            };
            Channel::parse(c).map(|c| (c, part))
        });
        let Some((ch, part)) = parsed else {
            return Err(Error::bad_file(
                file,
                header_line,
                Some(name),
                format!("unknown column '{name}'; FRF columns are <out><in>_re, <out><in>_im, <out><in>_coh with axes x, y, z (e.g. yx_re)"),
            ));
        };
        if !order.contains(&ch) {
            order.push(ch);
        }
        map.push((ch, part));
    }
    for ch in &order {
        for (part, suffix) in [(Part::Re, "re"), (Part::Im, "im")] {
            if !map.contains(&(*ch, part)) {
                return Err(Error::bad_file(
                    file,
                    header_line,
                    Some(&format!("{}_{suffix}", ch.name())),
                    format!("channel {ch} has no '{ch}_{suffix}' column; each channel needs both _re and _im"),
                ));
            }
        }
    }
    if order.is_empty() {
        return Err(Error::bad_file(
            file,
            header_line,
            None,
            "no FRF channel in the header; add columns such as xx_re,xx_im",
        ));
    }

    let mut frf = Frf {
        freqs_hz: Vec::new(),
        channels: order
            .iter()
            .map(|&channel| FrfChannel {
                channel,
                h: Vec::new(),
                coherence: map.contains(&(channel, Part::Coh)).then(Vec::new),
            })
            .collect(),
    };
    let idx: Vec<usize> = map
        .iter()
        .map(|(c, _)| order.iter().position(|o| o == c).unwrap_or(0))
        .collect();
    let mut row = vec![0.0; names.len()];
    let mut prev: Option<(f64, usize)> = None;
    for (n, l) in lines {
        let mut count = 0;
        for (j, cell) in l.split(',').enumerate() {
            count = j + 1;
            if j < names.len() {
                row[j] = match fast_f64(cell.trim_ascii()) {
                    Some(v) => v,
                    None => parse_cell(cell, file, n, names[j])?,
                };
            }
        }
        if count != names.len() {
            return Err(Error::bad_file(
                file,
                n,
                None,
                format!("this row has {} but the header (line {header_line}) has {}; every row needs one value per column", crate::axis::count(count, "cell"), crate::axis::count(names.len(), "column")),
            ));
        }
        let f = row[0];
        if f < 0.0 {
            return Err(Error::bad_file(
                file,
                n,
                Some(names[0]),
                format!("negative frequency {f}; frequencies are in hertz, 0 or more"),
            ));
        }
        if let Some((p, pl)) = prev {
            if f <= p {
                return Err(Error::bad_file(
                    file,
                    n,
                    Some(names[0]),
                    format!("frequency {f} does not increase (line {pl} has {p}); sort the rows by frequency and remove duplicates"),
                ));
            }
        }
        prev = Some((f, n));
        frf.freqs_hz.push(f);
        let start = frf.channels[0].h.len();
        for c in frf.channels.iter_mut() {
            c.h.push(Complex64::new(0.0, 0.0));
        }
        for (j, ((_, part), &ci)) in map.iter().zip(&idx).enumerate() {
            let v = row[j + 1];
            let c = &mut frf.channels[ci];
            match part {
                Part::Re => c.h[start].re = v,
                Part::Im => c.h[start].im = v,
                Part::Coh => {
                    if !(0.0..=1.0).contains(&v) {
                        return Err(Error::bad_file(
                            file,
                            n,
                            Some(names[j + 1]),
                            format!("coherence {v} outside [0, 1]; coherence is a ratio between 0 and 1"),
                        ));
                    }
                    if let Some(g) = c.coherence.as_mut() {
                        g.push(v);
                    }
                }
            }
        }
    }
    if frf.freqs_hz.is_empty() {
        return Err(Error::bad_file(
            file,
            header_line,
            None,
            "header only, no data rows; add one row per frequency below the header",
        ));
    }
    Ok(frf)
}

/// Parses one Python complex literal such as `(1.2+3.4j)`, `-1e-05j` or `(0.5-2j)`.
pub fn parse_python_complex(s: &str) -> Option<Complex64> {
    let s = s.trim();
    let s = s
        .strip_prefix('(')
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or(s)
        .trim();
    let Some(body) = s.strip_suffix('j').or_else(|| s.strip_suffix('J')) else {
        return s.parse::<f64>().ok().map(|re| Complex64::new(re, 0.0));
    };
    // Split at the last sign that is not the first character and not an exponent sign.
    let b = body.as_bytes();
    let split = (1..b.len())
        .rev()
        .find(|&i| (b[i] == b'+' || b[i] == b'-') && !matches!(b[i - 1], b'e' | b'E'));
    let (re, im) = match split {
        Some(i) => (
            body[..i].trim().parse().ok()?,
            body[i..].trim().parse().ok()?,
        ),
        None => (0.0, body.trim().parse().ok()?),
    };
    Some(Complex64::new(re, im))
}

/// Reads a text file with one complex value per line (Python syntax, e.g. `(1.2+3.4j)`),
/// as in `pyuff_measured_frf/meas_point_*.txt`; line `i` (0-based, blank and `#` lines
/// skipped) is at frequency `f0_hz + i * df_hz`. Values are returned as stored (the
/// pyuff files hold accelerance); see [`accelerance_to_receptance`].
pub fn read_complex_lines(path: &Path, f0_hz: f64, df_hz: f64) -> Result<Vec<(f64, Complex64)>> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    for (n, l) in numbered_lines(&text) {
        let t = l.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let Some(z) = parse_python_complex(t) else {
            return Err(Error::bad_file(
                path,
                n,
                None,
                format!(
                    "'{t}' is not a complex number; expected one value per line like (1.5+2e-3j)"
                ),
            ));
        };
        if !(z.re.is_finite() && z.im.is_finite()) {
            return Err(Error::bad_file(
                path,
                n,
                None,
                "value is not finite (NaN or Inf); every line must hold a measured value",
            ));
        }
        out.push((f0_hz + out.len() as f64 * df_hz, z));
    }
    if out.is_empty() {
        return Err(Error::bad_file(
            path,
            0,
            None,
            "no values in the file; expected one complex value per line",
        ));
    }
    Ok(out)
}

/// Converts accelerance samples `(f_hz, A)` to a receptance FRF channel `A / (-ω²)`;
/// lines at 0 Hz (where receptance is undefined from accelerance) are dropped.
pub fn accelerance_to_receptance(points: &[(f64, Complex64)], channel: Channel) -> Frf {
    let keep: Vec<&(f64, Complex64)> = points.iter().filter(|(f, _)| *f > 0.0).collect();
    Frf {
        freqs_hz: keep.iter().map(|(f, _)| *f).collect(),
        channels: vec![FrfChannel {
            channel,
            h: keep
                .iter()
                .map(|(f, a)| {
                    let w = 2.0 * std::f64::consts::PI * f;
                    a / (-w * w)
                })
                .collect(),
            coherence: None,
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_give_the_record_of_the_same_file() {
        let n = 40;
        let t: Vec<f64> = (0..n).map(|i| i as f64 / 1000.0).collect();
        let fx: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
        let dx: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).cos() * 1e-6).collect();
        let mut text = String::from("t,fx,dx,q\n");
        for i in 0..n {
            text.push_str(&format!("{},{},{},0\n", t[i], fx[i], dx[i]));
        }
        let src = Path::new("mem");
        let (file, wf) = parse_timeseries_with_warnings(&text, src).unwrap();
        let cols = vec![
            ("t".to_string(), t.clone()),
            ("fx".to_string(), fx.clone()),
            ("dx".to_string(), dx),
            ("q".to_string(), vec![0.0; n]),
        ];
        let (mem, wm) = timeseries_from_columns(src, cols).unwrap();
        assert_eq!(file, mem);
        assert_eq!(wf.len(), 1);
        assert_eq!(wm.len(), 1);
        let short = vec![
            ("t".to_string(), t.clone()),
            ("fx".to_string(), fx[1..].to_vec()),
        ];
        let e = timeseries_from_columns(src, short).unwrap_err().to_string();
        assert!(e.contains("column 'fx'") && e.contains("39 samples"), "{e}");
        let mut nan = fx.clone();
        nan[5] = f64::NAN;
        let e = timeseries_from_columns(src, vec![("t".into(), t.clone()), ("fx".into(), nan)])
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("mem:6 column 'fx'") && e.contains("not finite"),
            "{e}"
        );
        let mut back = t.clone();
        back[10] = back[9];
        let e = timeseries_from_columns(src, vec![("t".into(), back), ("fx".into(), fx)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not increase"), "{e}");
    }

    #[test]
    fn durations_read_as_people_write_them() {
        assert_eq!(seconds_text(2.0000000000000018e-3), "2 ms");
        assert_eq!(seconds_text(1.0204e-3), "1.02 ms");
        assert_eq!(seconds_text(9.765625e-5), "97.66 µs");
        assert_eq!(seconds_text(1.5), "1.5 s");
        assert_eq!(seconds_text(2.5e-9), "2.5 ns");
    }

    #[test]
    fn python_complex_forms() {
        let c = |s| parse_python_complex(s).unwrap();
        assert_eq!(c("(1.5+2j)"), Complex64::new(1.5, 2.0));
        assert_eq!(c("(-0.07-1e-08j)"), Complex64::new(-0.07, -1e-8));
        assert_eq!(c("(1e-05+2E+03j)"), Complex64::new(1e-5, 2e3));
        assert_eq!(c("-3j"), Complex64::new(0.0, -3.0));
        assert_eq!(c("2.5"), Complex64::new(2.5, 0.0));
        assert!(parse_python_complex("(1+zj)").is_none());
    }

    #[test]
    fn fast_path_agrees_with_std() {
        let cases = [
            "0",
            "-0",
            "1",
            "+2.5",
            "0.0000390625",
            "-0.0166735103",
            "36.53798",
            "1e5",
            "1.5E-3",
            "123456789012345678",
            "9007199254740993",
            "1e22",
            "1e23",
            "4.9e-324",
            ".5",
            "5.",
            "-.25e+2",
            "0.1",
            "3.141592653589793",
            "1e-22",
            "2.2250738585072014e-308",
        ];
        for c in cases {
            let want: f64 = c.parse().unwrap();
            let got = fast_f64(c).unwrap_or(want);
            assert_eq!(got.to_bits(), want.to_bits(), "{c}");
        }
        for hot in ["-0.0166735103", "0.0000390625", "36.53798", "1e-5"] {
            assert!(fast_f64(hot).is_some(), "{hot} should take the fast path");
        }
        for bad in ["", "-", ".", "e5", "1e", "1x", "--1", "nan", "inf", "1e+"] {
            assert!(fast_f64(bad).is_none(), "{bad}");
        }
        // a pseudo-random sweep of decimal strings
        let mut x: u64 = 0x2545_f491_4f6c_dd1d;
        for _ in 0..20000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let digits = x % 10_000_000_000_000;
            let frac = (x >> 50) % 16;
            let s = digits.to_string();
            let cut = s.len().saturating_sub(frac as usize);
            let t = format!("{}.{}e{}", &s[..cut], &s[cut..], (x >> 40) % 40);
            let t = t.replace("e", if x & 1 == 0 { "e-" } else { "e" });
            let want: f64 = t.parse().unwrap();
            let got = fast_f64(&t).unwrap_or(want);
            assert_eq!(got.to_bits(), want.to_bits(), "{t}");
        }
    }

    #[test]
    fn comment_strip() {
        assert_eq!(comment_text("# a=b"), "a=b");
        assert_eq!(comment_text("#a"), "a");
        assert_eq!(comment_text("#  two"), " two");
    }
}
