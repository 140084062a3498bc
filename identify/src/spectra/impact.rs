//! Impact tests: hit detection, double-hit and overload checks, force and exponential
//! windows, H1 over the hits (see the parent module's docs for the rules).

use super::ringing;
use super::*;

/// One detected hit, as a record window of the source record.
#[derive(Debug, Clone)]
struct Hit {
    record: usize,
    /// Record window [start, end) in samples of the source record.
    start: usize,
    end: usize,
    /// First sample of the pulse (force above 2 % of the hit's peak).
    pulse_start: usize,
    /// First sample after the pulse.
    pulse_end: usize,
    /// Force baseline (median of the source record).
    base: f64,
    /// Force sign (+1 or −1) so that the hit is positive.
    sign: f64,
    input: Axis,
    /// A double hit kept for want of clean ones (its pulse ends after the last pulse).
    double: bool,
}

/// Fewer clean hits than this along a force axis, and its double hits are kept.
const MIN_CLEAN_HITS: usize = 3;

/// Why a hit is not used as it is.
enum Rejected {
    /// A second pulse: `last_pulse_end` is the first sample after the last one.
    Double { why: String, last_pulse_end: usize },
    /// Overload: never used.
    Bad(String),
}

pub(super) fn estimate(
    records: &[TimeSeries],
    infos: &[RecordInfo],
    ctx: &mut Ctx,
) -> Result<FrfEstimate> {
    let io = &ctx.opts.impact;
    let mut hits: Vec<Hit> = Vec::new();
    let mut doubles: Vec<(Hit, String, String, usize)> = Vec::new();
    let mut n_detected = 0;
    // every pulse of each record (used or not): the hits a record's free decays follow
    let mut pulses: Vec<Vec<(usize, usize)>> = vec![Vec::new(); records.len()];
    for (r, (rec, info)) in records.iter().zip(infos).enumerate() {
        let found = detect(rec, r, info.strongest, io, ctx.dt);
        n_detected += found.len();
        pulses[r] = found.iter().map(|h| (h.pulse_start, h.pulse_end)).collect();
        if found.is_empty() {
            ctx.dropped
                .push(format!("{}: no hit found in the force", rec.source));
            continue;
        }
        if info.inputs.len() > 1 {
            for (k, _) in found.iter().enumerate() {
                ctx.dropped.push(format!(
                    "{} hit {}: force on several axes ({}); an oblique hit cannot be split into single-axis FRFs",
                    rec.source,
                    k + 1,
                    axes_name(&info.inputs)
                ));
            }
            continue;
        }
        for (k, mut h) in found.into_iter().enumerate() {
            match check(rec, &h, io) {
                Ok(()) => hits.push(h),
                Err(Rejected::Double {
                    why,
                    last_pulse_end,
                }) => {
                    let label = format!("{} hit {}", rec.source, k + 1);
                    h.pulse_end = last_pulse_end;
                    // where its line goes in the dropped list if it is dropped
                    doubles.push((h, label, why, ctx.dropped.len()));
                }
                Err(Rejected::Bad(why)) => {
                    ctx.dropped
                        .push(format!("{} hit {}: {why}", rec.source, k + 1))
                }
            }
        }
    }
    // Double hits: dropped, unless the clean hits along their force axis would be
    // fewer than MIN_CLEAN_HITS. A double hit is still a valid input-output pair when
    // the force window keeps both pulses (H1 = ΣXF*/Σ|F|² weights its notched lines
    // down); one average would leave no coherence to judge channels and band by.
    let mut dropped_doubles = Vec::new();
    for (h, label, why, slot) in doubles {
        let clean = hits
            .iter()
            .filter(|c| c.input == h.input && !c.double)
            .count();
        if clean < MIN_CLEAN_HITS {
            ctx.warnings.push(format!(
                "{label}: {why}; kept (only {clean} clean hit(s) along {}): its force window covers both pulses",
                h.input
            ));
            hits.push(Hit { double: true, ..h });
        } else {
            dropped_doubles.push((slot, format!("{label}: {why}")));
        }
    }
    for (slot, line) in dropped_doubles.into_iter().rev() {
        ctx.dropped.insert(slot, line);
    }
    // Records much shorter than the others (a hit followed too soon by the next).
    if !hits.is_empty() {
        let lens: Vec<f64> = hits.iter().map(|h| (h.end - h.start) as f64).collect();
        let med = median(&lens);
        let before = hits.len();
        let mut kept = Vec::with_capacity(before);
        for h in hits {
            if ((h.end - h.start) as f64) < 0.5 * med && ctx.opts.nfft.is_none() {
                ctx.dropped.push(format!(
                    "{} hit at t = {:.4} s: only {:.4} s until the next hit (others have {:.4} s)",
                    records[h.record].source,
                    records[h.record].t0 + h.pulse_start as f64 * ctx.dt,
                    (h.end - h.start) as f64 * ctx.dt,
                    med * ctx.dt
                ));
            } else {
                kept.push(h);
            }
        }
        hits = kept;
    }
    if hits.is_empty() {
        return Err(Error::BadInput(format!(
            "no usable hit: {n_detected} detected, all rejected ({}); repeat the test with single, clean hits below the sensors' range",
            ctx.dropped.join("; ")
        )));
    }
    let n = ctx
        .opts
        .nfft
        .unwrap_or_else(|| hits.iter().map(|h| h.end - h.start).min().unwrap_or(0));
    if n < 16 {
        return Err(Error::BadInput(format!(
            "hit records are only {n} samples long; leave more time between hits"
        )));
    }

    // Settling before the hit, decay at the end.
    let mut sigma_auto = 0.0f64;
    let mut unsettled: std::collections::BTreeMap<(usize, Axis), (usize, f64)> = Default::default();
    for h in &hits {
        let rec = &records[h.record];
        let end = (h.start + n).min(h.end);
        for a in rec.response_axes() {
            let y = &rec.response(a).unwrap_or(&[])[h.start..end];
            // Peak of the free vibration after the pulse (the impulsive part of an
            // acceleration during the pulse is not what has to decay).
            let after = (h.pulse_end + (h.pulse_end - h.pulse_start)).saturating_sub(h.start);
            let peak = y
                .get(after.min(y.len())..)
                .unwrap_or(&[])
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            if peak <= 0.0 {
                continue;
            }
            let pre = &y[..(h.pulse_start - h.start).min(y.len())];
            let pre_max = pre.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if pre_max > 0.05 * peak {
                let e = unsettled.entry((h.record, a)).or_insert((0, 0.0));
                e.0 += 1;
                e.1 = f64::max(e.1, 100.0 * pre_max / peak);
            }
            let tail = (y.len() / 20).max(8).min(y.len());
            let t = &y[y.len() - tail..];
            let amp = (t.iter().map(|v| v * v).sum::<f64>() / tail as f64).sqrt()
                * std::f64::consts::SQRT_2;
            // A response that has sunk into its noise floor (the pre-trigger level)
            // has decayed: no window for it, whatever its noise-to-peak ratio.
            let noise = if pre.len() >= 4 {
                (pre.iter().map(|v| v * v).sum::<f64>() / pre.len() as f64).sqrt()
                    * std::f64::consts::SQRT_2
            } else {
                0.0
            };
            if amp <= 2.0 * noise {
                continue;
            }
            let ratio = amp / peak;
            let dur = (h.start + n).saturating_sub(h.pulse_start) as f64 * ctx.dt;
            if ratio > io.end_level && dur > 0.0 {
                sigma_auto = sigma_auto.max((ratio / io.end_level).ln() / dur);
            }
        }
    }
    for ((r, a), (count, pct)) in unsettled {
        ctx.warnings.push(format!(
            "{}: response {a} is not at rest before {count} of its hits (up to {pct:.0} % of the response peak): {}",
            records[r].source,
            if io.separation.is_none() {
                "leave more time between hits, or the channel is mostly noise"
            } else {
                "each hit's response is separated from the earlier hits' free decays; more time between hits still makes a cleaner test"
            }
        ));
    }
    let sigma = io.exp_window_sigma.unwrap_or(sigma_auto).max(0.0);

    let mut dft = RealDft::new(n);
    let nl = n_lines(n);
    let mut accs = Vec::new();
    let mut fwin = vec![0.0; n];
    let mut ewin = vec![0.0; n];
    for input in Axis::ALL {
        let group: Vec<&Hit> = hits.iter().filter(|h| h.input == input).collect();
        if group.is_empty() {
            continue;
        }
        let outputs: Vec<Axis> = Axis::ALL
            .into_iter()
            .filter(|a| group.iter().all(|h| infos[h.record].outputs.contains(a)))
            .collect();
        let mut acc = Accumulator::new(vec![input], outputs.clone(), nl);
        let mut sp = Spectra::new(1, outputs.len());
        for h in group {
            let rec = &records[h.record];
            let conv = to_displacement(rec.response_kind, n, ctx.dt, sigma);
            force_window(&mut fwin, h);
            let t_hit = h.pulse_start - h.start;
            for (i, e) in ewin.iter_mut().enumerate() {
                *e = (-sigma * (i as f64 - t_hit as f64) * ctx.dt).exp();
            }
            let avail = (rec.len() - h.start).min(n).min(h.end - h.start);
            let f = &rec.force(input).unwrap_or(&[])[h.start..h.start + avail];
            for (i, b) in dft.buf.iter_mut().enumerate() {
                *b = if i < avail {
                    (f[i] - h.base) * fwin[i] * ewin[i]
                } else {
                    0.0
                };
            }
            dft.run_into(&mut sp.fs[0], None)?;
            for (o, &a) in outputs.iter().enumerate() {
                let y = rec.response(a).unwrap_or(&[]);
                match &io.separation {
                    None => {
                        let y = &y[h.start..h.start + avail];
                        for (i, b) in dft.buf.iter_mut().enumerate() {
                            *b = if i < avail { y[i] * ewin[i] } else { 0.0 };
                        }
                    }
                    Some(sep) => {
                        let z = separated(y, h, &pulses[h.record], sep, ctx.dt, n);
                        fold(&z, &mut dft.buf, sigma, t_hit, ctx.dt);
                    }
                }
                dft.run_into(&mut sp.ys[o], conv.as_deref())?;
            }
            acc.add(std::slice::from_ref(&sp));
        }
        accs.push(acc);
    }
    let df = 1.0 / (n as f64 * ctx.dt);
    let used: usize = accs.iter().map(|a| a.averages).sum();
    let method = format!(
        "{:?}, impact: {} averaged, record {n} samples, force window{}{}, df {df:.4} Hz",
        ctx.opts.estimator,
        crate::axis::count(used, "hit"),
        match &io.separation {
            None => String::new(),
            Some(sep) => format!(
                ", each hit's response separated from the others' (free decays over {} of a first fit)",
                crate::axis::count(sep.poles.len(), "pole")
            ),
        },
        if sigma > 0.0 {
            format!(" + exponential window sigma {sigma:.3} 1/s (estimate = H(s + sigma))")
        } else {
            String::new()
        }
    );
    let mut est = assemble(accs, n, ctx, method, (sigma > 0.0).then_some(sigma))?;
    est.hit_record_s = Some(n as f64 * ctx.dt);
    Ok(est)
}

