//! Cause `disturbance`: sinusoids at residual peaks the measured forces do not explain, and
//! the proven tones from outside that the FRF evidence leaves out.

use super::candidate::Cand;
use super::evidence::{retain_lines, windowed_fft, IncoherentLines};
use super::{trace, Cause};
use crate::axis::Axis;
use crate::extended::simulate_as_measured;
use crate::modal_update::Points;
use crate::timeseries::{ResponseKind, TimeSeries};
use crate::twin::{Sinusoid, Twin};
use rustfft::FftPlanner;
use serde_json::{json, Map};
use std::f64::consts::PI;

/// Narrowband peaks of the building part's residual that the forces do not explain.
/// A residual line counts as a disturbance only when the response power at it that is
/// not coherent with the forces stands this many times above the median of its
/// neighbourhood (±24 lines): a tone from outside. Broadband noise scatters such a ratio
/// by a factor of about 3 over 8 averages.
const DISTURBANCE_MIN_STRENGTH: f64 = 20.0;

/// A tone's amplitude in the second half of the building part over its amplitude in the
/// first half, below which the line is a decaying resonance, not a vibration from outside
/// (a constant tone scatters around 1; a mode of 3 % damping at 72 Hz rung by the cut's
/// start has decayed by orders of magnitude after a second).
const PERSISTENT_MIN: f64 = 0.4;

/// Incoherent-power ratio above which a disturbance needs no minimum held-out gain.
pub(super) const DISTURBANCE_PROVEN_STRENGTH: f64 = 1000.0;

impl IncoherentLines {
    /// Frequencies of lines whose incoherent power proves a tone from outside
    /// ([`DISTURBANCE_PROVEN_STRENGTH`]), any output.
    pub(super) fn tones(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for (a, p) in &self.per_output {
            for l in 1..p.len().saturating_sub(1) {
                if p[l] < p[l - 1] || p[l] < p[l + 1] {
                    continue;
                }
                let f = self.freqs[l];
                // a tone is one line wide (Hann: ±2 lines) and takes the coherence with
                // it; a resonance of a slightly time-varying machine is wider and stays
                // coherent
                let narrow = [l.checked_sub(4), Some(l + 4)]
                    .into_iter()
                    .flatten()
                    .filter(|&j| j < p.len())
                    .all(|j| p[j] < 0.01 * p[l]);
                if narrow
                    && !self.force_line(l)
                    && self.strength(*a, f) >= DISTURBANCE_PROVEN_STRENGTH
                    && !out.iter().any(|g| (g - f).abs() < 3.0 * self.df)
                {
                    out.push(f);
                }
            }
        }
        out
    }

    /// Removes the FRF points within 3 Welch lines of a proven tone: there the response
    /// is not the force's, and the FRF estimate's leakage around the tone is no evidence
    /// against the twin.
    pub(super) fn drop_tone_points(&self, pts: &mut Vec<Points>, tones: &[f64]) {
        if tones.is_empty() {
            return;
        }
        let w = 3.0 * self.df;
        for p in pts.iter_mut() {
            let keep: Vec<bool> = p
                .freqs_hz
                .iter()
                .map(|f| tones.iter().all(|t| (t - f).abs() > w))
                .collect();
            retain_lines(p, &keep);
        }
        pts.retain(|p| !p.h.is_empty());
    }
}

