//! Universal File Format (UFF/UNV) dataset 58: functions at nodal DOF, the FRF exchange
//! format of modal testing (pyuff, MATLAB toolboxes, Simcenter Testlab, ME'scope, ...).
//!
//! * [`parse_uff58`] / [`read_uff`] read every dataset 58 of a file, ASCII (`58`) or
//!   binary (`58b`), single or double precision, real or complex, even or uneven abscissa
//!   spacing. Other datasets (15, 55, 151, 164, 2411, ...) are skipped.
//! * [`format_uff58`] / [`write_uff58`] write ASCII, [`format_uff58b`] / [`write_uff58b`]
//!   binary (little-endian IEEE doubles); always double precision, even spacing when the
//!   abscissa is uniform.
//! * [`frf_from_uff`] turns the FRFs (function type 4) of one response/reference node pair
//!   into an [`Frf`] in receptance (m/N), converting accelerance and mobility;
//!   [`uff_from_frf`] goes the other way (receptance, displacement over force).
//!
//! ## Record layout (after the `    -1` delimiter and the `    58` line)
//!
//! | record | format | content |
//! |---|---|---|
//! | 1–5 | 80A1 | ID lines (description, ..., date) |
//! | 6 | 2(I5,I10),2(1X,10A1,I10,I4) | function type, function id, version, load case, response entity/node/direction, reference entity/node/direction |
//! | 7 | 3I10,3E13.5 | ordinate data type (2/4 real single/double, 5/6 complex single/double), number of points, spacing (1 even, 0 uneven), abscissa minimum, increment, z value |
//! | 8–11 | I10,3I5,2(1X,20A1) | abscissa, ordinate (numerator), ordinate denominator and z-axis: specific data type, length/force/temperature unit exponents, label, units label |
//! | 12 | 4E20.12 (double, even), 6E13.5 (single), E13.5,2E20.12 (complex double, uneven), 2(E13.5,E20.12) (real double, uneven) | data; uneven spacing interleaves the abscissa |
//!
//! Binary 58b puts `b` and byte order (1 little, 2 big), floating-point format (2 IEEE),
//! number of ASCII header lines (11) and number of data bytes on the dataset-number line;
//! the data follow record 11 as raw IEEE numbers. The number of bytes actually read is
//! computed from record 7 (pyuff writes a wrong byte count for complex data).
//!
//! ## Reading rules
//!
//! Data lines are split at whitespace; a line whose tokens are not all numbers (fields
//! written without a separating blank) is read in the fixed Fortran field widths above.
//! Fortran `D` exponents and exponents without `E` (`0.1234+100`) are accepted. A blank
//! integer header field reads as 0, as in Fortran. Every violation (truncated data, a
//! non-numeric field, a point count that does not match the data, a missing `    -1`) is an
//! [`Error::BadFile`] with the file, the 1-based line and what to do.
//!
//! ## Units
//!
//! Values are taken as stored and assumed to be SI (m, m/s, m/s², N; abscissa in Hz). The
//! unit exponents of records 8–11 are kept but not applied, and dataset 164 (units) is
//! skipped: convert files written in other unit systems before reading.

use crate::atomic::write_atomic;
use crate::axis::{Axis, Channel};
use crate::error::{Error, Result};
use crate::frf::{Frf, FrfChannel};
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::Path;

/// Function type 0: general or unknown.
pub const FUNC_GENERAL: i32 = 0;
/// Function type 1: time response.
pub const FUNC_TIME_RESPONSE: i32 = 1;
/// Function type 4: frequency response function.
pub const FUNC_FRF: i32 = 4;
/// Function type 6: coherence.
pub const FUNC_COHERENCE: i32 = 6;

/// Specific data type 0: unknown.
pub const DATA_UNKNOWN: i32 = 0;
/// Specific data type 1: general.
pub const DATA_GENERAL: i32 = 1;
/// Specific data type 8: displacement.
pub const DATA_DISPLACEMENT: i32 = 8;
/// Specific data type 11: velocity.
pub const DATA_VELOCITY: i32 = 11;
/// Specific data type 12: acceleration.
pub const DATA_ACCELERATION: i32 = 12;
/// Specific data type 13: excitation force.
pub const DATA_FORCE: i32 = 13;
/// Specific data type 17: time.
pub const DATA_TIME: i32 = 17;
/// Specific data type 18: frequency.
pub const DATA_FREQUENCY: i32 = 18;

/// One axis description of records 8–11 (abscissa, ordinate, denominator, z axis).
/// The default is data type 0 (unknown), exponents 0, labels `NONE`.
#[derive(Debug, Clone, PartialEq)]
pub struct UffAxis {
    /// Specific data type: 0 unknown, 1 general, 8 displacement, 11 velocity,
    /// 12 acceleration, 13 excitation force, 17 time, 18 frequency, ... (see the `DATA_*`
    /// constants).
    pub data_type: i32,
    /// Length unit exponent.
    pub len_exp: i32,
    /// Force unit exponent.
    pub force_exp: i32,
    /// Temperature unit exponent.
    pub temp_exp: i32,
    /// Axis label (at most 20 characters are written).
    pub label: String,
    /// Units label (at most 20 characters are written).
    pub units: String,
}

impl Default for UffAxis {
    fn default() -> Self {
        UffAxis {
            data_type: DATA_UNKNOWN,
            len_exp: 0,
            force_exp: 0,
            temp_exp: 0,
            label: "NONE".into(),
            units: "NONE".into(),
        }
    }
}

impl UffAxis {
    /// An axis with this data type, label and units label, unit exponents zero.
    pub fn new(data_type: i32, label: &str, units: &str) -> Self {
        UffAxis {
            data_type,
            label: label.into(),
            units: units.into(),
            ..Default::default()
        }
    }
}

/// One dataset 58: a function (FRF, coherence, spectrum, time response) at nodal DOF.
#[derive(Debug, Clone, PartialEq)]
pub struct UffFunction {
    /// ID lines 1–5 (records 1–5), trailing blanks removed.
    pub id: [String; 5],
    /// Function type: 0 general, 1 time response, 2 auto spectrum, 3 cross spectrum,
    /// 4 FRF, 6 coherence, 9 PSD, ... (see the `FUNC_*` constants).
    pub func_type: i32,
    /// Function identification number.
    pub func_id: i64,
    /// Version or sequence number.
    pub version: i64,
    /// Load case identification number (0 = single point excitation).
    pub load_case: i64,
    /// Response entity name (`NONE` if unused; at most 10 characters are written).
    pub response_entity: String,
    /// Response node.
    pub response_node: i64,
    /// Response direction: 0 scalar, ±1 ±X, ±2 ±Y, ±3 ±Z translation, ±4..±6 rotation.
    pub response_dir: i32,
    /// Reference (excitation) entity name.
    pub reference_entity: String,
    /// Reference node.
    pub reference_node: i64,
    /// Reference direction (codes as `response_dir`).
    pub reference_dir: i32,
    /// Ordinate data type as read: 2 real single, 4 real double, 5 complex single,
    /// 6 complex double. The writers always write double precision (4 or 6).
    pub ord_data_type: i32,
    /// Whether the ordinate is complex (types 5 and 6); real data have `im == 0`.
    pub is_complex: bool,
    /// Z-axis value (record 7, field 6).
    pub z_value: f64,
    /// Abscissa description (record 8); for FRFs data type 18, frequency in Hz.
    pub abscissa_axis: UffAxis,
    /// Ordinate numerator description (record 9), e.g. 12 acceleration.
    pub ordinate_axis: UffAxis,
    /// Ordinate denominator description (record 10), e.g. 13 force.
    pub denominator_axis: UffAxis,
    /// Z-axis description (record 11).
    pub z_axis: UffAxis,
    /// Abscissa values, one per point (in Hz for frequency functions).
    pub abscissa: Vec<f64>,
    /// Ordinate values, one per point.
    pub data: Vec<Complex64>,
    /// 1-based line of the `    -1` that opens the dataset in the file it was read from
    /// (0 when built in memory); used in messages.
    pub line: usize,
}

