//! The evidence every cause is judged on: the records split into a building and a held-out
//! part, impact hits and force levels, the FRF points with their standard errors (the
//! twin's own uncertainty added), the held-out time fit, and the response power the
//! measured forces do not explain.

use crate::axis::{Axis, Channel};
use crate::error::{Error, Result};
use crate::extended::simulate_as_measured;
use crate::frf::fit_percent_real;
use crate::modal_update::Points;
use crate::operating::{operating_spectra, OperatingSpectra};
use crate::signal::slice;
use crate::simulate::force_rows;
use crate::timeseries::{ResponseKind, TimeSeries};
use crate::twin::Twin;
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// A record cut in two: building part and held-out part.
#[derive(Debug, Clone)]
pub struct Split {
    /// The whole record.
    pub full: TimeSeries,
    /// First held-out sample.
    pub holdout_start: usize,
}

pub(super) fn force_mag(ts: &TimeSeries) -> Vec<f64> {
    force_rows(ts)
        .iter()
        .map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
        .collect()
}

/// True when the force is a train of short pulses (impact test).
pub fn is_impact(ts: &TimeSeries) -> bool {
    let f = force_mag(ts);
    let n = f.len().max(1) as f64;
    let rms = (f.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    let peak = f.iter().copied().fold(0.0, f64::max);
    rms > 0.0 && peak / rms > 8.0
}

/// Start indices of hits (force above 20 % of the peak after a quiet gap).
fn hit_starts(ts: &TimeSeries) -> Vec<usize> {
    let f = force_mag(ts);
    let peak = f.iter().copied().fold(0.0, f64::max);
    // hits at every force level of a record (a test at three levels has light hits
    // below a tenth of the hard ones): 5 % of the largest peak, and well above the
    // force's noise (its median magnitude)
    let mut sorted = f.clone();
    sorted.sort_by(f64::total_cmp);
    let noise = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let threshold = (0.05 * peak).max(20.0 * noise);
    let gap = (0.05 / ts.dt) as usize; // 50 ms
    let mut hits = Vec::new();
    let mut last: Option<usize> = None;
    for (i, v) in f.iter().enumerate() {
        if *v > threshold && last.is_none_or(|l| i > l + gap) {
            hits.push(i);
        }
        if *v > threshold {
            last = Some(i);
        }
    }
    hits
}

/// Splits a record: impact records between hits (the last ~30 % of the hits held out),
/// continuous records at `1 - fraction` of their length.
pub fn split(ts: &TimeSeries, fraction: f64) -> Split {
    let n = ts.len();
    let mut at = ((1.0 - fraction) * n as f64) as usize;
    if is_impact(ts) {
        let hits = hit_starts(ts);
        if hits.len() >= 2 {
            let mut keep = ((hits.len() as f64) * (1.0 - fraction)).round().max(1.0) as usize;
            // hits at several force levels (a nonlinearity test: light, then hard): the
            // building part must hold every level, so only the last hit is held out
            let f = force_mag(ts);
            let peaks: Vec<f64> = hits
                .iter()
                .enumerate()
                .map(|(h, &a)| {
                    let b = hits.get(h + 1).copied().unwrap_or(f.len());
                    f[a..b].iter().fold(0.0f64, |m, v| m.max(*v))
                })
                .collect();
            let (lo, hi) = peaks
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(*p), b.max(*p)));
            if hits.len() >= 4 && lo > 0.0 && hi >= 2.0 * lo {
                keep = hits.len() - 1;
            }
            let keep = keep.min(hits.len() - 1);
            at = hits[keep].saturating_sub((0.002 / ts.dt) as usize);
        }
    }
    Split {
        full: ts.clone(),
        holdout_start: at.clamp(1, n.saturating_sub(1)),
    }
}

/// FRF evidence from data: per channel the H1 points, coherence and standard errors.
#[derive(Debug, Clone)]
pub struct Evidence {
    /// Frequency lines \[Hz\].
    pub freqs_hz: Vec<f64>,
    /// Per channel: H1, coherence.
    pub channels: Vec<(Channel, Vec<Complex64>, Vec<f64>)>,
    /// Per channel (as `channels`): the standard error of each H point when the
    /// estimate provides it (multi-input Welch); empty = from coherence.
    pub sigma: Vec<Vec<f64>>,
    /// Averages behind each estimate.
    pub n_avg: usize,
    /// `impact` or `continuous`.
    pub kind: String,
    /// Noise share of the response power (1 − power-weighted coherence).
    pub noise_share: f64,
}

/// Per-hit H1 of impact records (rectangular window per hit, zero-padded to the longest
/// hit), grouped by the axis each hit excites.
fn impact_evidence(parts: &[TimeSeries]) -> Result<Evidence> {
    impact_evidence_with(parts, None)
}

/// Share of each hit segment, at its end, that [`noise_psd`] takes as the sensor's
/// noise: by then the structure's response to the hit has decayed (a mode of 1 %
/// damping at 100 Hz has lost 98 % of its amplitude after 0.6 s; the less damped
/// ring on, and their rest counts as noise: conservative).
const NOISE_TAIL: f64 = 0.3;

/// Per response axis, the noise power per sample at each line of an `nfft`-point
/// transform: the mean of `|FFT(tail)|² / len(tail)` over the last [`NOISE_TAIL`] of
/// every hit segment of `units` (mean removed), smoothed over ±3 lines. A property of
/// the sensor and the acquisition, the same at every force level.
/// Per response axis and (second) per force axis.
type NoisePsd = (Vec<(Axis, Vec<f64>)>, Vec<(Axis, Vec<f64>)>);

