//! The Welch estimate of one long record streamed from its file: memory stays
//! `O(nfft × channels)` however long the record is.
//!
//! Two passes over the file: [`scan_timeseries`](crate::read::scan_timeseries) checks
//! it and counts the rows (the automatic `nfft` and the sample period depend on the whole
//! record), then [`estimate_frf_streamed`] reads the rows again into one ring of `nfft`
//! samples per channel and hands every full segment to the same Welch core as
//! [`estimate_frf`](super::estimate_frf). The result equals the in-memory estimate of the
//! same file bit for bit (same segments, same order of accumulation).
//!
//! Only continuous excitation streams. Whether a record under [`Excitation::Auto`] is an
//! impact test is judged on a systematic subsample of its strongest force
//! ([`ColumnStats::subsample`](crate::read::ColumnStats::subsample), the whole column
//! up to 65 536 samples) against the exact extremes; records that short are judged
//! exactly as in memory. Whether it is a sweep is judged as in memory, from one more pass
//! that keeps the middle window of each part the test looks at.

use super::{
    check_averages, check_options, check_responses, groups, impulsive, is_sweep_windows, n_lines,
    on_worker, resolve_excitation, to_displacement, too_short_for_segment, welch_estimate,
    welch_length, welch_segments, Accumulator, Ctx, Excitation, FrfEstimate, FrfOptions,
    RecordInfo, Welch, SWEEP_SEGMENTS, SWEEP_WINDOW,
};
use crate::error::{Error, Result};
use crate::read::{RecordScan, RowReader};

impl RecordInfo {
    fn from_scan(scan: &RecordScan) -> Result<Self> {
        let rms = scan
            .force
            .each_ref()
            .map(|c| c.as_ref().map_or(0.0, |c| c.rms));
        Self::from_stats(&source(scan), rms, scan.response_axes(), |a| {
            scan.force[a.index()]
                .as_ref()
                .is_some_and(|c| impulsive(&mut c.subsample.clone(), (c.min, c.max)))
        })
    }
}

fn source(scan: &RecordScan) -> String {
    scan.source.display().to_string()
}

/// The excitation [`estimate_frf`](super::estimate_frf) would use for this record:
/// `opts.excitation`, or for [`Excitation::Auto`] impact or continuous (module docs).
/// Only [`Excitation::Continuous`] can be streamed.
pub fn excitation_of_scan(scan: &RecordScan, opts: &FrfOptions) -> Result<Excitation> {
    check_responses(&source(scan), scan.response_kind, &scan.response_axes())?;
    let mut info = RecordInfo::from_scan(scan)?;
    if opts.excitation == Excitation::Auto && !info.impulsive {
        info.sweep = swept(scan, info.strongest)?;
    }
    resolve_excitation(opts.excitation, &[info])
}

/// Whether the strongest force of a scanned record is a sweep, judged as in memory
/// ([`super::is_sweep`]: the same parts, the same middle windows, each part's mean and
/// RMS) from one more pass over the file that keeps only those windows. Without it a
/// long logarithmic sweep was taken for continuous excitation and Welch-averaged, where
/// `identify` (in memory) recognised it: tryout sweep, 10.6 MB, xx 99.41 % vs the truth
/// from the Welch FRF CSV, 99.95 % from the record.
fn swept(scan: &RecordScan, along: crate::axis::Axis) -> Result<bool> {
    let rows = scan.rows;
    let part = (rows / SWEEP_SEGMENTS) & !1;
    if rows / SWEEP_SEGMENTS < 64 {
        return Ok(false);
    }
    let n = part.min(SWEEP_WINDOW);
    let off = (part - n) / 2;
    let mut reader = RowReader::open(&scan.source)?;
    let col = reader
        .force_column(along)
        .ok_or_else(|| crate::read::changed_while_read(&scan.source))?;
    let mut windows: Vec<Vec<f64>> = (0..SWEEP_SEGMENTS).map(|_| Vec::with_capacity(n)).collect();
    // per part: its first sample (the shift), Σ(v - c), Σ(v - c)²
    let mut sums = vec![(0.0f64, 0.0f64, 0.0f64); SWEEP_SEGMENTS];
    let mut i = 0usize;
    while let Some(row) = reader.next_row()? {
        let v = row[col];
        let s = i / part;
        if s < SWEEP_SEGMENTS {
            let k = i - s * part;
            if k == 0 {
                sums[s].0 = v;
            }
            let d = v - sums[s].0;
            sums[s].1 += d;
            sums[s].2 += d * d;
            if k >= off && k < off + n {
                windows[s].push(v);
            }
        }
        i += 1;
    }
    let end = reader.finish()?;
    if end.rows != rows {
        return Err(crate::read::changed_while_read(&scan.source));
    }
    let len = part as f64;
    let means: Vec<f64> = sums.iter().map(|&(c, s1, _)| c + s1 / len).collect();
    let rms: Vec<f64> = (sums.iter())
        .map(|&(_, s1, s2)| ((s2 - s1 * s1 / len) / len).max(0.0).sqrt())
        .collect();
    let parts: Vec<&[f64]> = windows.iter().map(Vec::as_slice).collect();
    Ok(is_sweep_windows(&parts, &means, &rms))
}