impl Default for UffFunction {
    fn default() -> Self {
        UffFunction {
            id: std::array::from_fn(|_| "NONE".to_string()),
            func_type: FUNC_GENERAL,
            func_id: 0,
            version: 0,
            load_case: 0,
            response_entity: "NONE".into(),
            response_node: 0,
            response_dir: 0,
            reference_entity: "NONE".into(),
            reference_node: 0,
            reference_dir: 0,
            ord_data_type: 6,
            is_complex: true,
            z_value: 0.0,
            abscissa_axis: UffAxis::default(),
            ordinate_axis: UffAxis::default(),
            denominator_axis: UffAxis::default(),
            z_axis: UffAxis::default(),
            abscissa: Vec::new(),
            data: Vec::new(),
            line: 0,
        }
    }
}

impl UffFunction {
    /// Short description for messages: line, ID line 1, nodes and directions.
    fn describe(&self) -> String {
        let at = if self.line > 0 {
            format!("dataset 58 at line {}", self.line)
        } else {
            "dataset 58".to_string()
        };
        format!(
            "{at} ('{}', response {}:{}, reference {}:{})",
            self.id[0].trim(),
            self.response_node,
            self.response_dir,
            self.reference_node,
            self.reference_dir
        )
    }
}

// ---------------------------------------------------------------------------------------
// Reading
// ---------------------------------------------------------------------------------------

/// Reads every dataset 58 / 58b of a universal file.
pub fn read_uff(path: &Path) -> Result<Vec<UffFunction>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_uff58(&bytes, path)
}

/// Byte cursor over a file with 1-based line numbers.
struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
    /// Number of the line that starts at `pos`.
    line: usize,
}

impl<'a> Cursor<'a> {
    /// The next line without its `\n` / `\r\n`, with its number.
    fn next_line(&mut self) -> Option<(usize, &'a [u8])> {
        if self.pos >= self.b.len() {
            return None;
        }
        let rest = &self.b[self.pos..];
        let (mut l, adv) = match rest.iter().position(|&c| c == b'\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        if let Some(s) = l.strip_suffix(b"\r") {
            l = s;
        }
        let n = self.line;
        self.pos += adv;
        self.line += 1;
        Some((n, l))
    }

    /// The next `n` raw bytes (binary data).
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let s = self.b.get(self.pos..end)?;
        self.line += s.iter().filter(|&&c| c == b'\n').count();
        self.pos = end;
        Some(s)
    }
}

fn trim_bytes(l: &[u8]) -> &[u8] {
    let s = l
        .iter()
        .position(|c| !c.is_ascii_whitespace())
        .unwrap_or(l.len());
    let e = l
        .iter()
        .rposition(|c| !c.is_ascii_whitespace())
        .map_or(s, |i| i + 1);
    &l[s..e.max(s)]
}

fn is_delimiter(l: &[u8]) -> bool {
    trim_bytes(l) == b"-1"
}

/// Text of a header line (lossy for non-UTF-8 bytes).
fn text(l: &[u8]) -> String {
    String::from_utf8_lossy(l).into_owned()
}

/// Fixed-width field `[start, start + width)` of a line (shorter lines give shorter or
/// empty fields); char-based on the lossy text.
fn field(chars: &[char], start: usize, width: usize) -> String {
    let s = start.min(chars.len());
    let e = (start + width).min(chars.len());
    chars[s..e].iter().collect()
}

/// Parses a Fortran real: `1.5E+03`, `1.5D+03`, `0.15+004` (exponent without letter).
fn parse_real(s: &str) -> Option<f64> {
    let s = s.trim();
    if s.is_empty() {
        return None;
    }
    if let Ok(v) = s.parse::<f64>() {
        return Some(v);
    }
    let t: String = s
        .chars()
        .map(|c| if c == 'D' || c == 'd' { 'E' } else { c })
        .collect();
    if let Ok(v) = t.parse::<f64>() {
        return Some(v);
    }
    // exponent sign without a letter: 0.123456789012+100
    let b = t.as_bytes();
    let i = (1..b.len()).rev().find(|&i| {
        matches!(b[i], b'+' | b'-') && (b[i - 1].is_ascii_digit() || b[i - 1] == b'.')
    })?;
    format!("{}E{}", &t[..i], &t[i..]).parse().ok()
}

/// Parses a Fortran integer field; blank reads as 0.
fn parse_int(s: &str) -> Option<i64> {
    let s = s.trim();
    if s.is_empty() {
        return Some(0);
    }
    s.parse::<i64>().ok()
}

fn to_i32(v: i64) -> Option<i32> {
    i32::try_from(v).ok()
}

/// Header context for errors.
struct Ctx<'p> {
    file: &'p Path,
}

impl Ctx<'_> {
    fn err(&self, line: usize, column: Option<&str>, msg: impl Into<String>) -> Error {
        Error::bad_file(self.file, line, column, msg)
    }
}

/// Integer fields of a fixed-width record, falling back to whitespace tokens.
/// `spec` = (start, width, name); returns the values in order.
fn int_fields(
    ctx: &Ctx,
    chars: &[char],
    line: usize,
    record: &str,
    spec: &[(usize, usize, &str)],
    tokens_idx: &[usize],
) -> Result<Vec<i64>> {
    let fixed: Option<Vec<i64>> = spec
        .iter()
        .map(|&(s, w, _)| parse_int(&field(chars, s, w)))
        .collect();
    if let Some(v) = fixed {
        return Ok(v);
    }
    let line_s: String = chars.iter().collect();
    let toks: Vec<&str> = line_s.split_whitespace().collect();
    let mut out = Vec::with_capacity(spec.len());
    for (k, &(s, w, name)) in spec.iter().enumerate() {
        let tok = tokens_idx.get(k).and_then(|&i| toks.get(i)).copied();
        match tok.and_then(|t| t.parse::<i64>().ok()) {
            Some(v) => out.push(v),
            None => {
                let shown = field(chars, s, w);
                return Err(ctx.err(
                    line,
                    Some(name),
                    format!(
                        "{record}: '{}' is not an integer; the field is columns {}-{} \
                         (Fortran fixed width), check that the header is not shifted or cut",
                        shown.trim(),
                        s + 1,
                        s + w
                    ),
                ));
            }
        }
    }
    Ok(out)
}