/// Samples after a pulse's end before its response is a free decay (the pulse's own
/// transient, an anti-alias filter's ringing), at least this many.
const DECAY_GUARD: usize = 16;
/// A continued decay is followed until every pole is down to this fraction.
const TAIL_LEVEL: f64 = 1e-4;
/// ... but over at most this many record lengths.
const TAIL_RECORDS: usize = 32;

/// Hit `h`'s response alone, from its record start: its record (n samples) minus the
/// free decay of the hits before it (fitted between the previous pulse and this hit's
/// pre-trigger), then continued past the record's end by its own free decay (fitted
/// after its pulse). Longer than `n` where the decay lasts: [`fold`] wraps it.
fn separated(
    y: &[f64],
    h: &Hit,
    pulses: &[(usize, usize)],
    sep: &HitSeparation,
    dt: f64,
    n: usize,
) -> Vec<f64> {
    let (poles, keep) = (&sep.poles, &sep.continued);
    let width = (h.pulse_end - h.pulse_start).max(1);
    let guard = (3 * width).max(DECAY_GUARD);
    let pre = h.pulse_start - h.start;
    // the record as the plain estimate takes it (n samples at most: data after that,
    // wrapped, would also carry what the force window cut, e.g. a small rebound)
    let data = (y.len() - h.start).min(h.end - h.start).min(n);
    let mut z = y[h.start..h.start + data].to_vec();
    // the earlier hits' decay: fitted from the last pulse before this hit to a
    // pre-trigger's length before the record (an anti-alias filter's pre-ringing of
    // this hit stays out)
    if let Some(&(_, prev_end)) = pulses.iter().rev().find(|p| p.1 <= h.pulse_start) {
        let lo = prev_end + guard;
        let hi = h.start.saturating_sub(pre);
        if let Some(fd) = ringing::FreeDecay::fit(y, lo, hi, poles, keep, dt) {
            fd.add_to(h.start, &mut z, -1.0);
        }
    }
    // this hit's own decay past its record's end
    let after = h.pulse_end - h.start + guard;
    let ringing_poles: Vec<Complex64> = poles
        .iter()
        .zip(keep)
        .filter(|(_, &k)| k)
        .map(|(p, _)| *p)
        .collect();
    let tail = ringing::decay_samples(&ringing_poles, dt, TAIL_LEVEL, TAIL_RECORDS * n);
    if tail > 0 && after < data {
        if let Some(fd) = ringing::FreeDecay::fit(&z, after, data, poles, keep, dt) {
            let mut ext = vec![0.0; tail];
            fd.add_to(data, &mut ext, 1.0);
            z.extend_from_slice(&ext);
        }
    }
    z
}