fn noise_psd(units: &[TimeSeries], nfft: usize) -> NoisePsd {
    (
        tail_psd(units, nfft, |s, ax| s.response(ax)),
        tail_psd(units, nfft, |s, ax| s.force(ax)),
    )
}

/// The DFT on `nfft` lines (zero-padded) of `x` less `mean`, times `window` (as long as
/// `x`), by the forward plan `fft` of that length.
pub(super) fn windowed_fft(
    x: &[f64],
    mean: f64,
    window: &[f64],
    fft: &dyn rustfft::Fft<f64>,
    nfft: usize,
) -> Vec<Complex64> {
    let mut b: Vec<Complex64> = x
        .iter()
        .zip(window)
        .map(|(v, w)| Complex64::new((v - mean) * w, 0.0))
        .collect();
    b.resize(nfft, Complex64::new(0.0, 0.0));
    fft.process(&mut b);
    b
}

fn tail_psd(
    units: &[TimeSeries],
    nfft: usize,
    signal: impl Fn(&TimeSeries, Axis) -> Option<&[f64]>,
) -> Vec<(Axis, Vec<f64>)> {
    let fft = FftPlanner::<f64>::new().plan_fft_forward(nfft);
    let nl = nfft / 2;
    let segs: Vec<TimeSeries> = units.iter().flat_map(hit_segments).collect();
    let mut out = Vec::new();
    for ax in Axis::ALL {
        let mut acc = vec![0.0; nl];
        let mut n = 0usize;
        for s in &segs {
            let Some(y) = signal(s, ax) else { continue };
            let len = ((y.len() as f64 * NOISE_TAIL) as usize).min(nfft);
            if len < 16 {
                continue;
            }
            let tail = &y[y.len() - len..];
            let mean = tail.iter().sum::<f64>() / len as f64;
            // Hann window: the strong low-frequency (1/f) noise must not leak into the
            // lines above through a rectangular window's side lobes
            let w = crate::spectra::hann(len);
            let w2: f64 = w.iter().map(|v| v * v).sum();
            let b = windowed_fft(tail, mean, &w, &*fft, nfft);
            for l in 1..nl {
                acc[l] += b[l].norm_sqr() / w2;
            }
            n += 1;
        }
        if n == 0 {
            continue;
        }
        let smooth: Vec<f64> = (0..nl)
            .map(|l| {
                let (a, b) = (l.saturating_sub(3).max(1), (l + 3).min(nl - 1));
                if b < a {
                    return 0.0;
                }
                acc[a..=b].iter().sum::<f64>() / ((b - a + 1) * n) as f64
            })
            .collect();
        out.push((ax, smooth));
    }
    out
}

/// [`impact_evidence`]; with `noise_from`, each point's standard error from the sensor's
/// noise measured in the quiet ends of those records' hits ([`noise_psd`]):
/// `σ² = S_N Σ|F_i|² N_i / (Σ|F_i|²)²` over the hits `i` (length `N_i`) of the estimate.
/// Unlike the coherence of a few hits (2 hits: any noise looks half coherent; 1 hit: no
/// coherence at all) it holds for any number of hits, so FRFs of a few hits at one force
/// level can be compared with another level's.
fn impact_evidence_with(
    parts: &[TimeSeries],
    noise_from: Option<&[TimeSeries]>,
) -> Result<Evidence> {
    let mut segs: Vec<(Axis, TimeSeries)> = Vec::new();
    for ts in parts {
        for seg in hit_segments(ts) {
            let axis = Axis::ALL
                .into_iter()
                .filter(|x| seg.force(*x).is_some())
                .max_by(|x, y| {
                    let e = |ax: &Axis| {
                        seg.force(*ax)
                            .map_or(0.0, |f| f.iter().map(|v| v * v).sum())
                    };
                    e(x).total_cmp(&e(y))
                })
                .ok_or_else(|| Error::BadInput("impact record without force".into()))?;
            segs.push((axis, seg));
        }
    }
    if segs.is_empty() {
        return Err(Error::BadInput(
            "no impact hits found in the building part".into(),
        ));
    }
    let dt = segs[0].1.dt;
    let nfft = segs.iter().map(|(_, s)| s.len()).max().unwrap_or(16);
    let fft = FftPlanner::<f64>::new().plan_fft_forward(nfft);
    let nl = nfft / 2;
    let accel = segs[0].1.response_kind == Some(ResponseKind::Acceleration);
    let df = 1.0 / (nfft as f64 * dt);
    let freqs: Vec<f64> = (1..nl).map(|l| l as f64 * df).collect();
    let mut channels = Vec::new();
    let mut sigmas: Vec<Vec<f64>> = Vec::new();
    let noise = noise_from.map(|u| noise_psd(u, nfft));
    let mut n_avg = usize::MAX;
    let mut pw = 0.0;
    let mut pw_noise = 0.0;
    for inp in Axis::ALL {
        let group: Vec<&TimeSeries> = segs
            .iter()
            .filter(|(a, _)| *a == inp)
            .map(|(_, s)| s)
            .collect();
        if group.is_empty() {
            continue;
        }
        n_avg = n_avg.min(group.len());
        for out in Axis::ALL {
            if group.iter().any(|s| s.response(out).is_none()) {
                continue;
            }
            let mut gff = vec![0.0; nl];
            let mut gyy = vec![0.0; nl];
            let mut gfy = vec![Complex64::new(0.0, 0.0); nl];
            let mut gffn = vec![0.0; nl];
            for s in &group {
                let spec = |x: &[f64]| {
                    let mut b: Vec<Complex64> = x.iter().map(|v| Complex64::new(*v, 0.0)).collect();
                    b.resize(nfft, Complex64::new(0.0, 0.0));
                    fft.process(&mut b);
                    b
                };
                let f = spec(s.force(inp).unwrap_or(&[]));
                let y = spec(s.response(out).unwrap_or(&[]));
                for l in 1..nl {
                    gff[l] += f[l].norm_sqr();
                    gffn[l] += f[l].norm_sqr() * s.len() as f64;
                    gyy[l] += y[l].norm_sqr();
                    gfy[l] += f[l].conj() * y[l];
                }
            }
            let mut h = Vec::with_capacity(nl - 1);
            let mut coh = Vec::with_capacity(nl - 1);
            for l in 1..nl {
                let w2 = (2.0 * PI * l as f64 * df).powi(2);
                let conv = if accel { -1.0 / w2 } else { 1.0 };
                h.push(gfy[l] / gff[l].max(1e-300) * conv);
                let g = if group.len() >= 2 {
                    (gfy[l].norm_sqr() / (gff[l] * gyy[l]).max(1e-300)).clamp(0.0, 1.0)
                } else {
                    0.99
                };
                coh.push(g);
                pw += gyy[l];
                pw_noise += (1.0 - g) * gyy[l];
            }
            // the response's noise, and the force's (a light hit's force spectrum at high
            // frequencies is not far above the force sensor's noise: H1 scatters by |H|
            // times their ratio)
            let of = |v: &Vec<(Axis, Vec<f64>)>, x: Axis| {
                v.iter().find(|(a, _)| *a == x).map(|(_, p)| p.clone())
            };
            let psd = noise
                .as_ref()
                .and_then(|(r, f)| Some((of(r, out)?, of(f, inp)?)));
            sigmas.push(psd.map_or_else(Vec::new, |(py, pf)| {
                (1..nl)
                    .map(|l| {
                        let w2 = (2.0 * PI * l as f64 * df).powi(2);
                        let conv = if accel { 1.0 / w2 } else { 1.0 };
                        let h_raw = gfy[l].norm() / gff[l].max(1e-300);
                        let s = py[l] + h_raw * h_raw * pf[l];
                        (s * gffn[l]).sqrt() / gff[l].max(1e-300) * conv
                    })
                    .collect()
            }));
            channels.push((Channel::new(out, inp), h, coh));
        }
    }
    Ok(Evidence {
        freqs_hz: freqs,
        sigma: sigmas,
        channels,
        n_avg: n_avg.max(1),
        kind: "impact".into(),
        noise_share: if pw > 0.0 { pw_noise / pw } else { 0.0 },
    })
}