/// Reads records 8–11.
fn parse_axis(ctx: &Ctx, l: &[u8], line: usize, record: &str) -> Result<UffAxis> {
    let t = text(l);
    let chars: Vec<char> = t.chars().collect();
    let spec = [
        (0, 10, "specific data type"),
        (10, 5, "length unit exponent"),
        (15, 5, "force unit exponent"),
        (20, 5, "temperature unit exponent"),
    ];
    let v = int_fields(ctx, &chars, line, record, &spec, &[0, 1, 2, 3])?;
    let small = |x: i64, name: &str| {
        to_i32(x).ok_or_else(|| ctx.err(line, Some(name), format!("{record}: {x} is out of range")))
    };
    Ok(UffAxis {
        data_type: small(v[0], spec[0].2)?,
        len_exp: small(v[1], spec[1].2)?,
        force_exp: small(v[2], spec[2].2)?,
        temp_exp: small(v[3], spec[3].2)?,
        label: field(&chars, 26, 20).trim().to_string(),
        units: field(&chars, 47, 20).trim().to_string(),
    })
}

/// Parses the text or bytes of a universal file and returns every dataset 58 / 58b in
/// file order; `source` names the file in messages.
///
/// Fails with [`Error::BadFile`] when the file holds no dataset 58, when text lies outside
/// a `    -1` ... `    -1` block, or when a dataset 58 is malformed or truncated.
pub fn parse_uff58(bytes: &[u8], source: &Path) -> Result<Vec<UffFunction>> {
    let ctx = Ctx { file: source };
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes); // UTF-8 BOM
    let mut cur = Cursor {
        b: bytes,
        pos: 0,
        line: 1,
    };
    let mut out = Vec::new();
    let mut others: Vec<String> = Vec::new();
    while let Some((n, l)) = cur.next_line() {
        let t = trim_bytes(l);
        if t.is_empty() {
            continue;
        }
        if !is_delimiter(l) {
            return Err(ctx.err(
                n,
                None,
                format!(
                    "'{}' is outside any dataset; a universal file is a sequence of blocks \
                     that start and end with a line '    -1' (is this a UFF/UNV file?)",
                    text(&t[..t.len().min(40)])
                ),
            ));
        }
        let Some((hn, hl)) = cur.next_line() else {
            break; // a trailing lone delimiter
        };
        let ht = trim_bytes(hl);
        if ht.is_empty() || is_delimiter(hl) {
            return Err(ctx.err(
                hn,
                None,
                "expected a dataset number (e.g. '    58') after the '    -1' line that opens \
                 a dataset; remove the empty block",
            ));
        }
        let first: Vec<u8> = ht
            .iter()
            .take_while(|c| !c.is_ascii_whitespace())
            .copied()
            .collect();
        let binary = first.last().is_some_and(|c| c.eq_ignore_ascii_case(&b'b'));
        let num_txt = text(if binary {
            &first[..first.len() - 1]
        } else {
            &first
        });
        let Ok(number) = num_txt.parse::<u32>() else {
            return Err(ctx.err(
                hn,
                None,
                format!(
                    "'{}' is not a dataset number; the line after '    -1' must hold the \
                     dataset number in columns 1-6 (e.g. '    58')",
                    text(&ht[..ht.len().min(40)])
                ),
            ));
        };
        if number == 58 {
            let f = parse_one58(&ctx, &mut cur, n, hn, hl, binary)?;
            out.push(f);
        } else {
            if binary {
                return Err(ctx.err(
                    hn,
                    None,
                    format!(
                        "binary dataset {number}b cannot be skipped safely; export the file \
                         with ASCII datasets except 58b"
                    ),
                ));
            }
            let tag = number.to_string();
            if !others.contains(&tag) {
                others.push(tag);
            }
            loop {
                match cur.next_line() {
                    Some((_, l)) if is_delimiter(l) => break,
                    Some(_) => {}
                    None => {
                        return Err(ctx.err(
                            n,
                            None,
                            format!(
                                "dataset {number} opened here has no closing '    -1' line; \
                                 the file is truncated"
                            ),
                        ))
                    }
                }
            }
        }
    }
    if out.is_empty() {
        let found = if others.is_empty() {
            "no datasets at all".to_string()
        } else {
            format!("only datasets {}", others.join(", "))
        };
        return Err(ctx.err(
            0,
            None,
            format!(
                "no dataset 58 (function at nodal DOF) in the file, {found}; export the FRFs \
                 as universal dataset 58 or 58b"
            ),
        ));
    }
    Ok(out)
}