/// Wraps `z` (from the record start) onto `buf` (length n) under the exponential window
/// `e^{-σ (t - t_hit)}`: the DFT of the wrapped record is the transform of the whole
/// decay at the DFT's lines.
fn fold(z: &[f64], buf: &mut [f64], sigma: f64, t_hit: usize, dt: f64) {
    let n = buf.len();
    buf.iter_mut().for_each(|b| *b = 0.0);
    for (i, v) in z.iter().enumerate() {
        buf[i % n] += v * (-sigma * (i as f64 - t_hit as f64) * dt).exp();
    }
}

/// Finds the hits of one record.
fn detect(rec: &TimeSeries, r: usize, axis: Axis, io: &ImpactOptions, dt: f64) -> Vec<Hit> {
    let f = rec.force(axis).unwrap_or(&[]);
    let n = f.len();
    let base = median(f);
    let (imax, _) = f.iter().enumerate().fold((0, 0.0f64), |(bi, bv), (i, v)| {
        if (v - base).abs() > bv {
            (i, (v - base).abs())
        } else {
            (bi, bv)
        }
    });
    let sign = if f.get(imax).copied().unwrap_or(0.0) >= base {
        1.0
    } else {
        -1.0
    };
    let g = |i: usize| sign * (f[i] - base);
    let peak = if n > 0 { g(imax) } else { 0.0 };
    if peak <= 0.0 {
        return Vec::new();
    }
    let thr = io.trigger_fraction * peak;
    let spacing = ((io.min_spacing_s / dt).round() as usize).max(1);
    let pre = ((io.pretrigger_s / dt).round() as usize).max(4);
    let mut crossings: Vec<usize> = Vec::new();
    for i in 0..n {
        if g(i) >= thr && (i == 0 || g(i - 1) < thr) {
            match crossings.last() {
                Some(&last) if i - last < spacing => {}
                _ => crossings.push(i),
            }
        }
    }
    let mut hits = Vec::with_capacity(crossings.len());
    for (k, &c) in crossings.iter().enumerate() {
        let start = c.saturating_sub(pre);
        let end = crossings.get(k + 1).map_or(n, |&nx| nx.saturating_sub(pre));
        // Peak of this pulse: within the region above the threshold.
        let mut p = c;
        let mut i = c;
        while i < end && g(i) >= thr {
            if g(i) > g(p) {
                p = i;
            }
            i += 1;
        }
        let low = 0.02 * g(p);
        let mut ps = p;
        while ps > start && g(ps - 1) >= low {
            ps -= 1;
        }
        let mut pe = p;
        while pe < end && g(pe) >= low {
            pe += 1;
        }
        hits.push(Hit {
            record: r,
            start,
            end,
            pulse_start: ps,
            pulse_end: pe,
            base,
            sign,
            input: axis,
            double: false,
        });
    }
    hits
}