/// Welch FRF estimate of the record `scan` describes, read again row by row (module
/// docs). Fails with [`Error::BadInput`] unless the excitation is continuous (see
/// [`excitation_of_scan`]), and with [`Error::BadFile`] when the file no longer matches
/// its scan.
pub fn estimate_frf_streamed(scan: &RecordScan, opts: &FrfOptions) -> Result<FrfEstimate> {
    on_worker(|| streamed(scan, opts))
}

fn streamed(scan: &RecordScan, opts: &FrfOptions) -> Result<FrfEstimate> {
    check_options(opts)?;
    let excitation = excitation_of_scan(scan, opts)?;
    if excitation != Excitation::Continuous {
        return Err(Error::BadInput(format!(
            "{}: {excitation:?} excitation is not estimated streamed (only continuous excitation is); read the record into memory",
            source(scan)
        )));
    }
    let info = RecordInfo::from_scan(scan)?;
    let mut ctx = Ctx::new(scan.dt, opts);
    let n = welch_length(&[scan.rows], opts)?;
    // one segment at a time: memory stays that of one segment per channel
    let mut welch = Welch::new(n);
    let mut accs = Vec::new();
    for (inputs, outputs, _) in groups(std::slice::from_ref(&info), &mut ctx.warnings) {
        let mut acc = Accumulator::new(inputs.clone(), outputs.clone(), n_lines(n));
        let (hop, count) = welch_segments(scan.rows, n, opts.overlap);
        if count == 0 {
            ctx.dropped
                .push(too_short_for_segment(&source(scan), scan.rows, n));
        } else {
            let conv = to_displacement(scan.response_kind, n, scan.dt, 0.0);
            let mut reader = RowReader::open(&scan.source)?;
            let columns: Vec<usize> = inputs
                .iter()
                .map(|&a| reader.force_column(a))
                .chain(outputs.iter().map(|&a| reader.response_column(a)))
                .collect::<Option<_>>()
                .ok_or_else(|| crate::read::changed_while_read(&scan.source))?;
            let ni = inputs.len();
            // One ring per channel: the last `n` samples, `hop` dropped after each segment.
            let mut rings: Vec<Vec<f64>> = columns.iter().map(|_| Vec::with_capacity(n)).collect();
            let mut done = 0;
            while let Some(row) = reader.next_row()? {
                for (ring, &c) in rings.iter_mut().zip(&columns) {
                    ring.push(row[c]);
                }
                if rings[0].len() == n {
                    if done < count {
                        let segment = rings.iter().map(Vec::as_slice).collect();
                        if !welch.add_segments(&mut acc, conv.as_deref(), ni, &[segment])? {
                            // the reader lets no NaN/Inf through
                            return Err(crate::read::changed_while_read(&scan.source));
                        }
                        done += 1;
                    }
                    for ring in &mut rings {
                        ring.drain(..hop);
                    }
                }
            }
            let end = reader.finish()?;
            if end.rows != scan.rows || end.dt != scan.dt || done != count {
                return Err(crate::read::changed_while_read(&scan.source));
            }
        }
        check_averages(&acc, n, &mut ctx)?;
        accs.push(acc);
    }
    welch_estimate(accs, n, &mut ctx)
}