/// Lines of a Welch estimate dominated by a periodic force component (in milling the
/// tooth-passing and spindle harmonics) or by its window leakage: the force PSD (summed
/// over the inputs) above 1.25 × its median over ±16 lines. There the H1 estimate is the
/// FRF at the harmonic's exact frequency, not at the line's: up to half a line off in
/// frequency, with a coherence near 1 — a precise-looking but biased point near a
/// resonance. The broadband share of the force gives the evidence between them.
fn periodic_lines(sp: &OperatingSpectra) -> Vec<bool> {
    let n = sp.freqs_hz.len();
    let p: Vec<f64> = (0..n)
        .map(|l| sp.psd_in.iter().map(|(_, v)| v[l]).sum())
        .collect();
    let half = 16usize;
    (0..n)
        .map(|l| {
            let mut w: Vec<f64> = p[l.saturating_sub(half)..(l + half + 1).min(n)].to_vec();
            w.sort_by(f64::total_cmp);
            p[l] > 1.25 * w[w.len() / 2]
        })
        .collect()
}

fn continuous_evidence(parts: &[TimeSeries]) -> Result<Evidence> {
    let fs = parts.first().map_or(1.0, TimeSeries::fs);
    let mut nfft = (fs / 2.0).round() as usize; // ≈ 2 Hz lines
    nfft = nfft.next_power_of_two();
    // at least 12 half-overlapping segments over all records (the estimate pools them):
    // fine lines keep a low mode's resonance several lines wide
    let segments = |nfft: usize| -> usize {
        parts
            .iter()
            .map(|p| (p.len() + nfft / 2).saturating_sub(nfft) / (nfft / 2))
            .sum()
    };
    while nfft > 256 && segments(nfft) < 12 {
        nfft /= 2;
    }
    let sp: OperatingSpectra = operating_spectra(parts, nfft.max(64))?;
    let mut pw = 0.0;
    let mut pwn = 0.0;
    for ((_, g), (_, p)) in sp.coherence.iter().zip(&sp.psd_out) {
        for (gi, pi) in g.iter().zip(p) {
            pw += pi;
            pwn += (1.0 - gi) * pi;
        }
    }
    let periodic = periodic_lines(&sp);
    let channels =
        sp.h.iter()
            .map(|(c, h)| {
                let o = sp.outputs.iter().position(|a| *a == c.output).unwrap_or(0);
                let mut g = sp.coherence[o].1.clone();
                // not evidence (see periodic_lines): coherence 0 keeps them out of `points`
                g.iter_mut()
                    .zip(&periodic)
                    .filter(|(_, p)| **p)
                    .for_each(|(g, _)| *g = 0.0);
                (*c, h.clone(), g)
            })
            .collect();
    Ok(Evidence {
        freqs_hz: sp.freqs_hz.clone(),
        sigma: sp.sigma.iter().map(|(_, s)| s.clone()).collect(),
        channels,
        n_avg: sp.n_avg,
        kind: "continuous".into(),
        noise_share: if pw > 0.0 { pwn / pw } else { 0.0 },
    })
}