/// Parses one dataset 58 after its number line `hl` (line `hn`); `open` is the line of
/// the opening delimiter. Leaves the cursor after the closing delimiter.
fn parse_one58(
    ctx: &Ctx,
    cur: &mut Cursor,
    open: usize,
    hn: usize,
    hl: &[u8],
    binary: bool,
) -> Result<UffFunction> {
    // binary spec on the dataset-number line
    let mut little = true;
    if binary {
        let t = text(hl);
        let rest = t
            .split_once(['b', 'B'])
            .map(|(_, r)| r.to_string())
            .unwrap_or_default();
        let toks: Vec<&str> = rest.split_whitespace().collect();
        let bo = toks.first().and_then(|s| s.parse::<i64>().ok());
        let fp = toks.get(1).and_then(|s| s.parse::<i64>().ok());
        match bo {
            Some(1) => little = true,
            Some(2) => little = false,
            _ => {
                return Err(ctx.err(
                    hn,
                    Some("byte ordering"),
                    "dataset 58b: byte ordering must be 1 (little endian) or 2 (big endian) \
                     right after '58b'",
                ))
            }
        }
        if !matches!(fp, Some(2) | Some(0) | None) {
            return Err(ctx.err(
                hn,
                Some("floating-point format"),
                "dataset 58b: only floating-point format 2 (IEEE 754) is supported; export \
                 the file as ASCII dataset 58",
            ));
        }
    }
    let truncated = |line: usize, what: &str| {
        ctx.err(
            line,
            None,
            format!(
                "dataset 58 opened at line {open} ends before {what}; the file is truncated \
                 (a dataset 58 has 11 header lines, the data and a closing '    -1')"
            ),
        )
    };
    let mut header: Vec<(usize, &[u8])> = Vec::with_capacity(11);
    for k in 0..11 {
        let what = format!("header record {} of 11", k + 1);
        match cur.next_line() {
            Some((n, l)) if !is_delimiter(l) => header.push((n, l)),
            Some((n, _)) => return Err(truncated(n, &what)),
            None => return Err(truncated(cur.line.saturating_sub(1).max(hn), &what)),
        }
    }
    let mut f = UffFunction {
        line: open,
        ..Default::default()
    };
    for k in 0..5 {
        f.id[k] = text(header[k].1).trim_end().to_string();
    }
    // record 6
    let (n6, l6) = header[5];
    let t6 = text(l6);
    let c6: Vec<char> = t6.chars().collect();
    let r6 = "record 6 (function type, nodes and directions)";
    let spec6 = [
        (0, 5, "function type"),
        (5, 10, "function id"),
        (15, 5, "version number"),
        (20, 10, "load case"),
        (41, 10, "response node"),
        (51, 4, "response direction"),
        (66, 10, "reference node"),
        (76, 4, "reference direction"),
    ];
    let v6 = int_fields(ctx, &c6, n6, r6, &spec6, &[0, 1, 2, 3, 5, 6, 8, 9])?;
    let small = |x: i64, name: &str, line: usize| {
        to_i32(x).ok_or_else(|| ctx.err(line, Some(name), format!("{x} is out of range")))
    };
    // entity names: fixed columns when the integer fields read in fixed width
    let fixed_ok = spec6
        .iter()
        .all(|&(s, w, _)| parse_int(&field(&c6, s, w)).is_some());
    if fixed_ok {
        f.response_entity = field(&c6, 31, 10).trim().to_string();
        f.reference_entity = field(&c6, 56, 10).trim().to_string();
    } else {
        let toks: Vec<&str> = t6.split_whitespace().collect();
        f.response_entity = toks.get(4).unwrap_or(&"").to_string();
        f.reference_entity = toks.get(7).unwrap_or(&"").to_string();
    }
    f.func_type = small(v6[0], "function type", n6)?;
    f.func_id = v6[1];
    f.version = v6[2];
    f.load_case = v6[3];
    f.response_node = v6[4];
    f.response_dir = small(v6[5], "response direction", n6)?;
    f.reference_node = v6[6];
    f.reference_dir = small(v6[7], "reference direction", n6)?;
    // record 7
    let (n7, l7) = header[6];
    let t7 = text(l7);
    let c7: Vec<char> = t7.chars().collect();
    let r7 = "record 7 (data form)";
    let spec7 = [
        (0, 10, "ordinate data type"),
        (10, 10, "number of points"),
        (20, 10, "abscissa spacing"),
    ];
    let v7 = int_fields(ctx, &c7, n7, r7, &spec7, &[0, 1, 2])?;
    let fixed_ok7 = spec7
        .iter()
        .all(|&(s, w, _)| parse_int(&field(&c7, s, w)).is_some());
    let reals: Vec<Option<f64>> = if fixed_ok7 {
        (0..3)
            .map(|k| {
                let s = field(&c7, 30 + 13 * k, 13);
                if s.trim().is_empty() {
                    Some(0.0)
                } else {
                    parse_real(&s)
                }
            })
            .collect()
    } else {
        let toks: Vec<&str> = t7.split_whitespace().collect();
        (3..6)
            .map(|i| toks.get(i).map_or(Some(0.0), |s| parse_real(s)))
            .collect()
    };
    let names7 = ["abscissa minimum", "abscissa increment", "z-axis value"];
    let mut r = [0.0; 3];
    for k in 0..3 {
        match reals[k] {
            Some(v) if v.is_finite() => r[k] = v,
            _ => {
                return Err(ctx.err(
                    n7,
                    Some(names7[k]),
                    format!(
                        "{r7}: the {} is not a finite number (columns {}-{})",
                        names7[k],
                        31 + 13 * k,
                        43 + 13 * k
                    ),
                ))
            }
        }
    }
    f.ord_data_type = small(v7[0], "ordinate data type", n7)?;
    let (is_complex, double) = match f.ord_data_type {
        2 => (false, false),
        4 => (false, true),
        5 => (true, false),
        6 => (true, true),
        t => {
            return Err(ctx.err(
                n7,
                Some("ordinate data type"),
                format!(
                    "{r7}: ordinate data type {t} is not one of 2 (real single), 4 (real \
                     double), 5 (complex single), 6 (complex double)"
                ),
            ))
        }
    };
    f.is_complex = is_complex;
    let num_pts = v7[1];
    if num_pts < 1 {
        return Err(ctx.err(
            n7,
            Some("number of points"),
            format!("{r7}: number of points is {num_pts}; a function needs at least one point"),
        ));
    }
    let num_pts = num_pts as usize;
    let even = match v7[2] {
        0 => false,
        1 => true,
        s => {
            return Err(ctx.err(
                n7,
                Some("abscissa spacing"),
                format!("{r7}: abscissa spacing {s} must be 0 (uneven) or 1 (even)"),
            ))
        }
    };
    let (xmin, dx) = (r[0], r[1]);
    if even && num_pts > 1 && dx <= 0.0 {
        return Err(ctx.err(
            n7,
            Some("abscissa increment"),
            format!(
                "{r7}: even spacing needs a positive abscissa increment, found {dx}; \
                 columns 44-56 hold the increment"
            ),
        ));
    }
    if even && !(xmin + (num_pts - 1) as f64 * dx).is_finite() {
        return Err(ctx.err(
            n7,
            Some("abscissa increment"),
            format!(
                "{r7}: {num_pts} points from {xmin:e} in steps of {dx:e} go beyond the range \
                 of a double; check the abscissa minimum and increment (columns 31-56)"
            ),
        ));
    }
    f.z_value = r[2];
    f.abscissa_axis = parse_axis(ctx, header[7].1, header[7].0, "record 8 (abscissa)")?;
    f.ordinate_axis = parse_axis(ctx, header[8].1, header[8].0, "record 9 (ordinate)")?;
    f.denominator_axis = parse_axis(
        ctx,
        header[9].1,
        header[9].0,
        "record 10 (ordinate denominator)",
    )?;
    f.z_axis = parse_axis(ctx, header[10].1, header[10].0, "record 11 (z axis)")?;

    // data
    let per_pt = usize::from(is_complex) + 1 + usize::from(!even);
    let Some(expected) = num_pts.checked_mul(per_pt) else {
        return Err(ctx.err(
            n7,
            Some("number of points"),
            "number of points is too large",
        ));
    };
    let values: Vec<f64> = if binary {
        let size = if double { 8 } else { 4 };
        let nbytes = expected.saturating_mul(size);
        let start_line = cur.line;
        let Some(raw) = cur.take(nbytes) else {
            return Err(ctx.err(
                start_line,
                None,
                format!(
                    "dataset 58b opened at line {open}: record 7 declares {num_pts} points = \
                     {nbytes} bytes of binary data but the file has only {} bytes left; the \
                     file is truncated (or was transferred in text mode)",
                    cur.b.len() - cur.pos
                ),
            ));
        };
        let mut v = Vec::with_capacity(expected);
        for ch in raw.chunks_exact(size) {
            let x = if double {
                let a: [u8; 8] = ch.try_into().unwrap_or([0; 8]);
                if little {
                    f64::from_le_bytes(a)
                } else {
                    f64::from_be_bytes(a)
                }
            } else {
                let a: [u8; 4] = ch.try_into().unwrap_or([0; 4]);
                f64::from(if little {
                    f32::from_le_bytes(a)
                } else {
                    f32::from_be_bytes(a)
                })
            };
            if !x.is_finite() {
                return Err(ctx.err(
                    start_line,
                    None,
                    format!(
                        "dataset 58b opened at line {open}: binary value {} is NaN or \
                         infinite; check the byte order (1 little, 2 big endian)",
                        v.len() + 1
                    ),
                ));
            }
            v.push(x);
        }
        // closing delimiter (possibly after a line end)
        loop {
            match cur.next_line() {
                Some((_, l)) if is_delimiter(l) => break,
                Some((_, l)) if trim_bytes(l).is_empty() => {}
                Some((n, _)) => {
                    return Err(ctx.err(
                        n,
                        None,
                        format!(
                            "dataset 58b opened at line {open}: more data than the {num_pts} \
                             points of record 7 (line {n7}), or the closing '    -1' is missing"
                        ),
                    ))
                }
                None => {
                    return Err(ctx.err(
                        cur.line.saturating_sub(1),
                        None,
                        format!(
                            "dataset 58b opened at line {open} has no closing '    -1' line; \
                             the file is truncated"
                        ),
                    ))
                }
            }
        }
        v
    } else {
        let widths: &[usize] = match (double, is_complex, even) {
            (false, _, _) => &[13, 13, 13, 13, 13, 13],
            (true, _, true) => &[20, 20, 20, 20],
            (true, false, false) => &[13, 20, 13, 20],
            (true, true, false) => &[13, 20, 20],
        };
        let mut v: Vec<f64> = Vec::with_capacity(expected.min(1 << 20));
        loop {
            let Some((n, l)) = cur.next_line() else {
                return Err(ctx.err(
                    cur.line.saturating_sub(1),
                    None,
                    format!(
                        "dataset 58 opened at line {open} ends after {} of {expected} values \
                         ({num_pts} points, record 7 at line {n7}) without the closing \
                         '    -1'; the file is truncated",
                        v.len()
                    ),
                ));
            };
            if is_delimiter(l) {
                if v.len() != expected {
                    return Err(ctx.err(
                        n,
                        Some("number of points"),
                        format!(
                            "dataset 58 opened at line {open} holds {} values but record 7 \
                             (line {n7}) declares {num_pts} points = {expected} values ({per_pt} \
                             per point); the data are truncated or the point count is wrong",
                            v.len()
                        ),
                    ));
                }
                break;
            }
            data_line(ctx, l, n, widths, &mut v)?;
            if v.len() > expected {
                return Err(ctx.err(
                    n,
                    Some("number of points"),
                    format!(
                        "dataset 58 opened at line {open} holds more than the {expected} values \
                         that record 7 (line {n7}) declares ({num_pts} points, {per_pt} values \
                         per point); fix the point count or remove the extra data"
                    ),
                ));
            }
        }
        v
    };
    // unpack
    f.abscissa = Vec::with_capacity(num_pts);
    f.data = Vec::with_capacity(num_pts);
    for (i, p) in values.chunks_exact(per_pt).enumerate() {
        let (x, rest) = if even {
            (xmin + i as f64 * dx, p)
        } else {
            (p[0], &p[1..])
        };
        f.abscissa.push(x);
        f.data.push(if is_complex {
            Complex64::new(rest[0], rest[1])
        } else {
            Complex64::new(rest[0], 0.0)
        });
    }
    Ok(f)
}

