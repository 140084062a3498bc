//! Lifetime refit from operating data (paper section 2.3), and a better update.
//!
//! 1. **Drift check**: the twin simulates the measured forces (paper eq. 3, here the
//!    exact modal state space with a first-order hold); its fit to the measured response
//!    and the misfit of the operating FRF points in standard errors decide whether the
//!    machine has changed.
//! 2. **The paper's update** ([`RefitMethod::Paper`]): response PSD above a threshold
//!    selects lines; FRF points there come from cross-spectra (H1, phase kept); they
//!    replace the previous FRF's lines (the *intermediate FRF*, with steps); the weight
//!    W(ω) is 1 at inserted points and far from them, 0 between inserted points, faded in
//!    over an uncertainty range around them and near 0 Hz; the rational fit is refined
//!    from the previous model.
//! 3. **mtwin's update** ([`RefitMethod::Modal`], the default): no stepped FRF. Only
//!    modes whose response dominates some well-excited line are candidates; they are
//!    freed one at a time (forward selection: the candidate that lowers the misfit most,
//!    kept while it lowers it by ≥ 1 %), all others held; the free modes' frequency,
//!    damping and residues are fitted directly to the operating cross-spectral FRF
//!    points, each weighted by its standard error from coherence, with a weak prior
//!    towards the previous model ([`crate::modal_update`]). The standard errors scale
//!    with |H| from the neighbourhood, then (a second, reweighted pass) from the updated
//!    model — never from the line's own noisy value, which would bias peaks low.
//! 4. **Position update**: the parameter change found at the operating pose applies in
//!    full to the measured poses of the grid cell around it (so the twin there carries
//!    the whole change) and to every other measured pose with weight `exp(-(d/L)²)`
//!    (d = distance from that cell, L settable; default half the workspace diagonal).
//! 5. **History**: an entry with the data files, the figures and the complete previous
//!    pose models is appended; nothing is ever removed.

use crate::axis::Axis;
use crate::campaign::channel_fits;
use crate::error::{Error, Result};
use crate::frf::{fit_percent_real, Frf};
use crate::interpolate::{simulate_twin, TwinEvaluator};
use crate::modal_update::{apply_change, chi, update_modes, Points, Prior};
use crate::model::ModalModel;
use crate::operating::{operating_spectra, OperatingSpectra};
use crate::rational_fit::{refine_from, FitOptions};
use crate::simulate::{force_rows, Hold};
use crate::timeseries::{ResponseKind, TimeSeries};
use crate::twin::{now_unix, HistoryEntry, Twin};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Which update to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RefitMethod {
    /// The paper's intermediate FRF + weighted refit.
    Paper,
    /// mtwin's direct modal update from operating cross-spectra.
    Modal,
    /// The modal update, then the updated modes refined by output error on the records
    /// themselves ([`crate::output_error`]: no Welch window, no leakage).
    Time,
}

/// Options of [`refit`].
#[derive(Debug, Clone)]
pub struct RefitOptions {
    /// Which update.
    pub method: RefitMethod,
    /// Update when the simulated response fits the measured one worse than
    /// `100 - drift_threshold_pct` percent ...
    pub drift_threshold_pct: f64,
    /// ... or when the operating FRF points miss the twin by more than this many
    /// standard errors (RMS).
    pub drift_chi: f64,
    /// Refit even without drift.
    pub force: bool,
    /// Paper's PSD threshold on the response [m²/Hz]; `None` = automatic
    /// (10 × the median response PSD).
    pub psd_threshold: Option<f64>,
    /// Lines below this coherence are not used.
    pub min_coherence: f64,
    /// Welch segment length (default: ~0.25 Hz... chosen from the record: 1 s or shorter).
    pub nfft: Option<usize>,
    /// Length L \[m\] of the position spread: the change applies in full to the measured
    /// poses of the grid cell around the operating pose and with weight exp(−(d/L)²) to
    /// the others, d = distance from that cell; `None` = half the workspace diagonal; 0 = the
    /// nearest pose only;
    /// infinity = the same change everywhere.
    pub spread_length_m: Option<f64>,
    /// Rational-fit options (the paper's method).
    pub fit: FitOptions,
}