/// Overload and double hit checks; `Err` says why the hit is not used as it is.
fn check(rec: &TimeSeries, h: &Hit, io: &ImpactOptions) -> std::result::Result<(), Rejected> {
    let f = rec.force(h.input).unwrap_or(&[]);
    let g = |i: usize| h.sign * (f[i] - h.base);
    let (p, peak) = (h.pulse_start..h.pulse_end.max(h.pulse_start + 1).min(h.end))
        .map(|i| (i, g(i)))
        .fold(
            (h.pulse_start, f64::MIN),
            |a, b| if b.1 > a.1 { b } else { a },
        );
    if flat_top(&f[h.start..h.end]) {
        return Err(Rejected::Bad(format!(
            "force {} overloaded: flat top at {:.4e} (clipped); hit softer or raise the force sensor range",
            h.input,
            f[p]
        )));
    }
    for a in rec.response_axes() {
        let y = &rec.response(a).unwrap_or(&[])[h.start..h.end];
        if flat_top(y) {
            return Err(Rejected::Bad(format!(
                "response {a} overloaded (clipped at its extreme value); hit softer or raise the sensor range"
            )));
        }
    }
    if let Some(i) = (h.pulse_end..h.end).find(|&i| g(i) > io.double_hit_fraction * peak) {
        let second = (i..h.end)
            .take_while(|&j| g(j) > 0.02 * peak)
            .map(g)
            .fold(0.0, f64::max);
        // the last pulse: the last sample above the double-hit level, then down to 2 %
        let last = (h.pulse_end..h.end)
            .rev()
            .find(|&j| g(j) > io.double_hit_fraction * peak)
            .unwrap_or(i);
        let last_pulse_end = (last..h.end)
            .find(|&j| g(j) <= 0.02 * peak)
            .unwrap_or(h.end);
        return Err(Rejected::Double {
            why: format!(
                "double hit: a second pulse of {:.0} % of the hit's force {:.4} s after it; hit once and let the hammer rebound away",
                100.0 * second / peak,
                (i - p) as f64 * rec.dt
            ),
            last_pulse_end,
        });
    }
    Ok(())
}