/// Impact evidence of `units` (hits at one force level) with standard errors from the
/// sensor noise in the quiet ends of all the hits `noise_from` ([`impact_evidence_with`]).
pub(super) fn level_evidence(units: &[TimeSeries], noise_from: &[TimeSeries]) -> Result<Evidence> {
    impact_evidence_with(units, Some(noise_from))
}

/// FRF evidence of the building parts of the records.
pub fn evidence(parts: &[TimeSeries]) -> Result<Evidence> {
    if parts.iter().all(is_impact) {
        impact_evidence(parts)
    } else {
        continuous_evidence(parts)
    }
}

/// FRF points of the evidence inside `band` with coherence ≥ `min_coh`.
pub fn points(ev: &Evidence, band: (f64, f64), min_coh: f64) -> Vec<Points> {
    ev.channels
        .iter()
        .zip(&ev.sigma)
        .map(|((c, h, g), sig)| {
            let mut p = Points {
                channel: *c,
                freqs_hz: vec![],
                h: vec![],
                sigma: vec![],
            };
            // the channel's peak: for continuous data over the lines that are evidence
            // (below the band, an accelerometer's noise divided by ω² dwarfs every
            // resonance and the floor would swamp the Welch errors). Impact evidence keeps
            // the peak over all lines: its thresholds and the nonlinearity retunes were
            // tuned with that floor (with the in-band peak, 18 → 20/20 new modes but
            // 17 → 6/20 nonlinearities found in bench/diagnose_confusion.md's impact run).
            // Both only over coherent lines: an accelerometer's low-frequency noise
            // divided by ω² (1/f noise, a second generator) made the impact floor
            // absurd, every misfit hid under it (a 2-sample delay, rel. error 1.9: 1 σ)
            let continuous = ev.kind == "continuous";
            let hmax = h
                .iter()
                .zip(&ev.freqs_hz)
                .zip(g)
                .filter(|((_, f), g)| {
                    **g >= min_coh && (!continuous || (**f >= band.0 && **f <= band.1))
                })
                .map(|((v, _), _)| v.norm())
                .fold(0.0, f64::max);
            for (i, f) in ev.freqs_hz.iter().enumerate() {
                if *f < band.0 || *f > band.1 || g[i] < min_coh {
                    continue;
                }
                // a few hits' coherence is unreliable line by line: noise alone passes
                // 0.8 on isolated lines (4 averages: about 1 in 100), and its standard
                // error from that chance value is many times too small. A resonance is
                // coherent over its neighbours too: impact evidence takes the median
                // coherence of the line and its two neighbours (one chance line among
                // noise gets the noise's, one dip beside a peak does not spread)
                let g_se = if ev.kind == "impact"
                    && ev.n_avg < SMOOTH_COHERENCE_BELOW_AVG
                    && i > 0
                    && i + 1 < g.len()
                {
                    let mut w = [g[i - 1], g[i], g[i + 1]];
                    w.sort_by(f64::total_cmp);
                    w[1]
                } else {
                    g[i]
                };
                let rel = OperatingSpectra::rel_error(g_se, ev.n_avg);
                let se = sig.get(i).copied().unwrap_or(rel * h[i].norm());
                p.freqs_hz.push(*f);
                p.h.push(h[i]);
                // floors: 0.5 % of the point, 0.1 % of the channel's peak (numerical and
                // leakage limits)
                p.sigma
                    .push(se.max(5e-3 * h[i].norm()).max(1e-3 * hmax).max(1e-300));
            }
            p
        })
        .filter(|p| !p.h.is_empty())
        .collect()
}

/// The force axes the twin knows: inputs of the channels it models or its campaign
/// measured. `None` for a twin without plans (every channel counts).
fn known_inputs(twin: &Twin) -> Option<Vec<Axis>> {
    if twin.poses.iter().all(|p| p.plan.is_none()) {
        return None;
    }
    let mut known: Vec<Axis> = twin.channels.iter().map(|c| c.input).collect();
    for p in &twin.poses {
        for d in p.plan.iter().flat_map(|pl| &pl.channels) {
            known.push(d.channel.input);
        }
    }
    known.sort_by_key(|a| a.index());
    known.dedup();
    Some(known)
}