impl Default for RefitOptions {
    fn default() -> Self {
        RefitOptions {
            method: RefitMethod::Time,
            drift_threshold_pct: 5.0,
            drift_chi: 5.0,
            force: false,
            psd_threshold: None,
            min_coherence: 0.8,
            nfft: None,
            spread_length_m: None,
            fit: FitOptions::default(),
        }
    }
}

/// A mode's change in one refit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModeChange {
    /// Index of the tracked mode.
    pub mode: usize,
    /// Natural frequency before \[Hz\].
    pub freq_before_hz: f64,
    /// Natural frequency after \[Hz\].
    pub freq_after_hz: f64,
    /// Damping ratio before.
    pub zeta_before: f64,
    /// Damping ratio after.
    pub zeta_after: f64,
}

/// What a refit found and did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefitReport {
    /// Method used.
    pub method: RefitMethod,
    /// Operating pose (mean axis position of the data) \[m\].
    pub pose: [f64; 3],
    /// Fit \[%\] of the twin's simulated response to the measured one, before.
    pub drift_fit_pct: f64,
    /// RMS misfit of the operating FRF points in standard errors, before.
    pub drift_chi: f64,
    /// Whether the twin was changed.
    pub updated: bool,
    /// Fit \[%\] of the updated twin's simulated response (same data).
    pub fit_after_pct: f64,
    /// Lines used \[Hz\].
    pub lines_hz: Vec<f64>,
    /// Modes freed (modal method) or all (paper).
    pub modes: Vec<ModeChange>,
    /// Weight of the change at each measured pose.
    pub pose_weights: Vec<([f64; 3], f64)>,
    /// The output-error stage (method `time`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_error: Option<crate::output_error::OeSummary>,
}

/// One response axis: the axis, the measured and the simulated samples.
pub type AxisTrace = (Axis, Vec<f64>, Vec<f64>);

/// Simulated response of a twin for a record, in the record's response quantity, per
/// response axis present in both (FOH: the force is linear between samples).
pub fn simulate_record(twin: &Twin, ts: &TimeSeries) -> Result<Vec<AxisTrace>> {
    let mut ev = TwinEvaluator::new(twin)?;
    let forces = force_rows(ts);
    let y = simulate_twin(&mut ev, &forces, |i| ts.position_at(i), ts.dt, Hold::Foh);
    let outs: Vec<Axis> = ev.channels().iter().map(|c| c.output).collect();
    let mut res = Vec::new();
    for a in Axis::ALL {
        let Some(meas) = ts.response(a) else { continue };
        if !outs.contains(&a) {
            continue;
        }
        let mut sim: Vec<f64> = y.iter().map(|r| r[a.index()]).collect();
        if ts.response_kind == Some(ResponseKind::Acceleration) {
            sim = second_derivative(&sim, ts.dt);
        }
        res.push((a, meas.to_vec(), sim));
    }
    Ok(res)
}

/// Central second difference (acceleration from sampled displacement), ends copied.
pub(crate) fn second_derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut a = vec![0.0; n];
    for i in 1..n.saturating_sub(1) {
        a[i] = (x[i + 1] - 2.0 * x[i] + x[i - 1]) / (dt * dt);
    }
    if n >= 3 {
        a[0] = a[1];
        a[n - 1] = a[n - 2];
    }
    a
}

/// Fit \[%\] of the twin's simulation against the measured responses (all axes pooled).
pub fn time_fit(twin: &Twin, records: &[TimeSeries]) -> Result<f64> {
    let mut meas = Vec::new();
    let mut sim = Vec::new();
    for ts in records {
        for (_, m, s) in simulate_record(twin, ts)? {
            // skip the start-up transient (the twin starts at rest, the machine did not)
            let skip = (m.len() / 20).min(2000);
            meas.extend_from_slice(&m[skip..]);
            sim.extend_from_slice(&s[skip..]);
        }
    }
    if meas.is_empty() {
        return Err(Error::BadInput(
            "the data has no response column the twin models".into(),
        ));
    }
    Ok(fit_percent_real(&meas, &sim))
}