/// Appends the numbers of one ASCII data line to `v`.
fn data_line(ctx: &Ctx, l: &[u8], n: usize, widths: &[usize], v: &mut Vec<f64>) -> Result<()> {
    let t = text(l);
    let before = v.len();
    let mut ok = true;
    for tok in t.split_whitespace() {
        match parse_real(tok) {
            Some(x) => v.push(x),
            None => {
                ok = false;
                break;
            }
        }
    }
    if !ok {
        v.truncate(before);
        let chars: Vec<char> = t.chars().collect();
        let mut start = 0;
        for (k, &w) in widths.iter().enumerate() {
            if start >= chars.len() {
                break;
            }
            let s = field(&chars, start, w);
            start += w;
            if s.trim().is_empty() {
                continue;
            }
            match parse_real(&s) {
                Some(x) => v.push(x),
                None => {
                    return Err(ctx.err(
                        n,
                        None,
                        format!(
                            "data field {} ('{}', columns {}-{}) is not a number; data lines \
                             hold numbers like -1.234567890123E-02 separated by blanks or in \
                             fixed Fortran widths {:?}",
                            k + 1,
                            s.trim(),
                            start - w + 1,
                            start,
                            widths
                        ),
                    ))
                }
            }
        }
        if start < chars.len() && !field(&chars, start, chars.len()).trim().is_empty() {
            return Err(ctx.err(
                n,
                None,
                format!(
                    "data line has text after column {start} that is not a number in the \
                     fixed Fortran widths {widths:?}"
                ),
            ));
        }
    }
    if let Some(i) = v[before..].iter().position(|x| !x.is_finite()) {
        return Err(ctx.err(
            n,
            None,
            format!(
                "data value {} of the line is NaN or infinite; every value must be a finite \
                 measured number",
                i + 1
            ),
        ));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------

/// Fortran-style `E` format right-aligned in `width` columns, with at least one leading
/// blank and as many decimals (up to `max_dec`) as fit: `-1.234567890123E-02`.
fn fmt_e(x: f64, width: usize, max_dec: usize) -> String {
    let mut dec = max_dec;
    loop {
        let s = format!("{x:.dec$e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let e: i32 = e.parse().unwrap_or(0);
        let sign = if e < 0 { '-' } else { '+' };
        let body = format!("{m}E{sign}{:02}", e.unsigned_abs());
        if body.len() < width || dec == 0 {
            return format!("{body:>width$}");
        }
        dec -= 1;
    }
}

/// Left-aligned ASCII text of at most `width` characters (non-ASCII and control
/// characters become `?` and blank).
fn ascii_field(s: &str, width: usize) -> String {
    let t: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_control() {
                ' '
            } else if c.is_ascii() {
                c
            } else {
                '?'
            }
        })
        .take(width)
        .collect();
    format!("{t:<width$}")
}

fn int_fits(v: i64, width: usize) -> bool {
    v.to_string().len() <= width
}

/// Checks a function before writing; returns (complex, even, xmin, dx).
fn check_for_write(k: usize, f: &UffFunction) -> Result<(bool, bool, f64, f64)> {
    let what = || format!("cannot write function {} ({})", k + 1, f.describe());
    let n = f.data.len();
    if n == 0 || f.abscissa.len() != n {
        return Err(Error::BadInput(format!(
            "{}: it needs at least one point and one abscissa value per data value \
             ({} abscissa, {} data)",
            what(),
            f.abscissa.len(),
            n
        )));
    }
    if let Some(i) = f.abscissa.iter().position(|x| !x.is_finite()) {
        return Err(Error::BadInput(format!(
            "{}: abscissa value {} is not finite",
            what(),
            i + 1
        )));
    }
    if let Some(i) = f
        .data
        .iter()
        .position(|z| !(z.re.is_finite() && z.im.is_finite()))
    {
        return Err(Error::Numerical(format!(
            "{}: value {} (abscissa {}) is not finite",
            what(),
            i + 1,
            f.abscissa[i]
        )));
    }
    if !f.is_complex && f.data.iter().any(|z| z.im != 0.0) {
        return Err(Error::BadInput(format!(
            "{}: is_complex is false but the data have imaginary parts; set is_complex",
            what()
        )));
    }
    let ints: [(i64, usize, &str); 8] = [
        (f.func_type.into(), 5, "function type"),
        (f.func_id, 10, "function id"),
        (f.version, 5, "version number"),
        (f.load_case, 10, "load case"),
        (f.response_node, 10, "response node"),
        (f.response_dir.into(), 4, "response direction"),
        (f.reference_node, 10, "reference node"),
        (f.reference_dir.into(), 4, "reference direction"),
    ];
    for (v, w, name) in ints {
        if !int_fits(v, w) {
            return Err(Error::BadInput(format!(
                "{}: {name} {v} does not fit in its {w}-column field",
                what()
            )));
        }
    }
    for a in [
        &f.abscissa_axis,
        &f.ordinate_axis,
        &f.denominator_axis,
        &f.z_axis,
    ] {
        let ok = int_fits(a.data_type.into(), 10)
            && [a.len_exp, a.force_exp, a.temp_exp]
                .iter()
                .all(|&e| int_fits(e.into(), 5));
        if !ok {
            return Err(Error::BadInput(format!(
                "{}: an axis data type or unit exponent does not fit its field",
                what()
            )));
        }
    }
    let x0 = f.abscissa[0];
    let (even, dx) = if n == 1 {
        (true, 1.0)
    } else {
        let dx = (f.abscissa[n - 1] - x0) / (n - 1) as f64;
        let tol = 1e-9 * (x0.abs() + f.abscissa[n - 1].abs()).max(dx.abs());
        let uniform = dx > 0.0
            && f.abscissa
                .iter()
                .enumerate()
                .all(|(i, x)| (x - (x0 + i as f64 * dx)).abs() <= tol);
        (uniform, if uniform { dx } else { 0.0 })
    };
    Ok((f.is_complex, even, x0, dx))
}

/// The 13 text lines from `    -1` to record 11 (each ending in `\n`).
fn header_text(
    f: &UffFunction,
    complex: bool,
    even: bool,
    x0: f64,
    dx: f64,
    binary_bytes: Option<usize>,
) -> String {
    let mut o = String::new();
    o.push_str("    -1\n");
    match binary_bytes {
        Some(nb) => {
            let _ = writeln!(
                o,
                "    58b{:6}{:6}{:12}{:12}{:6}{:6}{:12}{:12}",
                1, 2, 11, nb, 0, 0, 0, 0
            );
        }
        None => o.push_str("    58\n"),
    }
    for id in &f.id {
        let id = if id.trim().is_empty() { "NONE" } else { id };
        let _ = writeln!(o, "{}", ascii_field(id, 80).trim_end());
    }
    let ent = |s: &str| {
        let s = if s.trim().is_empty() { "NONE" } else { s };
        let t = ascii_field(s, 10);
        format!("{:>10}", t.trim())
    };
    let _ = writeln!(
        o,
        "{:5}{:10}{:5}{:10} {}{:10}{:4} {}{:10}{:4}",
        f.func_type,
        f.func_id,
        f.version,
        f.load_case,
        ent(&f.response_entity),
        f.response_node,
        f.response_dir,
        ent(&f.reference_entity),
        f.reference_node,
        f.reference_dir
    );
    let (xm, xd) = if even { (x0, dx) } else { (0.0, 0.0) };
    let _ = writeln!(
        o,
        "{:10}{:10}{:10}{}{}{}",
        if complex { 6 } else { 4 },
        f.data.len(),
        i32::from(even),
        fmt_e(xm, 13, 9),
        fmt_e(xd, 13, 9),
        fmt_e(f.z_value, 13, 9)
    );
    for a in [
        &f.abscissa_axis,
        &f.ordinate_axis,
        &f.denominator_axis,
        &f.z_axis,
    ] {
        let lab = |s: &str| {
            if s.trim().is_empty() {
                ascii_field("NONE", 20)
            } else {
                ascii_field(s, 20)
            }
        };
        let line = format!(
            "{:10}{:5}{:5}{:5} {} {}",
            a.data_type,
            a.len_exp,
            a.force_exp,
            a.temp_exp,
            lab(&a.label),
            lab(&a.units)
        );
        let _ = writeln!(o, "{}", line.trim_end());
    }
    o
}

/// The data values in file order (abscissa interleaved for uneven spacing).
fn data_values(f: &UffFunction, complex: bool, even: bool) -> Vec<f64> {
    let mut v = Vec::with_capacity(f.data.len() * 3);
    for (x, z) in f.abscissa.iter().zip(&f.data) {
        if !even {
            v.push(*x);
        }
        v.push(z.re);
        if complex {
            v.push(z.im);
        }
    }
    v
}

/// Formats functions as ASCII universal file text (dataset 58, double precision).
///
/// Even spacing is written when the abscissa is uniform to 1e-9 of its span (the
/// minimum and increment are stored with 7 significant digits), else uneven spacing with
/// the abscissa interleaved (also 7 significant digits, the 13-column field). Ordinates
/// have 13–14 significant digits (E20 fields). Fails on empty or non-finite data, a
/// length mismatch or an integer too wide for its field.
pub fn format_uff58(funcs: &[UffFunction]) -> Result<String> {
    let mut o = String::new();
    for (k, f) in funcs.iter().enumerate() {
        let (complex, even, x0, dx) = check_for_write(k, f)?;
        o.push_str(&header_text(f, complex, even, x0, dx, None));
        let vals = data_values(f, complex, even);
        let widths: &[usize] = match (complex, even) {
            (_, true) => &[20, 20, 20, 20],
            (false, false) => &[13, 20, 13, 20],
            (true, false) => &[13, 20, 20],
        };
        for chunk in vals.chunks(widths.len()) {
            for (x, &w) in chunk.iter().zip(widths) {
                o.push_str(&fmt_e(*x, w, if w == 20 { 13 } else { 9 }));
            }
            o.push('\n');
        }
        o.push_str("    -1\n");
    }
    Ok(o)
}

/// Formats functions as binary universal file bytes (dataset 58b, little-endian IEEE
/// doubles, exact).
pub fn format_uff58b(funcs: &[UffFunction]) -> Result<Vec<u8>> {
    let mut o = Vec::new();
    for (k, f) in funcs.iter().enumerate() {
        let (complex, even, x0, dx) = check_for_write(k, f)?;
        let vals = data_values(f, complex, even);
        o.extend_from_slice(header_text(f, complex, even, x0, dx, Some(vals.len() * 8)).as_bytes());
        for x in vals {
            o.extend_from_slice(&x.to_le_bytes());
        }
        o.extend_from_slice(b"\n    -1\n");
    }
    Ok(o)
}

/// Writes functions as an ASCII universal file (dataset 58) atomically.
pub fn write_uff58(path: &Path, funcs: &[UffFunction]) -> Result<()> {
    write_atomic(path, format_uff58(funcs)?.as_bytes())
}

/// Writes functions as a binary universal file (dataset 58b) atomically.
pub fn write_uff58b(path: &Path, funcs: &[UffFunction]) -> Result<()> {
    write_atomic(path, &format_uff58b(funcs)?)
}

// ---------------------------------------------------------------------------------------
// Conversion to and from Frf
// ---------------------------------------------------------------------------------------

/// The machine axis and sign of a UFF direction code (±1 X, ±2 Y, ±3 Z translation);
/// `None` for scalar (0) and rotations (±4..±6).
pub fn direction_axis(dir: i32) -> Option<(Axis, f64)> {
    let s = if dir < 0 { -1.0 } else { 1.0 };
    match dir.abs() {
        1 => Some((Axis::X, s)),
        2 => Some((Axis::Y, s)),
        3 => Some((Axis::Z, s)),
        _ => None,
    }
}

/// The UFF direction code of the positive translation along `a` (1, 2, 3).
pub fn axis_direction(a: Axis) -> i32 {
    a.index() as i32 + 1
}

/// Which functions [`frf_from_uff`] takes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UffSelect {
    /// Only FRFs with this response node (`None` = any).
    pub response_node: Option<i64>,
    /// Only FRFs with this reference (excitation) node (`None` = any).
    pub reference_node: Option<i64>,
    /// Ordinate data type to assume when a file leaves it unknown (0) or general (1):
    /// [`DATA_DISPLACEMENT`], [`DATA_VELOCITY`] or [`DATA_ACCELERATION`]. `None` makes
    /// such files an error.
    pub assume_ordinate: Option<i32>,
}