/// True when the extreme value of `x` (by magnitude) is held for three or more
/// consecutive samples: a clipped (overloaded) channel.
pub(super) fn flat_top(x: &[f64]) -> bool {
    let Some((imax, &vmax)) = x
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    else {
        return false;
    };
    if vmax == 0.0 {
        return false;
    }
    let tol = 1e-9 * vmax.abs();
    let same = |i: usize| (x[i] - vmax).abs() <= tol;
    let mut lo = imax;
    while lo > 0 && same(lo - 1) {
        lo -= 1;
    }
    let mut hi = imax;
    while hi + 1 < x.len() && same(hi + 1) {
        hi += 1;
    }
    hi - lo + 1 >= 3
}

/// Force window: 1 up to one pulse width after the pulse, cosine taper over one
/// pulse width, 0 after (indices relative to the hit record).
fn force_window(w: &mut [f64], h: &Hit) {
    let width = (h.pulse_end - h.pulse_start).max(2);
    let flat_end = h.pulse_end - h.start + width;
    for (i, v) in w.iter_mut().enumerate() {
        *v = if i < flat_end {
            1.0
        } else if i < flat_end + width {
            0.5 + 0.5 * (PI * (i - flat_end) as f64 / width as f64).cos()
        } else {
            0.0
        };
    }
}
