//! Reading a time-series CSV row by row in constant memory (for records too long to
//! hold: 10 minutes at 25.6 kHz are 15 million rows).
//!
//! [`RowReader`] applies exactly the rules of [`read_timeseries`](super::read_timeseries)
//! (same header, cells, comments, UTF-8 and error messages with line and column) with
//! one difference forced by streaming: the *typical* time step that points at a missing
//! or repeated row is the median of the first three steps, not of all steps (which
//! would need every step in memory). The SPEC rule itself — every step within 1 % of
//! the mean step — is applied exactly: the smallest and largest step are kept, and
//! when one of them is off the mean (known only at the end), the file is read once more
//! to name the first offending line. When a file has several faults, the one reported
//! is the one the in-memory reader reports (a bad cell before a bad time step, time
//! order before the sampling checks), except that a typical-step fault is judged
//! against the first three steps.
//!
//! [`scan_timeseries`] reads a whole file this way and keeps only what a streamed
//! estimate needs to know before its own pass: the row count, the time axis and
//! per-force-column statistics ([`ColumnStats`]).

use super::{
    check_row_count, comment_text, irregular_step, mean_step, no_header, not_increasing, not_utf8,
    off_step, Header, LineKind, Role, StepRef,
};
use crate::axis::Axis;
use crate::error::{Error, Result};
use crate::timeseries::ResponseKind;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Comment lines a [`RowReader`] keeps (later ones are skipped).
pub const MAX_COMMENTS: usize = 256;

/// Largest number of samples per force column kept in [`ColumnStats::subsample`].
pub const SUBSAMPLE_CAP: usize = 1 << 16;

/// Stride of the systematic subsample kept of a column of `n` samples
/// ([`ColumnStats::subsample`]): the smallest power of two that leaves at most
/// [`SUBSAMPLE_CAP`] samples.
pub fn subsample_stride(n: usize) -> usize {
    let mut stride = 1;
    while n.div_ceil(stride) > SUBSAMPLE_CAP {
        stride *= 2;
    }
    stride
}

/// A time-series CSV read one row at a time (module docs).
#[derive(Debug)]
pub struct RowReader {
    file: PathBuf,
    reader: BufReader<File>,
    buf: Vec<u8>,
    /// Number of the last line read.
    line: usize,
    header: Header,
    row: Vec<f64>,
    comments: Vec<String>,
    warnings: Vec<String>,
    time: TimeCheck,
}

/// What is known of a file's time axis once every row has been read.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordEnd {
    /// Number of data rows.
    pub rows: usize,
    /// Time of the first row \[s\].
    pub t0: f64,
    /// Mean step \[s\] = sample period, as [`TimeSeries::dt`](crate::timeseries::TimeSeries::dt).
    pub dt: f64,
}

impl RowReader {
    /// Opens `path` and reads up to and including the header.
    pub fn open(path: &Path) -> Result<Self> {
        let f = File::open(path).map_err(|e| Error::io(path, e))?;
        let mut r = RowReader {
            file: path.to_path_buf(),
            reader: BufReader::with_capacity(1 << 16, f),
            buf: Vec::with_capacity(256),
            line: 0,
            header: Header {
                line: 0,
                names: Vec::new(),
                roles: Vec::new(),
                time_col: 0,
                kind: None,
            },
            row: Vec::new(),
            comments: Vec::new(),
            warnings: Vec::new(),
            time: TimeCheck::default(),
        };
        loop {
            if !r.next_line()? {
                return Err(no_header(path));
            }
            let l = line_str(&r.buf);
            match LineKind::of(l) {
                LineKind::Comment => push_comment(&mut r.comments, l),
                LineKind::Blank => {}
                LineKind::Content => {
                    r.header = Header::parse(r.line, l, path, &mut r.warnings)?;
                    break;
                }
            }
        }
        r.row = vec![0.0; r.header.names.len()];
        Ok(r)
    }