/// [`points`] of the channels whose input the twin knows (inputs of the channels it models or measured): a channel
/// driven by a force the campaign never applied (the z force in milling, when only x
/// and y were hit) is no evidence against the twin, it says nothing there. A response
/// in another axis to a known force stays evidence (a cross coupling the twin lacks).
pub fn twin_points(ev: &Evidence, twin: &Twin, band: (f64, f64), min_coh: f64) -> Vec<Points> {
    let known = known_inputs(twin);
    let mut pts = points(ev, band, min_coh);
    if let Some(known) = &known {
        pts.retain(|p| known.contains(&p.channel.input));
    }
    // a channel the twin holds empty is evidence only where the response is coherent
    // over a run of lines (a resonance): with a few averages, noise alone passes the
    // coherence threshold on isolated lines (about 1 % of them with 4 averages), and
    // against a model of zero each such line is a many-sigma misfit. Either
    // [`EMPTY_CHANNEL_MIN_RUN`] lines at `min_coh`, or [`RECIPROCAL_MIN_RUN`] lines where
    // the channel and its reciprocal (yx and xy) are both coherent beyond chance: a
    // turned guide raises both alike, noise does not (second generator, a guide turned
    // 15 degrees at a 70 Hz mode under 1/f sensor noise: yx and xy at 0.65-0.87 on three
    // lines at 131-138 Hz, none at 0.8 on five)
    let df = ev
        .freqs_hz
        .get(1)
        .zip(ev.freqs_hz.first())
        .map_or(0.0, |(b, a)| b - a);
    let level = reciprocal_level(ev.n_avg).min(min_coh);
    let relaxed = points(ev, band, level);
    let coherence = |c: Channel| {
        (ev.channels.iter())
            .find(|(ch, _, _)| *ch == c)
            .map(|(_, _, g)| g)
    };
    // lines of runs of at least `min_run` consecutive lines that `pass`
    let runs = |freqs: &[f64], pass: &dyn Fn(usize) -> bool, min_run: usize| {
        let n = freqs.len();
        let mut keep = vec![false; n];
        let mut i = 0;
        while i < n {
            if !pass(i) {
                i += 1;
                continue;
            }
            let mut j = i + 1;
            while j < n && pass(j) && freqs[j] - freqs[j - 1] <= 1.5 * df {
                j += 1;
            }
            if j - i >= min_run {
                keep[i..j].iter_mut().for_each(|k| *k = true);
            }
            i = j;
        }
        keep
    };
    let line_of = |f: f64| {
        let k = ev.freqs_hz.partition_point(|x| *x < f);
        if k > 0 && (k == ev.freqs_hz.len() || f - ev.freqs_hz[k - 1] < ev.freqs_hz[k] - f) {
            k - 1
        } else {
            k
        }
    };
    let order = |c: Channel| ev.channels.iter().position(|(ch, _, _)| *ch == c);
    let mut out: Vec<Points> = Vec::with_capacity(pts.len());
    let noise = noise_model_channels(twin);
    let held = |c: Channel| twin.channels.contains(&c) && !noise.contains(&c);
    let empty = relaxed.into_iter().filter(|q| {
        !held(q.channel) && known.as_ref().is_none_or(|k| k.contains(&q.channel.input))
    });
    for mut q in empty {
        let own = coherence(q.channel);
        // the reciprocal channel (the twin may hold it)
        let back = Channel::new(q.channel.input, q.channel.output);
        let recip = (back != q.channel).then(|| coherence(back)).flatten();
        let g_at = |g: Option<&Vec<f64>>, f: f64| g.map_or(0.0, |g| g[line_of(f)]);
        let f = q.freqs_hz.clone();
        let paired = runs(
            &f,
            &|i| g_at(own, f[i]) >= level && g_at(recip, f[i]) >= level,
            RECIPROCAL_MIN_RUN,
        );
        let strong = runs(&f, &|i| g_at(own, f[i]) >= min_coh, EMPTY_CHANNEL_MIN_RUN);
        if paired.iter().any(|k| *k) {
            let keep: Vec<bool> = strong.iter().zip(&paired).map(|(a, b)| *a || *b).collect();
            retain_lines(&mut q, &keep);
            out.push(q);
        } else if let Some(mut p) = pts.iter().find(|p| p.channel == q.channel).cloned() {
            // no paired run: the strong runs, on the lines (and floors) at `min_coh`
            let keep = runs(&p.freqs_hz, &|_| true, EMPTY_CHANNEL_MIN_RUN);
            retain_lines(&mut p, &keep);
            out.push(p);
        }
    }
    out.extend(pts.into_iter().filter(|p| held(p.channel)));
    out.sort_by_key(|p| order(p.channel));
    let mut pts = out;
    pts.retain(|p| !p.h.is_empty());
    pts
}

/// The channels `twin` holds as a model of noise: at every measured pose the model fits
/// its own FRF no better than zero and so would the noise-free truth (its noise limit is
/// ≤ 0 too: a noise-only cross channel that the campaign kept for its few coherent lines;
/// a channel whose data hold a response the model missed is not one). Such a channel is
/// as good as empty: its model's size is the twin's noise level, and new data's
/// noise-level lines that pass the coherence threshold by chance (a few averages) would
/// be many-sigma misfits against a twin measured with a quieter sensor (second
/// generator, accelerometer noise ×0.1: healthy impacts `unexplained` on 3 of 20 seeds,
/// local misfit 4.1 sigma in zy).
fn noise_model_channels(twin: &Twin) -> Vec<Channel> {
    twin.channels
        .iter()
        .copied()
        .filter(|&c| {
            let fits: Vec<(f64, Option<f64>)> = (twin.poses.iter())
                .filter_map(|p| p.fit.iter().find(|f| f.channel == c))
                .map(|f| (f.fit_pct, f.noise_limit_pct))
                .collect();
            !fits.is_empty() && (fits.iter()).all(|(f, n)| *f <= 0.0 && n.is_some_and(|n| n <= 0.0))
        })
        .collect()
}

/// Averages below which [`points`] takes a line's standard error from the median coherence
/// of the line and its neighbours (impact evidence).
const SMOOTH_COHERENCE_BELOW_AVG: usize = 16;

/// Keeps the lines of `p` where `keep` is true (same length as `p`'s lines).
pub(super) fn retain_lines(p: &mut Points, keep: &[bool]) {
    let mut k = keep.iter();
    p.freqs_hz.retain(|_| *k.next().unwrap_or(&false));
    let mut k = keep.iter();
    p.h.retain(|_| *k.next().unwrap_or(&false));
    let mut k = keep.iter();
    p.sigma.retain(|_| *k.next().unwrap_or(&false));
}

/// Consecutive coherent lines a channel the twin holds empty needs to count as evidence.
const EMPTY_CHANNEL_MIN_RUN: usize = 5;

/// Consecutive lines where a channel the twin holds empty and its reciprocal are both
/// coherent beyond chance ([`reciprocal_level`]) that count as evidence: noise passes
/// both on one line with probability 0.0025, on three in a row 1.6e-8.
const RECIPROCAL_MIN_RUN: usize = 3;