pub(super) fn cand_disturbance(
    twin: &Twin,
    parts: &[TimeSeries],
    incoherent: Option<&IncoherentLines>,
) -> Option<Cand> {
    // every part's residual, simulated once; the lines are searched in every part (a
    // tone that falls on a force harmonic of one cut is hidden there, not in a cut at
    // another speed: tryout truth, a 298.7 Hz tone on the second spindle harmonic of
    // 8960 rpm was missed when only the longest part was searched), and each part's
    // tones are fitted on its own
    let residual: Vec<Option<AxisResiduals>> = parts.iter().map(|p| residuals(twin, p)).collect();
    let longest = (0..parts.len()).max_by_key(|&i| parts[i].len())?;
    let masked = ForceLines::of(&parts[longest]);
    let mut found: Vec<(Axis, f64)> = Vec::new();
    for (i, (ts, res)) in parts.iter().zip(&residual).enumerate() {
        let Some(res) = res else { continue };
        let own = (i != longest).then(|| ForceLines::of(ts));
        for (a, f) in part_tones(ts, res, own.as_ref().unwrap_or(&masked), incoherent) {
            // the other parts only recover a tone that a force line of the longest part
            // hides (else a part's own transient, a low mode rung by a cut's start, is a
            // tone: second generator, healthy cuts of seed 18, 23.5 Hz in the shorter cut)
            let fresh = !found
                .iter()
                .any(|(b, g)| *b == a && (g - f).abs() <= 2e-3 * f);
            if fresh && (i == longest || masked.forced_hz(f)) {
                found.push((a, f));
            }
        }
    }
    // the extended twin carries the tones fitted to the longest part
    let ts = &parts[longest];
    let res_longest = residual[longest].as_ref()?;
    let mut sines = Vec::new();
    let mut freqs_found = Vec::new();
    for (a, fhz) in found {
        let Some((ca, cb)) = (res_longest.iter())
            .find(|(b, _)| *b == a)
            .and_then(|(_, r)| tone(r, ts, fhz))
        else {
            continue;
        };
        sines.push(Sinusoid {
            freq_hz: fhz,
            axis: a,
            a: ca,
            b: cb,
        });
        freqs_found.push(fhz);
    }
    if sines.is_empty() {
        return None;
    }
    let strength = freqs_found
        .iter()
        .zip(&sines)
        .map(|(f, sn)| {
            incoherent
                .as_ref()
                .map_or(f64::INFINITY, |inc| inc.strength(sn.axis, *f))
        })
        .fold(f64::INFINITY, f64::min);
    // the held-out check: a vibration from outside keeps its frequencies but not its
    // phase from one record to the next (each record starts at its own time): each
    // record's held-out part is predicted with the tones fitted to its own building part
    let per_record: Vec<Twin> = parts
        .iter()
        .zip(&residual)
        .map(|(p, res)| {
            let mut t = twin.clone();
            if let Some(res) = res {
                for sn in &sines {
                    let r = res.iter().find(|(a, _)| *a == sn.axis);
                    if let Some((a, b)) = r.and_then(|(_, r)| tone(r, p, sn.freq_hz)) {
                        t.extensions.disturbance.push(Sinusoid { a, b, ..*sn });
                    }
                }
            }
            t
        })
        .collect();
    let mut ext = twin.clone();
    ext.extensions.disturbance.extend(sines);
    let mut d = Map::new();
    freqs_found.sort_by(f64::total_cmp);
    // one tone seen in several response axes is one frequency of the disturbance
    freqs_found.dedup_by(|b, a| (*b - *a).abs() <= 2e-3 * *a);
    d.insert("freq_hz".into(), json!(freqs_found));
    if strength.is_finite() {
        d.insert("incoherent_power_ratio".into(), json!(strength));
    }
    d.insert(
        "tones_held_out".into(),
        json!("each record's held-out part predicted with amplitude and phase fitted to its own building part (an outside vibration keeps its frequencies, not its phase, from one record to the next); the extended twin carries those of the longest record"),
    );
    Some(Cand {
        cause: Cause::Disturbance,
        chi: f64::NAN,
        twin: ext,
        details: d,
        per_record,
        local_chi: None,
        fitted_in_time: false,
    })
}

/// The force's own lines in a part (a periodic force, e.g. the tooth-passing and spindle
/// harmonics in milling): a residual peak there is the twin's error at a forced line, not
/// a vibration from outside. The forces' Hann magnitude spectrum, summed over the axes, on
/// the part's own zero-padded FFT lines.
struct ForceLines {
    mag: Vec<f64>,
    /// Line spacing \[Hz\].
    df: f64,
}

impl ForceLines {
    fn of(ts: &TimeSeries) -> Self {
        let n = ts.len();
        let nfft = n.next_power_of_two();
        let fft = FftPlanner::<f64>::new().plan_fft_forward(nfft);
        let window = crate::spectra::hann(n);
        let mut mag = vec![0.0; nfft / 2];
        for fa in Axis::ALL.iter().filter_map(|a| ts.force(*a)) {
            let mean = fa.iter().sum::<f64>() / n.max(1) as f64;
            let b = windowed_fft(fa, mean, &window, &*fft, nfft);
            mag.iter_mut()
                .zip(&b[..nfft / 2])
                .for_each(|(t, v)| *t += v.norm());
        }
        ForceLines {
            mag,
            df: 1.0 / (nfft as f64 * ts.dt),
        }
    }

    /// Whether line `i` stands 10× above the median of its ±64 lines.
    fn forced(&self, i: usize) -> bool {
        let w = 64usize;
        let hi = (i + w + 1).min(self.mag.len());
        if i >= hi {
            return false;
        }
        let mut loc: Vec<f64> = self.mag[i.saturating_sub(w)..hi].to_vec();
        loc.sort_by(f64::total_cmp);
        self.mag[i] > 10.0 * loc[loc.len() / 2]
    }

    /// Whether a line within ±2 lines (the Hann main lobe) of `f` Hz is forced.
    fn forced_hz(&self, f: f64) -> bool {
        let i = (f / self.df).round() as usize;
        (i.saturating_sub(2)..=i + 2).any(|j| self.forced(j))
    }
}