    /// Reads the next line into `buf` (without its line end); false at the end of the file.
    fn next_line(&mut self) -> Result<bool> {
        self.buf.clear();
        let n = self
            .reader
            .read_until(b'\n', &mut self.buf)
            .map_err(|e| Error::io(&self.file, e))?;
        if n == 0 {
            return Ok(false);
        }
        self.line += 1;
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
            if self.buf.last() == Some(&b'\r') {
                self.buf.pop();
            }
        }
        if std::str::from_utf8(&self.buf).is_err() {
            return Err(not_utf8(&self.file, self.line));
        }
        Ok(true)
    }

    /// The next data row, one value per header column (0 for ignored columns), or `None`
    /// at the end of the file. Cell errors are returned at once; time-axis errors are
    /// returned by [`RowReader::finish`] (in the order the in-memory reader checks them).
    pub fn next_row(&mut self) -> Result<Option<&[f64]>> {
        loop {
            if !self.next_line()? {
                return Ok(None);
            }
            let l = line_str(&self.buf);
            match LineKind::of(l) {
                LineKind::Blank => {}
                LineKind::Comment => push_comment(&mut self.comments, l),
                LineKind::Content => {
                    let row = &mut self.row;
                    self.header
                        .parse_row(l, self.line, &self.file, |j, v| row[j] = v)?;
                    let t = self.row[self.header.time_col];
                    self.time.push(t, self.line);
                    return Ok(Some(&self.row));
                }
            }
        }
    }

    /// 1-based number of the last line read.
    pub fn line(&self) -> usize {
        self.line
    }

    /// Column index of the force along `a`, if the file has one.
    pub fn force_column(&self, a: Axis) -> Option<usize> {
        self.header.roles.iter().position(|r| *r == Role::Force(a))
    }

    /// Column index of the response along `a`, if the file has one.
    pub fn response_column(&self, a: Axis) -> Option<usize> {
        self.header
            .roles
            .iter()
            .position(|r| matches!(r, Role::Response(b, _) if *b == a))
    }

    /// Kind of the response columns (`None` without response columns).
    pub fn response_kind(&self) -> Option<ResponseKind> {
        self.header.kind
    }

    /// Column names as written in the header.
    pub fn column_names(&self) -> &[String] {
        &self.header.names
    }

    /// Warnings so far (unknown columns ignored), without the file name.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The first [`MAX_COMMENTS`] comment lines so far, without their `#`.
    pub fn comments(&self) -> &[String] {
        &self.comments
    }

    /// Checks the time axis once every row has been read (module docs) and returns it.
    /// Call after [`RowReader::next_row`] returned `None`.
    pub fn finish(&self) -> Result<RecordEnd> {
        let file = &self.file;
        let tc = &self.time;
        check_row_count(file, &self.header, tc.rows)?;
        let tname = self.header.time_name();
        if let Some((at, prev)) = tc.decrease {
            return Err(not_increasing(file, tname, at, prev));
        }
        let mean = mean_step(file, tname, (tc.t0, tc.t_prev), tc.rows, tc.prev_line)?;
        if let Some((line, step, typical)) = tc.irregular {
            return Err(irregular_step(
                file,
                line,
                tname,
                step,
                typical,
                StepRef::Typical,
            ));
        }
        if off_step(tc.step_min, mean) || off_step(tc.step_max, mean) {
            return Err(first_step_off_mean(file, mean));
        }
        Ok(RecordEnd {
            rows: tc.rows,
            t0: tc.t0,
            dt: mean,
        })
    }
}

fn line_str(buf: &[u8]) -> &str {
    // checked in next_line
    std::str::from_utf8(buf).unwrap_or_default()
}

fn push_comment(comments: &mut Vec<String>, l: &str) {
    if comments.len() < MAX_COMMENTS {
        comments.push(comment_text(l));
    }
}