/// The coherence a channel and its reciprocal both need on a line for
/// [`RECIPROCAL_MIN_RUN`]: the level that noise alone exceeds on 5 % of the lines with
/// `n` averages ([`crate::plan::null_coherence`]), and at least 0.5 (the response as
/// strong as the noise: long operating records reach small coherent cross responses that
/// an impact test's twin could not resolve).
fn reciprocal_level(n: usize) -> f64 {
    crate::plan::null_coherence(n, 0.05).max(0.5)
}

/// Adds the twin's own uncertainty to the standard errors of `pts`: at each line, the
/// local RMS misfit (±2.5 % of frequency, at least the nearest line) of the twin's
/// measured pose nearest to `pose` against the FRF it was identified from. New data more
/// precise than the twin's own (long operating records) must not call the twin's
/// identification error a misfit.
///
/// Also the twin's own estimate's variance there (its stored FRF's standard error from
/// its coherence and averages, `OperatingSpectra::rel_error`): a twin identified from a
/// few noisy hits is no better than that, whatever its fit to them. And a channel the
/// campaign trusted only in a narrower band (its plan's `band_hz`: coherence below the
/// trust level outside) is no evidence outside it: those lines are dropped.
pub fn add_twin_uncertainty(pts: &mut Vec<Points>, twin: &Twin, pose: [f64; 3]) {
    let dist = |q: &[f64; 3]| (0..3).map(|a| (q[a] - pose[a]).powi(2)).sum::<f64>();
    let Some(pm) = twin
        .poses
        .iter()
        .min_by(|a, b| dist(&a.pose).total_cmp(&dist(&b.pose)))
    else {
        return;
    };
    let mut model = pm.model.clone();
    if let Some(s) = pm.frf_exp_window_sigma {
        model.shift_poles(-s);
    }
    let fr = &pm.frf.freqs_hz;
    let averages = pm.plan.as_ref().and_then(|p| p.averages).unwrap_or(1);
    for p in pts.iter_mut() {
        let trusted = pm.plan.as_ref().and_then(|pl| {
            pl.channels
                .iter()
                .find(|d| d.channel == p.channel && d.used)
                .and_then(|d| d.band_hz)
        });
        if let Some([lo, hi]) = trusted {
            let keep: Vec<bool> = p.freqs_hz.iter().map(|f| *f >= lo && *f <= hi).collect();
            retain_lines(p, &keep);
        }
        let (Some(ci), Some(stored)) = (
            model.channel_index(p.channel),
            pm.frf.channels.iter().find(|c| c.channel == p.channel),
        ) else {
            continue;
        };
        let r2: Vec<f64> = fr
            .iter()
            .zip(&stored.h)
            .enumerate()
            .map(|(i, (f, h))| {
                let est = stored
                    .coherence
                    .as_ref()
                    .and_then(|g| g.get(i))
                    .map_or(0.0, |g| {
                        (OperatingSpectra::rel_error(*g, averages) * h.norm()).powi(2)
                    });
                (model.eval_hz(ci, *f) - h).norm_sqr() + est
            })
            .collect();
        if r2.is_empty() {
            continue;
        }
        for (f, sg) in p.freqs_hz.iter().zip(p.sigma.iter_mut()) {
            let a = fr.partition_point(|x| *x < 0.975 * f);
            let b = fr.partition_point(|x| *x <= 1.025 * f);
            let local = if b > a {
                r2[a..b].iter().sum::<f64>() / (b - a) as f64
            } else {
                let i = fr.partition_point(|x| x < f).min(r2.len() - 1);
                r2[i]
            };
            *sg = (*sg * *sg + local).sqrt();
        }
    }
    pts.retain(|p| !p.h.is_empty());
}

pub(super) fn band_of(twin: &Twin) -> (f64, f64) {
    let lo = twin
        .poses
        .iter()
        .map(|p| p.band_hz[0])
        .fold(f64::INFINITY, f64::min);
    let hi = twin.poses.iter().map(|p| p.band_hz[1]).fold(0.0, f64::max);
    (lo, hi)
}

/// Held-out time fit \[%\] of `twin` on the splits (all response axes pooled).
pub fn holdout_fit(twin: &Twin, splits: &[Split]) -> Result<f64> {
    holdout_fit_each(|_| twin, splits)
}

/// [`holdout_fit`] with the twin `twin_of(i)` for split `i` (e.g. tones whose phase
/// was fitted per record).
pub(super) fn holdout_fit_each<'a>(
    twin_of: impl Fn(usize) -> &'a Twin,
    splits: &[Split],
) -> Result<f64> {
    Ok(HeldOut::simulate(twin_of, splits)?.fit())
}

/// The response axes of `ts` whose simulation by `twin` counts: every one, also one the
/// twin does not model (then its prediction is 0: a missing cross channel shows) --
/// unless a force the twin knows nothing of acts too (the z force in milling, when only
/// x and y were hit): then such an axis' response is not the twin's to predict.
pub(super) fn judged_axes(twin: &Twin, ts: &TimeSeries) -> Vec<Axis> {
    let unknown_force = known_inputs(twin).is_some_and(|known| {
        Axis::ALL.iter().any(|a| {
            !known.contains(a) && ts.force(*a).is_some_and(|f| f.iter().any(|v| *v != 0.0))
        })
    });
    Axis::ALL
        .into_iter()
        .filter(|a| ts.response(*a).is_some())
        .filter(|a| !unknown_force || twin.channels.iter().any(|c| c.output == *a))
        .collect()
}