/// Welch segment length: lines no wider than an eighth of the narrowest half-power bandwidth of
/// the twin's modes below 0.4 fs (so peaks are resolved), but at least 4 segments in the
/// record (7 averages with 50 % overlap).
pub fn default_nfft(ts: &TimeSeries, model: &ModalModel) -> usize {
    let n = ts.len();
    let fs = ts.fs();
    let df = model
        .modes
        .iter()
        .filter(|m| m.freq_hz() < 0.4 * fs)
        .map(|m| 0.25 * m.zeta * m.freq_hz())
        .fold(fs / 256.0, f64::min)
        .max(fs / (1usize << 20) as f64);
    let mut nfft = ((fs / df).ceil() as usize).next_power_of_two();
    while nfft > 256 && nfft * 4 > n {
        nfft /= 2;
    }
    nfft.max(64)
}

/// Lines mtwin's modal update uses: every line whose coherence reaches the limit (the
/// cross-spectral H1 is valid wherever the coherence is high, whatever the PSD), thinned
/// to at most ~4000 lines.
fn coherent_lines(sp: &OperatingSpectra, opts: &RefitOptions) -> Vec<usize> {
    let n = sp.freqs_hz.len();
    let ok: Vec<usize> = (1..n)
        .filter(|&l| sp.coherence.iter().all(|(_, g)| g[l] >= opts.min_coherence))
        .collect();
    let step = ok.len().div_ceil(4000).max(1);
    ok.into_iter().step_by(step).collect()
}

/// Lines the paper would insert: response PSD above the threshold and coherence high.
fn selected_lines(sp: &OperatingSpectra, opts: &RefitOptions) -> Vec<usize> {
    let mut sel = Vec::new();
    for (o, (_, psd)) in sp.psd_out.iter().enumerate() {
        let thr = opts.psd_threshold.unwrap_or_else(|| {
            let mut v = psd.clone();
            v.sort_by(f64::total_cmp);
            10.0 * v[v.len() / 2]
        });
        for (l, p) in psd.iter().enumerate() {
            if *p >= thr && sp.coherence[o].1[l] >= opts.min_coherence {
                sel.push(l);
            }
        }
    }
    sel.sort_unstable();
    sel.dedup();
    sel
}

/// FRF points at `lines` with their standard errors. The error scales with `|H|` taken
/// from `mag_model` when given (an iteratively reweighted pass with the updated model),
/// else from the measured neighbourhood.
fn operating_points(
    sp: &OperatingSpectra,
    lines: &[usize],
    model: &ModalModel,
    mag_model: Option<&ModalModel>,
) -> Vec<Points> {
    let mut pts = Vec::new();
    for (ch, h) in &sp.h {
        if model.channel_index(*ch).is_none() {
            continue;
        }
        let o = sp.outputs.iter().position(|a| *a == ch.output).unwrap_or(0);
        let mut p = Points {
            channel: *ch,
            freqs_hz: Vec::new(),
            h: Vec::new(),
            sigma: Vec::new(),
        };
        // The standard error from the line's neighbourhood (median over ±3 lines of the
        // coherence and of |H|), not from the line itself: a weight that depends on the
        // line's own noise favours lines whose noise happens to lower |H| and biases
        // every peak low (damping high).
        let n = h.len();
        let g_all = &sp.coherence[o].1;
        let med = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        for &l in lines {
            let (a, b) = (l.saturating_sub(3), (l + 4).min(n));
            let g = med(&mut g_all[a..b].to_vec());
            let mag = match mag_model.and_then(|m| m.channel_index(*ch).map(|ci| (m, ci))) {
                Some((m, ci)) => m.eval_hz(ci, sp.freqs_hz[l]).norm(),
                None => med(&mut h[a..b].iter().map(|v| v.norm()).collect()),
            };
            let rel = OperatingSpectra::rel_error(g, sp.n_avg).max(2e-3);
            p.freqs_hz.push(sp.freqs_hz[l]);
            p.h.push(h[l]);
            p.sigma.push(rel * mag.max(1e-300));
        }
        pts.push(p);
    }
    pts
}