/// Running checks of the time column; the faults are kept (first of each kind) and
/// reported by [`RowReader::finish`].
#[derive(Debug, Default)]
struct TimeCheck {
    rows: usize,
    t0: f64,
    t_prev: f64,
    prev_line: usize,
    /// The first three steps with the lines they end at, until the typical step is known.
    first: Vec<(f64, usize)>,
    typical: Option<f64>,
    step_min: f64,
    step_max: f64,
    /// First time that does not increase: `(line, t)` and the previous row's.
    decrease: Option<((usize, f64), (usize, f64))>,
    /// First step off the typical step: `(line, step, typical)`.
    irregular: Option<(usize, f64, f64)>,
}

impl TimeCheck {
    #[inline]
    fn push(&mut self, t: f64, line: usize) {
        if self.rows == 0 {
            self.t0 = t;
            self.step_min = f64::INFINITY;
            self.step_max = f64::NEG_INFINITY;
        } else {
            let step = t - self.t_prev;
            if step <= 0.0 && self.decrease.is_none() {
                self.decrease = Some(((line, t), (self.prev_line, self.t_prev)));
            }
            self.step_min = self.step_min.min(step);
            self.step_max = self.step_max.max(step);
            match self.typical {
                Some(typ) => {
                    if self.irregular.is_none() && off_step(step, typ) {
                        self.irregular = Some((line, step, typ));
                    }
                }
                None => {
                    self.first.push((step, line));
                    if self.first.len() == 3 {
                        let mut s: Vec<f64> = self.first.iter().map(|p| p.0).collect();
                        s.sort_by(f64::total_cmp);
                        let typ = s[1];
                        self.typical = Some(typ);
                        self.irregular = self
                            .first
                            .iter()
                            .find(|&&(st, _)| off_step(st, typ))
                            .map(|&(st, l)| (l, st, typ));
                    }
                }
            }
        }
        self.rows += 1;
        self.t_prev = t;
        self.prev_line = line;
    }
}
/// Reads the file once more for the first step off the mean (known to exist).
fn first_step_off_mean(file: &Path, mean: f64) -> Error {
    let located = (|| -> Result<Option<Error>> {
        let mut r = RowReader::open(file)?;
        let tcol = r.header.time_col;
        let mut prev: Option<f64> = None;
        while let Some(row) = r.next_row()? {
            let t = row[tcol];
            if let Some(p) = prev {
                if off_step(t - p, mean) {
                    let (line, name) = (r.line(), r.header.time_name().to_string());
                    return Ok(Some(irregular_step(
                        file,
                        line,
                        &name,
                        t - p,
                        mean,
                        StepRef::Mean,
                    )));
                }
            }
            prev = Some(t);
        }
        Ok(None)
    })();
    match located {
        Ok(Some(e)) | Err(e) => e,
        Ok(None) => changed_while_read(file),
    }
}

/// The file's content differs between two reads.
pub(crate) fn changed_while_read(file: &Path) -> Error {
    Error::bad_file(
        file,
        0,
        None,
        "the file changed while it was being read; run again once it is completely written",
    )
}

/// Statistics of one force column gathered in one pass, in constant memory.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnStats {
    /// Mean \[N\].
    pub mean: f64,
    /// Root mean square about the mean \[N\].
    pub rms: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Every `subsample_stride`-th sample from the first, at most [`SUBSAMPLE_CAP`]
    /// (the whole column when it is that short).
    pub subsample: Vec<f64>,
    /// Stride of [`ColumnStats::subsample`] (a power of two).
    pub subsample_stride: usize,
}

/// Running [`ColumnStats`]: Welford's mean and variance, extremes and a systematic
/// subsample whose stride doubles whenever it is full.
#[derive(Debug, Clone)]
struct ColumnAcc {
    n: usize,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
    sub: Vec<f64>,
    stride: usize,
}

impl ColumnAcc {
    fn new() -> Self {
        ColumnAcc {
            n: 0,
            mean: 0.0,
            m2: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            sub: Vec::new(),
            stride: 1,
        }
    }