/// Builds a receptance [`Frf`] (m/N) from the FRFs (function type 4) in `funcs` that
/// match `sel`; channels are named by the response and reference directions (±1..3 →
/// X, Y, Z; a negative direction flips the sign).
///
/// Accelerance (ordinate data type 12) is divided by −ω², mobility (11) by jω,
/// receptance (8) is taken as is; when a conversion divides by ω, lines at 0 Hz are
/// dropped. The denominator must be force (13) or unknown (0). Coherence functions
/// (type 6) with the same nodes and directions on the same grid become the channels'
/// coherence. Fails ([`Error::BadInput`]) when nothing matches, two FRFs give the same
/// channel (select one node pair), the grids differ, a direction is a rotation or scalar,
/// the ordinate is not a motion, or a coherence lies outside [0, 1].
pub fn frf_from_uff(funcs: &[UffFunction], sel: &UffSelect) -> Result<Frf> {
    let matches = |f: &&UffFunction| {
        sel.response_node.is_none_or(|n| f.response_node == n)
            && sel.reference_node.is_none_or(|n| f.reference_node == n)
    };
    let frfs: Vec<&UffFunction> = funcs
        .iter()
        .filter(|f| f.func_type == FUNC_FRF)
        .filter(matches)
        .collect();
    if frfs.is_empty() {
        let avail: Vec<String> = funcs
            .iter()
            .filter(|f| f.func_type == FUNC_FRF)
            .map(|f| format!("{}->{}", f.reference_node, f.response_node))
            .collect();
        return Err(Error::BadInput(format!(
            "no FRF (function type 4) with response node {} and reference node {} among {} \
             dataset-58 functions; FRFs present (reference->response node): [{}]",
            sel.response_node.map_or("any".into(), |n| n.to_string()),
            sel.reference_node.map_or("any".into(), |n| n.to_string()),
            funcs.len(),
            avail.join(", ")
        )));
    }
    let grid = &frfs[0].abscissa;
    let same_grid = |x: &[f64]| {
        x.len() == grid.len() && {
            let scale = grid.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            x.iter()
                .zip(grid)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * scale)
        }
    };
    if grid.windows(2).any(|w| w[1] <= w[0]) || grid.iter().any(|f| *f < 0.0) {
        return Err(Error::BadInput(format!(
            "{}: the frequencies are not non-negative and strictly increasing",
            frfs[0].describe()
        )));
    }
    let mut chans: Vec<(Channel, &UffFunction, f64, i32)> = Vec::new();
    let mut needs_omega = false;
    for f in &frfs {
        if !matches!(f.abscissa_axis.data_type, DATA_FREQUENCY | DATA_UNKNOWN) {
            return Err(Error::BadInput(format!(
                "{}: the abscissa has data type {}, not frequency (18)",
                f.describe(),
                f.abscissa_axis.data_type
            )));
        }
        if !same_grid(&f.abscissa) {
            return Err(Error::BadInput(format!(
                "{} is on a different frequency grid than {} ({} lines from {} Hz vs {} \
                 from {} Hz); select FRFs of one measurement",
                f.describe(),
                frfs[0].describe(),
                f.abscissa.len(),
                f.abscissa.first().copied().unwrap_or(f64::NAN),
                grid.len(),
                grid.first().copied().unwrap_or(f64::NAN)
            )));
        }
        let (Some((o, so)), Some((i, si))) = (
            direction_axis(f.response_dir),
            direction_axis(f.reference_dir),
        ) else {
            return Err(Error::BadInput(format!(
                "{}: directions must be translations ±1, ±2, ±3 (X, Y, Z); scalar and \
                 rotational DOFs have no machine axis",
                f.describe()
            )));
        };
        let kind = match f.ordinate_axis.data_type {
            t @ (DATA_DISPLACEMENT | DATA_VELOCITY | DATA_ACCELERATION) => t,
            t @ (DATA_UNKNOWN | DATA_GENERAL) => match sel.assume_ordinate {
                Some(a @ (DATA_DISPLACEMENT | DATA_VELOCITY | DATA_ACCELERATION)) => a,
                _ => {
                    return Err(Error::BadInput(format!(
                        "{}: the ordinate data type is {t} (unknown/general), so receptance, \
                         mobility and accelerance cannot be told apart; set assume_ordinate \
                         to 8 (displacement), 11 (velocity) or 12 (acceleration)",
                        f.describe()
                    )))
                }
            },
            t => {
                return Err(Error::BadInput(format!(
                    "{}: ordinate data type {t} is not a motion (8 displacement, 11 velocity, \
                     12 acceleration)",
                    f.describe()
                )))
            }
        };
        if !matches!(f.denominator_axis.data_type, DATA_FORCE | DATA_UNKNOWN) {
            return Err(Error::BadInput(format!(
                "{}: the ordinate denominator has data type {}, not force (13)",
                f.describe(),
                f.denominator_axis.data_type
            )));
        }
        let c = Channel::new(o, i);
        if let Some((_, g, _, _)) = chans.iter().find(|(cc, ..)| *cc == c) {
            return Err(Error::BadInput(format!(
                "{} and {} both give channel {c}; select one response and one reference \
                 node",
                g.describe(),
                f.describe()
            )));
        }
        needs_omega |= kind != DATA_DISPLACEMENT;
        chans.push((c, f, so * si, kind));
    }
    let keep: Vec<usize> = (0..grid.len())
        .filter(|&k| !needs_omega || grid[k] > 0.0)
        .collect();
    let mut out = Frf {
        freqs_hz: keep.iter().map(|&k| grid[k]).collect(),
        channels: Vec::with_capacity(chans.len()),
    };
    for (c, f, sign, kind) in chans {
        let h = keep
            .iter()
            .map(|&k| {
                let w = 2.0 * std::f64::consts::PI * grid[k];
                let z = f.data[k] * sign;
                let h = match kind {
                    DATA_VELOCITY => z / Complex64::new(0.0, w),
                    DATA_ACCELERATION => z / (-w * w),
                    _ => z,
                };
                if h.re.is_finite() && h.im.is_finite() {
                    Ok(h)
                } else {
                    Err(Error::BadInput(format!(
                        "{}: the receptance at {} Hz is beyond the range of a double (the \
                         line is too close to 0 Hz to divide by the frequency); drop the \
                         lowest lines",
                        f.describe(),
                        grid[k]
                    )))
                }
            })
            .collect::<Result<Vec<_>>>()?;
        let coherence = match funcs.iter().find(|g| {
            g.func_type == FUNC_COHERENCE
                && g.response_node == f.response_node
                && g.reference_node == f.reference_node
                && g.response_dir.abs() == f.response_dir.abs()
                && g.reference_dir.abs() == f.reference_dir.abs()
                && same_grid(&g.abscissa)
        }) {
            Some(g) => Some(coherence_values(g, &keep)?),
            None => None,
        };
        out.channels.push(FrfChannel {
            channel: c,
            h,
            coherence,
        });
    }
    Ok(out)
}