/// The held-out parts of the records and a twin's simulation of them: each measured
/// response axis the fit counts, as (measured, simulated, sample interval).
pub(super) struct HeldOut {
    segments: Vec<(Vec<f64>, Vec<f64>, f64)>,
    /// Per segment: its response axis and whether its record is continuous (not an
    /// impact test).
    kinds: Vec<(Axis, bool)>,
}

/// The static part of the held-out responses of continuous records ([`HeldOut::static_part`]).
#[derive(Debug, Clone)]
pub(super) struct StaticPart {
    /// Per response axis: mean held-out deflection measured and simulated by the twin,
    /// averaged over the continuous records.
    pub axes: Vec<(Axis, f64, f64)>,
    /// Share of the held-out misfit's energy (continuous records) that the difference
    /// of each segment's means carries.
    pub share_of_misfit: f64,
    /// Percentage points of held-out fit (continuous records pooled) that the
    /// difference of the means costs.
    pub fit_cost_points: f64,
}

impl HeldOut {
    /// Simulates `twin_of(i)` on split `i` (the whole record, from rest) and keeps the
    /// held-out part of every response axis that counts ([`judged_axes`]).
    pub(super) fn simulate<'a>(
        twin_of: impl Fn(usize) -> &'a Twin,
        splits: &[Split],
    ) -> Result<HeldOut> {
        let mut segments = Vec::new();
        let mut kinds = Vec::new();
        for (i, s) in splits.iter().enumerate() {
            let twin = twin_of(i);
            let ts = &s.full;
            let y = simulate_as_measured(twin, ts)?;
            for a in judged_axes(twin, ts) {
                let Some(m) = ts.response(a) else { continue };
                segments.push((
                    m[s.holdout_start..].to_vec(),
                    y[a.index()][s.holdout_start..].to_vec(),
                    ts.dt,
                ));
                kinds.push((a, !is_impact(ts)));
            }
        }
        if segments.is_empty() {
            return Err(Error::BadInput("no response column to compare with".into()));
        }
        Ok(HeldOut { segments, kinds })
    }

    /// The static part of the continuous records' held-out responses: the mean
    /// deflection per axis, measured and simulated, and the share of the misfit it
    /// carries. `None` without a continuous record or without misfit.
    pub(super) fn static_part(&self) -> Option<StaticPart> {
        let (mut dc_err, mut err) = (0.0, 0.0);
        let mut per_axis: Vec<(Axis, f64, f64, usize)> = Vec::new();
        for ((m, y, _), (a, continuous)) in self.segments.iter().zip(&self.kinds) {
            if !continuous || m.is_empty() {
                continue;
            }
            let n = m.len() as f64;
            let (mm, my) = (m.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
            dc_err += n * (mm - my).powi(2);
            err += m.iter().zip(y).map(|(u, v)| (u - v).powi(2)).sum::<f64>();
            match per_axis.iter_mut().find(|p| p.0 == *a) {
                Some(p) => {
                    p.1 += mm;
                    p.2 += my;
                    p.3 += 1;
                }
                None => per_axis.push((*a, mm, my, 1)),
            }
        }
        let pooled: Vec<f64> = (self.segments.iter().zip(&self.kinds))
            .filter(|(_, k)| k.1)
            .flat_map(|(sg, _)| sg.0.iter().copied())
            .collect();
        let mean = pooled.iter().sum::<f64>() / pooled.len().max(1) as f64;
        let power: f64 = pooled.iter().map(|v| (v - mean).powi(2)).sum();
        (err > 0.0 && power > 0.0).then(|| StaticPart {
            fit_cost_points: 100.0 * (err.sqrt() - (err - dc_err).max(0.0).sqrt()) / power.sqrt(),
            axes: per_axis
                .into_iter()
                .map(|(a, m, y, k)| (a, m / k as f64, y / k as f64))
                .collect(),
            share_of_misfit: dc_err / err,
        })
    }

    /// The fit \[%\] of the simulated against the measured held-out responses.
    pub(super) fn fit(&self) -> f64 {
        let meas: Vec<f64> = self
            .segments
            .iter()
            .flat_map(|s| s.0.iter().copied())
            .collect();
        let sim: Vec<f64> = self
            .segments
            .iter()
            .flat_map(|s| s.1.iter().copied())
            .collect();
        fit_percent_real(&meas, &sim)
    }

    /// The same fit of the responses band-passed to `lo..hi` Hz (each held-out segment's
    /// spectrum, lines in the band only; Parseval): how much better a twin predicts the
    /// vibration where an effect acts, which the whole response's fit dilutes when the
    /// effect's mode carries little of the response power. `None` without power there.
    pub(super) fn band_fit(&self, lo: f64, hi: f64) -> Option<f64> {
        let (mut err, mut pow) = (0.0, 0.0);
        for (m, y, dt) in &self.segments {
            let n = m.len();
            if n < 4 {
                continue;
            }
            let fft = crate::spectra::plan(n);
            let spectrum = |v: &[f64]| {
                let mut x = v.to_vec();
                let mut out = fft.make_output_vec();
                fft.process(&mut x, &mut out).ok().map(|_| out)
            };
            let (Some(fm), Some(fy)) = (spectrum(m), spectrum(y)) else {
                continue;
            };
            let df = 1.0 / (n as f64 * dt);
            for (k, (a, b)) in fm.iter().zip(&fy).enumerate() {
                let f = k as f64 * df;
                if f >= lo && f <= hi {
                    err += (a - b).norm_sqr();
                    pow += a.norm_sqr();
                }
            }
        }
        (pow > 0.0).then(|| 100.0 * (1.0 - (err / pow).sqrt()))
    }
}