/// The tones from outside in one part's residual `res`, per response axis: narrow peaks
/// of the residual's spectrum, off the part's own force `lines`, whose response power
/// that is not coherent with the forces stands out ([`DISTURBANCE_MIN_STRENGTH`]) and
/// that persist through the part ([`PERSISTENT_MIN`]); at most 3 per axis.
fn part_tones(
    ts: &TimeSeries,
    res: &AxisResiduals,
    lines: &ForceLines,
    incoherent: Option<&IncoherentLines>,
) -> Vec<(Axis, f64)> {
    let n = ts.len();
    let nfft = n.next_power_of_two();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(nfft);
    let window = crate::spectra::hann(n);
    let mut out = Vec::new();
    // the evidence that a line comes from outside: the response power at it that is
    // not coherent with the measured forces (multiple coherence, Welch over all parts)
    // stands far above that of the neighbouring lines. A model error at a line the
    // force drives stays coherent with the force; a tone from outside does not.
    for (a, res) in res {
        let a = *a;
        let spec = windowed_fft(res, 0.0, &window, &*fft, nfft);
        let mag: Vec<f64> = spec[..nfft / 2].iter().map(|c| c.norm()).collect();
        let mut sorted = mag.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2].max(1e-300);
        // local maxima 30× above the median and as narrow as a pure tone (Hann main lobe
        // ±2 bins: 10× down at ±5 bins; a model error around a resonance is as wide as the
        // resonance), strongest first, at most 3
        let mut peaks: Vec<(f64, usize)> = (5..mag.len().saturating_sub(5))
            .filter(|&i| mag[i] > 30.0 * median && mag[i] >= mag[i - 1] && mag[i] >= mag[i + 1])
            .filter(|&i| mag[i] >= 10.0 * mag[i - 5].max(mag[i + 5]))
            .filter(|&i| !lines.forced(i))
            .map(|i| (mag[i], i))
            .collect();
        peaks.sort_by(|x, y| y.0.total_cmp(&x.0));
        peaks.truncate(3);
        for (_, i) in peaks {
            // parabolic interpolation of the peak on the log magnitude
            let (l, c, r) = (mag[i - 1].ln(), mag[i].ln(), mag[i + 1].ln());
            let delta = 0.5 * (l - r) / (l - 2.0 * c + r);
            let fhz = (i as f64 + delta) / (nfft as f64 * ts.dt);
            let strength = incoherent.map_or(f64::INFINITY, |inc| inc.strength(a, fhz));
            trace(|| {
                format!("disturbance: {a} line at {fhz:.2} Hz, incoherent power {strength:.1} x its neighbours")
            });
            if strength < DISTURBANCE_MIN_STRENGTH || tone(res, ts, fhz).is_none() {
                continue;
            }
            // a vibration from outside persists through the record; the free decay of a
            // resonance (the cut's start rings the low modes, not coherent with the
            // force over the record) dies out: the tone's amplitude in the second half
            // of the building part must stay near the first half's
            let amp = |r: &[f64]| tone(r, ts, fhz).map_or(0.0, |(a, b)| a.hypot(b));
            let (first, second) = (amp(&res[..n / 2]), amp(&res[n / 2..]));
            trace(|| {
                format!(
                    "disturbance: {a} line at {fhz:.2} Hz, amplitude second/first half {:.2}",
                    second / first.max(1e-300)
                )
            });
            if second >= PERSISTENT_MIN * first {
                out.push((a, fhz));
            }
        }
    }
    out
}

/// Per response axis, the measured response less the simulated one.
type AxisResiduals = Vec<(Axis, Vec<f64>)>;

/// The response of `ts` less `twin`'s simulation of it, per response axis, in the
/// record's response quantity.
fn residuals(twin: &Twin, ts: &TimeSeries) -> Option<AxisResiduals> {
    let y = simulate_as_measured(twin, ts).ok()?;
    Some(
        Axis::ALL
            .iter()
            .filter_map(|&a| {
                let m = ts.response(a)?;
                Some((a, m.iter().zip(&y[a.index()]).map(|(a, b)| a - b).collect()))
            })
            .collect(),
    )
}

/// Least-squares amplitude `(a, b)` of `a cos ωt + b sin ωt` at `fhz` in the residual
/// `res` of `ts`, on the absolute time base, as a displacement (the twin's output).
fn tone(res: &[f64], ts: &TimeSeries, fhz: f64) -> Option<(f64, f64)> {
    let w = 2.0 * PI * fhz;
    let (mut scc, mut sss, mut scs, mut syc, mut sys) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (k, r) in res.iter().enumerate() {
        let t = ts.t0 + k as f64 * ts.dt;
        let (c, s) = ((w * t).cos(), (w * t).sin());
        scc += c * c;
        sss += s * s;
        scs += c * s;
        syc += r * c;
        sys += r * s;
    }
    let det = scc * sss - scs * scs;
    if det.abs() < 1e-300 {
        return None;
    }
    let (ca, cb) = ((syc * sss - sys * scs) / det, (sys * scc - syc * scs) / det);
    let scale = if ts.response_kind == Some(ResponseKind::Acceleration) {
        -1.0 / (w * w)
    } else {
        1.0
    };
    Some((ca * scale, cb * scale))
}