/// The coherence of function `g` at the lines `keep`, checked to lie in [0, 1] (values
/// within 1e-6 outside, rounding of the writer, are clamped).
fn coherence_values(g: &UffFunction, keep: &[usize]) -> Result<Vec<f64>> {
    const SLACK: f64 = 1e-6;
    keep.iter()
        .map(|&k| {
            let v = g.data[k].re;
            if (-SLACK..=1.0 + SLACK).contains(&v) {
                Ok(v.clamp(0.0, 1.0))
            } else {
                Err(Error::BadInput(format!(
                    "{}: coherence {v} at {} Hz is outside [0, 1]; coherence is a ratio \
                     between 0 and 1 (is this function really a coherence?)",
                    g.describe(),
                    g.abscissa[k]
                )))
            }
        })
        .collect()
}

/// UFF functions of an [`Frf`]: one FRF (function type 4, complex, receptance =
/// displacement over force, SI unit exponents, `m` per `N`) per channel at `node`
/// (response and reference on the same node, directions 1/2/3 = X/Y/Z), plus one
/// coherence function (type 6, real) per channel that has coherence. Write them with
/// [`write_uff58`] or [`write_uff58b`].
pub fn uff_from_frf(frf: &Frf, node: i64) -> Vec<UffFunction> {
    let freq = UffAxis::new(DATA_FREQUENCY, "frequency", "Hz");
    let disp = UffAxis {
        len_exp: 1,
        ..UffAxis::new(DATA_DISPLACEMENT, "displacement", "m")
    };
    let force = UffAxis {
        force_exp: 1,
        ..UffAxis::new(DATA_FORCE, "force", "N")
    };
    let mut out = Vec::new();
    for (k, c) in frf.channels.iter().enumerate() {
        let base = UffFunction {
            func_id: k as i64 + 1,
            response_node: node,
            response_dir: axis_direction(c.channel.output),
            reference_node: node,
            reference_dir: axis_direction(c.channel.input),
            abscissa_axis: freq.clone(),
            abscissa: frf.freqs_hz.clone(),
            ..Default::default()
        };
        out.push(UffFunction {
            id: [
                format!("mtwin receptance {}", c.channel),
                "response/force, m/N".into(),
                "NONE".into(),
                "NONE".into(),
                "NONE".into(),
            ],
            func_type: FUNC_FRF,
            ord_data_type: 6,
            is_complex: true,
            ordinate_axis: disp.clone(),
            denominator_axis: force.clone(),
            data: c.h.clone(),
            ..base.clone()
        });
        if let Some(g) = &c.coherence {
            out.push(UffFunction {
                id: [
                    format!("mtwin coherence {}", c.channel),
                    "NONE".into(),
                    "NONE".into(),
                    "NONE".into(),
                    "NONE".into(),
                ],
                func_type: FUNC_COHERENCE,
                ord_data_type: 4,
                is_complex: false,
                ordinate_axis: UffAxis::new(DATA_UNKNOWN, "coherence", "NONE"),
                data: g
                    .iter()
                    .map(|&v| Complex64::new(if v.is_nan() { 0.0 } else { v }, 0.0))
                    .collect(),
                ..base
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fortran_reals() {
        assert_eq!(parse_real("1.5E+03"), Some(1500.0));
        assert_eq!(parse_real("1.5D+03"), Some(1500.0));
        assert_eq!(parse_real("-0.15-002"), Some(-0.0015));
        assert_eq!(parse_real("0.5+100"), Some(0.5e100));
        assert_eq!(parse_real("abc"), None);
        assert_eq!(parse_real("1.5E"), None);
    }

    #[test]
    fn e_format_fits_with_a_blank() {
        assert_eq!(fmt_e(-0.0774752256830106, 20, 13), " -7.747522568301E-02");
        assert_eq!(fmt_e(0.0774752256830106, 20, 13), " 7.7475225683011E-02");
        assert_eq!(fmt_e(1.0, 13, 9), " 1.000000E+00");
        assert_eq!(fmt_e(-1e-300, 20, 13), " -1.00000000000E-300");
        for x in [0.0, 1.0, -1.0, 1e-300, -3.3e200, 123456.789] {
            for w in [13, 20] {
                let s = fmt_e(x, w, 13);
                assert_eq!(s.len(), w, "{s}");
                assert!(s.starts_with(' '), "{s}");
                let back: f64 = s.trim().parse().unwrap();
                assert!((back - x).abs() <= 1e-5 * x.abs(), "{s}");
            }
        }
    }

    #[test]
    fn directions() {
        assert_eq!(direction_axis(-2), Some((Axis::Y, -1.0)));
        assert_eq!(direction_axis(4), None);
        for a in Axis::ALL {
            assert_eq!(direction_axis(axis_direction(a)), Some((a, 1.0)));
        }
    }
}