/// The records split by force level (peak force below / above the geometric mean of the
/// smallest and largest peak) when the levels differ clearly (ratio ≥ 2), else nothing.
/// The units a force level is judged on: each hit of an impact record (from its
/// pre-trigger to the next hit's; a record may hold hits at several levels), a
/// continuous record whole.
pub(super) fn level_units(parts: &[TimeSeries]) -> Vec<TimeSeries> {
    let mut out = Vec::new();
    for ts in parts {
        if !is_impact(ts) {
            out.push(ts.clone());
            continue;
        }
        out.extend(hit_segments(ts));
    }
    out
}

/// Each hit of an impact record as its own record: from a 2 ms pre-trigger to the next
/// hit's pre-trigger (or the end); segments of 16 samples or fewer are skipped.
fn hit_segments(ts: &TimeSeries) -> Vec<TimeSeries> {
    let hits = hit_starts(ts);
    let pre = (0.002 / ts.dt) as usize;
    hits.iter()
        .enumerate()
        .filter_map(|(h, &s)| {
            let a = s.saturating_sub(pre);
            let b = hits.get(h + 1).map_or(ts.len(), |&n| n.saturating_sub(pre));
            (b > a + 16).then(|| slice(ts, a, b))
        })
        .collect()
}

pub(super) fn force_levels(parts: &[TimeSeries]) -> Vec<Vec<TimeSeries>> {
    let parts = &level_units(parts);
    let peaks: Vec<f64> = parts
        .iter()
        .map(|t| force_mag(t).iter().fold(0.0f64, |a, v| a.max(*v)))
        .collect();
    let (lo, hi) = peaks
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(*p), b.max(*p)));
    if !(lo > 0.0 && hi >= 2.0 * lo) {
        return Vec::new();
    }
    let split = (lo * hi).sqrt();
    [false, true]
        .iter()
        .map(|high| {
            parts
                .iter()
                .zip(&peaks)
                .filter(|(_, p)| (**p >= split) == *high)
                .map(|(t, _)| t.clone())
                .collect()
        })
        .collect()
}

/// Response power not coherent with the measured forces, per output and Welch line.
pub(super) struct IncoherentLines {
    pub(super) df: f64,
    pub(super) freqs: Vec<f64>,
    pub(super) per_output: Vec<(Axis, Vec<f64>)>,
    /// Force PSD summed over the inputs.
    force_psd: Vec<f64>,
}

/// Median of `p` over the lines 4..24 away from `l` on both sides (the neighbourhood a
/// line stands out of); `None` without such lines.
fn side_median(p: &[f64], l: usize) -> Option<f64> {
    let mut side: Vec<f64> = (4..=24)
        .flat_map(|d| [l.checked_sub(d), Some(l + d)])
        .flatten()
        .filter(|&j| j < p.len())
        .map(|j| p[j])
        .collect();
    if side.is_empty() {
        return None;
    }
    side.sort_by(f64::total_cmp);
    Some(side[side.len() / 2])
}

impl IncoherentLines {
    /// Whether line `l` (or a neighbour) is a line of the force itself (a periodic force:
    /// tooth passing, spindle): its summed PSD 3× above the median of lines 4..24 away.
    pub(super) fn force_line(&self, l: usize) -> bool {
        let p = &self.force_psd;
        side_median(p, l).is_some_and(|med| {
            p[l.saturating_sub(1)..(l + 2).min(p.len())]
                .iter()
                .any(|v| *v > 3.0 * med)
        })
    }

    /// Index of the line nearest to `f`.
    fn line_of(&self, f: f64) -> usize {
        let k = self.freqs.partition_point(|x| *x < f);
        if k > 0 && (k == self.freqs.len() || f - self.freqs[k - 1] < self.freqs[k] - f) {
            k - 1
        } else {
            k
        }
    }

    /// Incoherent power at the line of `f` (the largest of it and its two neighbours: a
    /// tone between lines) over the median of the lines 4..24 away on both sides.
    pub(super) fn strength(&self, a: Axis, f: f64) -> f64 {
        let Some((_, p)) = self.per_output.iter().find(|(x, _)| *x == a) else {
            return f64::INFINITY;
        };
        let l = self.line_of(f);
        if l >= p.len() {
            return 0.0;
        }
        let peak = p[l.saturating_sub(1)..(l + 2).min(p.len())]
            .iter()
            .fold(0.0f64, |m, v| m.max(*v));
        side_median(p, l).map_or(0.0, |med| peak / med.max(1e-300))
    }
}

/// [`IncoherentLines`] of the building parts (lines of about 1 Hz, at least 8 averages);
/// `None` when the records cannot be estimated (no force, too short).
pub(super) fn incoherent_lines(parts: &[TimeSeries]) -> Option<IncoherentLines> {
    let fs = parts.first()?.fs();
    let total: usize = parts.iter().map(TimeSeries::len).sum();
    let mut nfft = (fs as usize).next_power_of_two();
    while nfft > 256 && total / nfft < 5 {
        nfft /= 2;
    }
    let sp = operating_spectra(parts, nfft).ok()?;
    let per_output = sp
        .coherence
        .iter()
        .zip(&sp.psd_out)
        .map(|((a, g), (_, p))| (*a, g.iter().zip(p).map(|(g, p)| (1.0 - g) * p).collect()))
        .collect();
    Some(IncoherentLines {
        df: sp.df_hz,
        freqs: sp.freqs_hz.clone(),
        per_output,
        force_psd: (0..sp.freqs_hz.len())
            .map(|l| sp.psd_in.iter().map(|(_, v)| v[l]).sum())
            .collect(),
    })
}