    #[inline]
    fn push(&mut self, v: f64) {
        if self.n % self.stride == 0 {
            if self.sub.len() == SUBSAMPLE_CAP {
                let mut i = 0;
                self.sub.retain(|_| {
                    i += 1;
                    i % 2 == 1
                });
                self.stride *= 2;
            }
            if self.n % self.stride == 0 {
                self.sub.push(v);
            }
        }
        self.n += 1;
        let d = v - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (v - self.mean);
        self.min = self.min.min(v);
        self.max = self.max.max(v);
    }

    fn finish(self) -> ColumnStats {
        ColumnStats {
            mean: self.mean,
            rms: (self.m2 / self.n.max(1) as f64).max(0.0).sqrt(),
            min: self.min,
            max: self.max,
            subsample: self.sub,
            subsample_stride: self.stride,
        }
    }
}

/// A whole time-series file read once, in constant memory: everything a streamed
/// estimate needs before its own pass over the rows.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordScan {
    /// The file.
    pub source: PathBuf,
    /// Number of data rows (samples).
    pub rows: usize,
    /// Time of the first sample \[s\].
    pub t0: f64,
    /// Sample period \[s\]: the mean step, exactly as the in-memory reader computes it.
    pub dt: f64,
    /// Kind of the response columns (`None` when there are none).
    pub response_kind: Option<ResponseKind>,
    /// Statistics of `fx, fy, fz`, indexed by [`Axis::index`]; `None` = column absent.
    pub force: [Option<ColumnStats>; 3],
    /// Which response columns the file has, indexed by [`Axis::index`].
    pub response: [bool; 3],
    /// The first [`MAX_COMMENTS`] comment lines.
    pub comments: Vec<String>,
    /// Warnings (unknown columns ignored), without the file name.
    pub warnings: Vec<String>,
}

impl RecordScan {
    /// Axes with a response column.
    pub fn response_axes(&self) -> Vec<Axis> {
        Axis::ALL
            .into_iter()
            .filter(|a| self.response[a.index()])
            .collect()
    }
}

/// Reads and checks a whole time-series CSV row by row (module docs) and returns its
/// [`RecordScan`]. Memory does not grow with the file: a few hundred kB at most.
pub fn scan_timeseries(path: &Path) -> Result<RecordScan> {
    scan(path).map_err(|e| prefer_utf8_error(path, e))
}

fn scan(path: &Path) -> Result<RecordScan> {
    let mut r = RowReader::open(path)?;
    let cols: Vec<(usize, usize)> = Axis::ALL
        .into_iter()
        .filter_map(|a| r.force_column(a).map(|c| (a.index(), c)))
        .collect();
    let mut accs: Vec<ColumnAcc> = cols.iter().map(|_| ColumnAcc::new()).collect();
    while let Some(row) = r.next_row()? {
        for (acc, &(_, c)) in accs.iter_mut().zip(&cols) {
            acc.push(row[c]);
        }
    }
    let end = r.finish()?;
    let mut force: [Option<ColumnStats>; 3] = Default::default();
    for (acc, &(i, _)) in accs.into_iter().zip(&cols) {
        force[i] = Some(acc.finish());
    }
    let response = Axis::ALL.map(|a| r.response_column(a).is_some());
    Ok(RecordScan {
        source: path.to_path_buf(),
        rows: end.rows,
        t0: end.t0,
        dt: end.dt,
        response_kind: r.response_kind(),
        force,
        response,
        comments: r.comments,
        warnings: r.warnings,
    })
}

/// The in-memory reader decodes the whole file before parsing, so a non-UTF-8 line
/// anywhere wins over a bad cell: keep that order.
fn prefer_utf8_error(path: &Path, e: Error) -> Error {
    if !matches!(e, Error::BadFile { .. }) {
        return e;
    }
    let Ok(f) = File::open(path) else { return e };
    let mut reader = BufReader::with_capacity(1 << 16, f);
    let mut buf = Vec::new();
    let mut line = 0;
    loop {
        buf.clear();
        match reader.read_until(b'\n', &mut buf) {
            Ok(0) | Err(_) => return e,
            Ok(_) => line += 1,
        }
        if std::str::from_utf8(&buf).is_err() {
            return not_utf8(path, line);
        }
    }
}