/// Per axis, the measured coordinates just below and above `pose` (the grid cell the
/// interpolation uses there; the nearest coordinate when outside).
fn enclosing_cell(twin: &Twin, pose: [f64; 3]) -> [(f64, f64); 3] {
    [0, 1, 2].map(|a| {
        let c: Vec<f64> = twin.poses.iter().map(|p| p.pose[a]).collect();
        let below = c
            .iter()
            .copied()
            .filter(|v| *v <= pose[a] + 1e-12)
            .fold(f64::NEG_INFINITY, f64::max);
        let above = c
            .iter()
            .copied()
            .filter(|v| *v >= pose[a] - 1e-12)
            .fold(f64::INFINITY, f64::min);
        let lo = if below.is_finite() { below } else { above };
        let hi = if above.is_finite() { above } else { below };
        (lo, hi)
    })
}

/// A freed mode must lower the RMS misfit by this fraction to stay free.
const MIN_MISFIT_GAIN: f64 = 0.01;

/// Forward selection of the modes to update: free the candidate whose update lowers the
/// misfit most, keep it when the gain is at least [`MIN_MISFIT_GAIN`], repeat. Wear
/// usually changes one or two modes; freeing every excited mode lets the unchanged ones
/// absorb estimation noise and leakage, which costs accuracy against the truth.
fn parsimonious_update(
    old: &ModalModel,
    candidates: &[usize],
    pts: &[Points],
) -> Result<(crate::modal_update::UpdateResult, Vec<usize>)> {
    let chi0 = chi(old, pts, 0.0);
    let mut best = crate::modal_update::UpdateResult {
        model: old.clone(),
        chi_before: chi0,
        chi_after: chi0,
        iterations: 0,
    };
    let mut free: Vec<usize> = Vec::new();
    loop {
        let mut round: Option<(usize, crate::modal_update::UpdateResult)> = None;
        for &k in candidates.iter().filter(|k| !free.contains(k)) {
            let mut f = free.clone();
            f.push(k);
            f.sort_unstable();
            let r = update_modes(old, &f, pts, Prior::default(), 60)?;
            if round
                .as_ref()
                .is_none_or(|(_, b)| r.chi_after < b.chi_after)
            {
                round = Some((k, r));
            }
        }
        let Some((k, r)) = round else { break };
        if std::env::var_os("MTWIN_DEBUG_REFIT").is_some() {
            eprintln!(
                "refit selection: free {free:?} + {k}: chi {:.4} -> {:.4}",
                best.chi_after, r.chi_after
            );
        }
        if r.chi_after > best.chi_after * (1.0 - MIN_MISFIT_GAIN) {
            break;
        }
        free.push(k);
        best = r;
    }
    best.chi_before = chi0;
    Ok((best, free))
}

/// Modes the operating data can tell about: the mode dominates (≥ 30 % of |H|) at some
/// selected line AND selected lines lie on both sides of its peak within a few half-power
/// bandwidths (or shifted by up to 15 %), so its frequency and damping are resolved.
fn excited_modes(model: &ModalModel, pts: &[Points]) -> Vec<usize> {
    let mut free = Vec::new();
    for k in 0..model.modes.len() {
        let m = model.modes[k];
        let fk = m.freq_hz();
        // the resonance region: a few half-power bandwidths, or 5 % for a shifted mode
        let reach = (6.0 * m.zeta * fk).max(0.05 * fk);
        let mut near = 0usize;
        for p in pts {
            let Some(ci) = model.channel_index(p.channel) else {
                continue;
            };
            let n = model.channels[ci].num[k];
            for f in &p.freqs_hz {
                if (f - fk).abs() > reach {
                    continue;
                }
                let s = Complex64::new(0.0, 2.0 * PI * f);
                let hk = (s * n.b1 + n.b0) / m.den(s);
                if hk.norm() >= 0.3 * model.eval_s(ci, s).norm() {
                    near += 1;
                }
            }
        }
        if near >= 3 {
            free.push(k);
        }
    }
    free
}

/// The paper's intermediate FRF and weight: the previous FRF with the operating points
/// inserted AT THEIR OWN FREQUENCIES (previous lines within half a previous line spacing
/// of an inserted point are replaced; snapping to the previous grid would misplace points
/// on lightly damped peaks). Channels the operating data lack take the previous model's
/// value at an inserted frequency.
pub fn intermediate_frf(
    previous: &Frf,
    model: &ModalModel,
    sp: &OperatingSpectra,
    lines: &[usize],
) -> (Frf, Vec<Vec<f64>>) {
    let pf = &previous.freqs_hz;
    let prev_df = if pf.len() > 1 {
        (pf[pf.len() - 1] - pf[0]) / (pf.len() - 1) as f64
    } else {
        1.0
    };
    let mut ins: Vec<f64> = lines.iter().map(|&l| sp.freqs_hz[l]).collect();
    ins.sort_by(f64::total_cmp);
    // rows: (frequency, previous line, operating line)
    let mut rows: Vec<(f64, Option<usize>, Option<usize>)> = Vec::new();
    for (i, &f) in pf.iter().enumerate() {
        let k = ins.partition_point(|&g| g < f);
        let near = [k.saturating_sub(1), k.min(ins.len().saturating_sub(1))]
            .iter()
            .any(|&j| ins.get(j).is_some_and(|g| (g - f).abs() <= 0.5 * prev_df));
        if !near {
            rows.push((f, Some(i), None));
        }
    }
    for &l in lines {
        rows.push((sp.freqs_hz[l], None, Some(l)));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    rows.dedup_by(|a, b| a.0 == b.0);
    let n = rows.len();
    let inserted: Vec<bool> = rows.iter().map(|r| r.2.is_some()).collect();
    let channels = previous
        .channels
        .iter()
        .map(|c| {
            let op = sp.h.iter().find(|(ch, _)| *ch == c.channel).map(|(_, h)| h);
            let o = sp
                .outputs
                .iter()
                .position(|a| *a == c.channel.output)
                .unwrap_or(0);
            let ci = model.channel_index(c.channel);
            let h = rows
                .iter()
                .map(|&(f, pi, ol)| match (pi, ol, op) {
                    (Some(i), _, _) => c.h[i],
                    (None, Some(l), Some(h)) => h[l],
                    _ => ci.map_or(Complex64::new(0.0, 0.0), |ci| model.eval_hz(ci, f)),
                })
                .collect();
            let coherence = c.coherence.as_ref().map(|g| {
                rows.iter()
                    .map(|&(_, pi, ol)| match (pi, ol) {
                        (Some(i), _) => g[i],
                        (None, Some(l)) if op.is_some() => sp.coherence[o].1[l],
                        _ => 1.0,
                    })
                    .collect()
            });
            crate::frf::FrfChannel {
                channel: c.channel,
                h,
                coherence,
            }
        })
        .collect();
    let frf = Frf {
        freqs_hz: rows.iter().map(|r| r.0).collect(),
        channels,
    };
    // uncertainty range: 3 half-power bandwidths of the nearest mode (≥ 3 lines)
    let df = prev_df;
    let range_at = |f: f64| -> f64 {
        let m = model
            .modes
            .iter()
            .min_by(|a, b| (a.freq_hz() - f).abs().total_cmp(&(b.freq_hz() - f).abs()));
        m.map_or(3.0 * df, |m| {
            (3.0 * 2.0 * m.zeta * m.freq_hz()).max(3.0 * df)
        })
    };
    let ins: Vec<usize> = (0..n).filter(|&i| inserted[i]).collect();
    let mut w = vec![1.0; n];
    for i in 0..n {
        if inserted[i] || ins.is_empty() {
            continue;
        }
        let f = frf.freqs_hz[i];
        // between two inserted points that are within each other's range: 0
        let below = ins.iter().rev().find(|&&j| j < i).copied();
        let above = ins.iter().find(|&&j| j > i).copied();
        let d_below = below.map(|j| f - frf.freqs_hz[j]);
        let d_above = above.map(|j| frf.freqs_hz[j] - f);
        if let (Some(a), Some(b)) = (d_below, d_above) {
            let gap = a + b;
            if gap <= 2.0 * range_at(f) {
                w[i] = 0.0;
                continue;
            }
        }
        let d = d_below
            .into_iter()
            .chain(d_above)
            .fold(f64::INFINITY, f64::min);
        let r = range_at(f);
        if d < r {
            // raised-cosine fade from 0 at the inserted point to 1 at distance r
            w[i] = 0.5 - 0.5 * (PI * d / r).cos();
        }
    }
    // near 0 Hz: fade in over the first 2 % of the band
    let f_hi = frf.freqs_hz.last().copied().unwrap_or(1.0);
    for (i, wi) in w.iter_mut().enumerate() {
        let f = frf.freqs_hz[i];
        if f < 0.02 * f_hi && !inserted[i] {
            *wi *= 0.5 - 0.5 * (PI * f / (0.02 * f_hi)).cos();
        }
    }
    let weights = vec![w; frf.channels.len()];
    (frf, weights)
}

/// Lifetime refit of `twin` from operating records (forces, responses, axis positions).
pub fn refit(
    twin: &Twin,
    records: &[TimeSeries],
    opts: &RefitOptions,
) -> Result<(Twin, RefitReport)> {
    let first = records
        .first()
        .ok_or_else(|| Error::BadInput("no operating data given".into()))?;
    let mut pose = [0.0; 3];
    let total: usize = records.iter().map(TimeSeries::len).sum();
    for r in records {
        let p = r.mean_position();
        for a in 0..3 {
            pose[a] += p[a] * r.len() as f64 / total.max(1) as f64;
        }
    }
    let mut ev = TwinEvaluator::new(twin)?;
    let old = ev.model_at(pose).clone();
    let nfft = opts.nfft.unwrap_or_else(|| default_nfft(first, &old));
    let sp = operating_spectra(records, nfft)?;
    let lines = selected_lines(&sp, opts);
    let pts = operating_points(&sp, &lines, &old, None);
    let drift_chi = chi(&old, &pts, 0.0);
    let drift_fit = time_fit(twin, records)?;
    let drifted = drift_fit < 100.0 - opts.drift_threshold_pct || drift_chi > opts.drift_chi;
    let mut report = RefitReport {
        method: opts.method,
        pose,
        drift_fit_pct: drift_fit,
        drift_chi,
        updated: false,
        fit_after_pct: drift_fit,
        lines_hz: lines.iter().map(|&l| sp.freqs_hz[l]).collect(),
        modes: Vec::new(),
        pose_weights: Vec::new(),
        output_error: None,
    };
    if !(drifted || opts.force) {
        return Ok((twin.clone(), report));
    }
    if lines.is_empty() {
        return Err(Error::BadInput(format!(
            "the twin has drifted (simulated response fit {drift_fit:.1} %) but no frequency line \
             of the operating data has coherence ≥ {} above the PSD threshold; record longer or \
             lower --min-coherence",
            opts.min_coherence
        )));
    }
    // nearest measured pose: its stored FRF is the "previous FRF" of the paper
    let d2 = |p: &[f64; 3]| (0..3).map(|a| (p[a] - pose[a]).powi(2)).sum::<f64>();
    let near = (0..twin.poses.len())
        .min_by(|&a, &b| d2(&twin.poses[a].pose).total_cmp(&d2(&twin.poses[b].pose)))
        .unwrap_or(0);
    let (new, new_frf) = match opts.method {
        RefitMethod::Modal | RefitMethod::Time => {
            let lines_c = coherent_lines(&sp, opts);
            let pts = operating_points(&sp, &lines_c, &old, None);
            report.lines_hz = lines_c.iter().map(|&l| sp.freqs_hz[l]).collect();
            let candidates = excited_modes(&old, &pts);
            let (first, free) = parsimonious_update(&old, &candidates, &pts)?;
            // reweighted pass: standard errors from the updated model's |H|
            let pts2 = operating_points(&sp, &lines_c, &old, Some(&first.model));
            let res = update_modes(&old, &free, &pts2, Prior::default(), 60)?;
            let model = if opts.method == RefitMethod::Time {
                // the modal update stands when the output-error stage cannot run
                // (the report then has no `output_error`)
                match crate::output_error::refine(&res.model, &free, records, Default::default()) {
                    Ok(oe) => {
                        report.output_error = Some(oe.summary());
                        oe.model
                    }
                    Err(_) => res.model,
                }
            } else {
                res.model
            };
            let prev = &twin.poses[near].frf;
            let (frf, _) = intermediate_frf(prev, &old, &sp, &lines);
            (model, frf)
        }
        RefitMethod::Paper => {
            let prev = &twin.poses[near].frf;
            let (frf, w) = intermediate_frf(prev, &old, &sp, &lines);
            let mut start = old.clone();
            if let Some(s) = twin.poses[near].frf_exp_window_sigma {
                start.shift_poles(-s);
            }
            let mut m = refine_from(&start, &frf, &w, &opts.fit)?;
            if let Some(s) = twin.poses[near].frf_exp_window_sigma {
                m.shift_poles(s);
            }
            (m, frf)
        }
    };
    // spread to the measured poses: in full over the poses of the grid cell around the
    // operating pose (so the twin at the operating pose carries the whole change), then
    // with weight exp(-(d/L)^2), d = distance from that cell
    let mut out = twin.clone();
    let (lo, hi) = ev.bounds();
    let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
    let l = opts.spread_length_m.unwrap_or(0.5 * diag);
    let cell = enclosing_cell(twin, pose);
    for (i, p) in out.poses.iter_mut().enumerate() {
        let d = (0..3)
            .map(|a| {
                (cell[a].0 - p.pose[a])
                    .max(p.pose[a] - cell[a].1)
                    .max(0.0)
                    .powi(2)
            })
            .sum::<f64>()
            .sqrt();
        let w = if l.is_infinite() || diag == 0.0 {
            1.0
        } else if l <= 0.0 {
            if i == near {
                1.0
            } else {
                0.0
            }
        } else {
            (-(d / l).powi(2)).exp()
        };
        apply_change(&mut p.model, &old, &new, w);
        if i == near {
            p.frf = new_frf.clone();
        }
        p.fit = channel_fits(&p.model, &p.frf, (p.band_hz[0], p.band_hz[1]));
        report.pose_weights.push((p.pose, w));
    }
    report.modes = (0..old.modes.len())
        .filter(|&k| {
            (new.modes[k].wn - old.modes[k].wn).abs() > 1e-9 * old.modes[k].wn
                || (new.modes[k].zeta - old.modes[k].zeta).abs() > 1e-9 * old.modes[k].zeta
        })
        .map(|k| ModeChange {
            mode: k,
            freq_before_hz: old.modes[k].freq_hz(),
            freq_after_hz: new.modes[k].freq_hz(),
            zeta_before: old.modes[k].zeta,
            zeta_after: new.modes[k].zeta,
        })
        .collect();
    report.updated = true;
    report.fit_after_pct = time_fit(&out, records)?;
    let mut figures = serde_json::Map::new();
    if let Ok(serde_json::Value::Object(m)) = serde_json::to_value(&report) {
        figures = m;
    }
    out.history.push(HistoryEntry {
        unix_time: now_unix(),
        kind: "refit".into(),
        files: records.iter().map(|r| r.source.clone()).collect(),
        summary: format!(
            "{:?} refit at pose {:?}: simulated-response fit {:.2} % -> {:.2} %, {} modes changed",
            opts.method,
            pose,
            report.drift_fit_pct,
            report.fit_after_pct,
            report.modes.len()
        ),
        figures,
        previous_poses: twin.poses.clone(),
    });
    Ok((out, report))
}
