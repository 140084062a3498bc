//! The automatic decisions between the FRF estimate and the fit, made from the data and
//! kept with their evidence: which band is trustworthy, which channels carry a coherent
//! response, what excitation was recognised. The campaign fits what the plan says, and
//! the summary, the report and the twin file print it.
//!
//! * **Band.** Start from the lines the FRF has; keep the range where the force
//!   auto-spectrum is within 20 dB of its peak (the estimate reports it); then trim each
//!   end to where the coherence of the used channels (the largest per line, smoothed over
//!   ±1/12 octave) reaches the *trust level* `max(0.8, min(0.95, 1/(1 + 30·NSR)))`, with `NSR` the
//!   median noise-to-signal ratio `(1−γ²)/γ²` of the band: the band ends where the
//!   estimate is 30 times noisier than it typically is, but never demands more than
//!   γ² = 0.95 nor accepts less than 0.8. An isolated resonance outside that range whose
//!   peak line has coherence at the trust level or [`RESONANCE_PEAK_COHERENCE`] (and a
//!   neighbour at least 0.8) extends it to the lines around the peak with coherence ≥ 0.8:
//!   the fit weights the lines between by their coherence (a pose identified alone, or a
//!   campaign where most poses hold such a resonance; see [`plan_pose`]). `--fmin/--fmax`
//!   only narrow the result.
//! * **Channels.** With `n` averages, the coherence of a channel without any response
//!   to the force exceeds `x = 1 − 0.01^{1/(n−1)}` on 1 % of the lines (γ² of pure noise
//!   is Beta(1, n−1) distributed). A channel whose coherence exceeds `x` on fewer than
//!   [`MIN_INFORMATIVE_FRACTION`] of the band's lines carries no information: it is kept
//!   out of the fit (it cannot steer the common poles) and reported as not identified.
//!   A measured FRF file states `n` in a comment (`mtwin frf` writes it); when it does
//!   not, `n` is estimated from its least coherent channel if that one's median coherence
//!   is what pure noise gives ([`averages_from_noise_channel`]). Without coherence
//!   (measured FRF files without it, one full-record DFT) every channel is used.

use crate::axis::Channel;
use crate::frf::Frf;
pub use mtwin_core::plan::{Bands, ChannelDecision, MeasuredAs, PosePlan};

/// A channel is informative when its coherence is significant on at least this fraction
/// of the band's lines.
pub const MIN_INFORMATIVE_FRACTION: f64 = 0.2;
/// Coherence below which a band edge is never trusted.
pub const MIN_TRUST_COHERENCE: f64 = 0.8;
/// Coherence at which a band edge is always trusted (1 % noise-to-signal per average:
/// very clean data must not lose a mode at its band edge to a strict relative rule).
pub const MAX_TRUST_COHERENCE: f64 = 0.95;
/// A band edge is trusted while its noise-to-signal ratio stays within this factor of
/// the band's median.
pub const NSR_FACTOR: f64 = 30.0;

/// What the estimate says about the data, for [`plan_pose`].
#[derive(Debug, Clone, Default)]
pub struct EstimateFacts {
    /// Band where the force is within 20 dB of its peak.
    pub excitation_band_hz: Option<(f64, f64)>,
    /// Averages (hits, Welch segments, chirp periods).
    pub averages: Option<usize>,
    /// Averages behind each channel's estimate, the fewest over the channels
    /// ([`crate::spectra::FrfEstimate::averages_per_channel`]).
    pub averages_per_channel: Option<usize>,
    /// Description of the estimator.
    pub method: String,
    /// What the response sensor measured, when known.
    pub measured_as: Option<MeasuredAs>,
    /// Lines behind each coherence value when the coherence comes from the FRF's
    /// line-to-line scatter (a single chirp record) rather than from averages.
    pub coherence_dof: Option<usize>,
}

/// Mean of `v` over the lines within ±`octaves` of each line (two pointers over the
/// sorted frequencies, prefix sums).
pub(crate) fn smooth_octave(freqs: &[f64], v: &[f64], octaves: f64) -> Vec<f64> {
    let r = 2f64.powf(octaves);
    let mut pre = Vec::with_capacity(v.len() + 1);
    pre.push(0.0);
    for x in v {
        let last = *pre.last().unwrap_or(&0.0);
        pre.push(last + x);
    }
    let (mut a, mut b) = (0usize, 0usize);
    freqs
        .iter()
        .map(|&f| {
            while a < freqs.len() && freqs[a] < f / r {
                a += 1;
            }
            while b < freqs.len() && freqs[b] <= f * r {
                b += 1;
            }
            (pre[b] - pre[a]) / (b - a).max(1) as f64
        })
        .collect()
}

/// Coherence a channel without response exceeds on 1 % of its lines, with `n` averages.
pub fn null_coherence_99(n: usize) -> f64 {
    null_coherence(n, 0.01)
}

/// Coherence a channel without response exceeds on a share `p` of its lines, with `n`
/// averages: `1 - p^(1/(n-1))` (1 with a single average).
pub fn null_coherence(n: usize, p: f64) -> f64 {
    if n <= 1 {
        return 1.0;
    }
    1.0 - p.powf(1.0 / (n as f64 - 1.0))
}

/// Median coherence below which a channel of an FRF whose averages are not known is
/// taken for one without response ([`averages_from_noise_channel`]): a coherent channel's
/// median lies near 1 where the force excites it, pure noise's at `1 - 0.5^(1/(n-1))`,
/// 0.5 with 2 averages and less with more.
pub const NOISE_MEDIAN_COHERENCE: f64 = 0.5;

/// The averages behind an FRF that does not state them (a measured FRF file from another
/// tool), from its least coherent channel when that looks like pure noise: γ² of noise
/// is Beta(1, n−1), whose median `m = 1 − 0.5^{1/(n−1)}` gives `n = 1 + ln 0.5 / ln(1 − m)`.
/// The count, the channel and its median; `None` when every channel's median coherence
/// over `lines` is at least [`NOISE_MEDIAN_COHERENCE`] (then no channel is taken for
/// noise and every one is used).
pub fn averages_from_noise_channel(frf: &Frf, lines: &[usize]) -> Option<(usize, Channel, f64)> {
    let (ch, m) = frf
        .channels
        .iter()
        .filter_map(|c| {
            let g = c.coherence.as_ref()?;
            let mut v: Vec<f64> = lines.iter().filter_map(|&k| g.get(k).copied()).collect();
            if v.len() < 16 {
                return None;
            }
            v.sort_by(f64::total_cmp);
            Some((c.channel, v[v.len() / 2]))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    if !(m > 0.0 && m < NOISE_MEDIAN_COHERENCE) {
        return None;
    }
    let n = 1.0 + 0.5f64.ln() / (1.0 - m).ln();
    Some(((n.round() as usize).clamp(2, 1000), ch, m))
}

/// Decides band and channels for one pose (module docs). `forced` lists channels the
/// campaign keeps out whatever this pose says (decided over all poses); `user_band`
/// narrows the band; `isolated_resonances` lets an isolated coherent resonance extend the
/// trusted band (a pose identified alone; a campaign's poses get their plans without it,
/// and the campaign's one band moves to such resonances only when most poses hold one:
/// every pose's own extension moved the median edge by a few hertz, which flipped the
/// variant the campaign kept and cost the lumped random machine 2's measured poses 6
/// points, mean 95.6 -> 89.6 % vs the truth, worst pose 92 -> 65 %).
pub fn plan_pose(
    frf: &Frf,
    facts: &EstimateFacts,
    user_band: Option<(f64, f64)>,
    excluded: &[Channel],
    isolated_resonances: bool,
) -> PosePlan {
    let f = &frf.freqs_hz;
    let mut plan = PosePlan {
        excitation: facts.method.clone(),
        averages: facts.averages,
        averages_per_channel: facts
            .averages_per_channel
            .filter(|n| Some(*n) != facts.averages),
        measured_as: facts.measured_as,
        ..Default::default()
    };
    let (mut lo, mut hi) = (
        f.first().copied().unwrap_or(0.0),
        f.last().copied().unwrap_or(0.0),
    );
    plan.band_evidence
        .push(format!("FRF lines {lo:.1}-{hi:.1} Hz"));
    if let Some((a, b)) = facts.excitation_band_hz {
        if a.max(lo) < b.min(hi) {
            lo = lo.max(a);
            hi = hi.min(b);
            plan.band_evidence.push(if facts.coherence_dof.is_some() {
                format!(
                    "force within 40 dB of its peak (one sweep record, spectrum smoothed over \
                     ±1/12 octave): {a:.1}-{b:.1} Hz"
                )
            } else {
                format!("force within 20 dB of its peak: {a:.1}-{b:.1} Hz")
            });
        }
    }
    // channel decisions over the force band
    let in_band: Vec<usize> = (0..f.len()).filter(|&k| f[k] >= lo && f[k] <= hi).collect();
    let guessed = (facts.coherence_dof.or(facts.averages).is_none())
        .then(|| averages_from_noise_channel(frf, &in_band))
        .flatten();
    let x99 = facts
        .coherence_dof
        .or(facts.averages)
        .or(guessed.as_ref().map(|g| g.0))
        .map(null_coherence_99);
    let basis = match (facts.coherence_dof, facts.averages, &guessed) {
        (Some(_), _, _) => "coherence from the FRF's line-to-line scatter".to_string(),
        (None, None, Some((n, ch, m))) => format!(
            "{}: the file does not say; estimated from channel {ch}, whose median coherence \
             {m:.3} is what pure noise gives with that many",
            crate::axis::count(*n, "average")
        ),
        _ => crate::axis::count(facts.averages.unwrap_or(0), "average"),
    };
    let level = |c: &crate::frf::FrfChannel| c.h.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let top = frf.channels.iter().map(level).fold(0.0, f64::max);
    for c in &frf.channels {
        let decision = match (&c.coherence, x99) {
            _ if !(level(c) > 1e-9 * top) => ChannelDecision {
                channel: c.channel,
                used: false,
                significant_fraction: None,
                band_hz: None,
                reason: "not identified (the FRF is zero on every line)".into(),
            },
            _ if excluded.contains(&c.channel) => ChannelDecision {
                channel: c.channel,
                used: false,
                significant_fraction: None,
                band_hz: None,
                reason: "not identified (no coherent response at most poses of the campaign)"
                    .into(),
            },
            (Some(g), Some(x)) if x < 1.0 && !in_band.is_empty() => {
                let frac =
                    in_band.iter().filter(|&&k| g[k] > x).count() as f64 / in_band.len() as f64;
                let used = frac >= MIN_INFORMATIVE_FRACTION;
                ChannelDecision {
                    channel: c.channel,
                    used,
                    significant_fraction: Some(frac),
                    band_hz: None,
                    reason: if used {
                        format!(
                            "coherence above the noise-only level {x:.2} ({basis}) on {:.0} % of the lines",
                            100.0 * frac
                        )
                    } else {
                        format!(
                            "not identified (no coherent response): coherence above the noise-only level {x:.2} ({basis}) on only {:.0} % of the lines",
                            100.0 * frac
                        )
                    },
                }
            }
            _ => ChannelDecision {
                channel: c.channel,
                used: true,
                significant_fraction: None,
                band_hz: None,
                reason: "no coherence to judge by: used".into(),
            },
        };
        plan.channels.push(decision);
    }
    if plan.channels.iter().all(|c| !c.used) {
        // nothing passes: fit them all rather than nothing, and say so
        for c in &mut plan.channels {
            c.used = true;
            c.reason
                .push_str("; used anyway: no channel of this pose shows a coherent response");
        }
    }
    // coherence-trusted edges, from the used channels with coherence
    let used: Vec<&crate::frf::FrfChannel> = frf
        .channels
        .iter()
        .zip(&plan.channels)
        .filter(|(_, d)| d.used)
        .map(|(c, _)| c)
        .collect();
    if used.iter().any(|c| c.coherence.is_some()) && in_band.len() > 8 {
        let best: Vec<f64> = in_band
            .iter()
            .map(|&k| {
                used.iter()
                    .filter_map(|c| c.coherence.as_ref().map(|g| g[k]))
                    .fold(0.0, f64::max)
            })
            .collect();
        let fb: Vec<f64> = in_band.iter().map(|&k| f[k]).collect();
        if let Some(t) = trusted_range(&fb, &best) {
            // isolated well-coherent resonances outside the trusted range, per used channel
            let mut ext = Resonances {
                first: t.first,
                last: t.last,
                peaks: Vec::new(),
            };
            // (direct channels only: every mode of a force direction shows in its direct
            // channel, and a cross channel's peak in a noisy band is judged by it alone)
            for c in (used.iter())
                .filter(|c| c.channel.output == c.channel.input)
                .filter(|_| isolated_resonances)
            {
                if let Some(g) = &c.coherence {
                    let gb: Vec<f64> = in_band.iter().map(|&k| g[k]).collect();
                    let mb: Vec<f64> = in_band.iter().map(|&k| c.h[k].norm()).collect();
                    let e = coherent_resonances(&fb, &gb, &mb, t.first, t.last, t.trust);
                    ext.first = ext.first.min(e.first);
                    ext.last = ext.last.max(e.last);
                    for p in e.peaks {
                        if !ext.peaks.iter().any(|q| q.0 == p.0) {
                            ext.peaks.push(p);
                        }
                    }
                }
            }
            if fb[t.last] > fb[t.first] && (fb[ext.first] > lo || fb[ext.last] < hi) {
                lo = fb[t.first];
                hi = fb[t.last];
                plan.band_evidence.push(format!(
                    "coherence (smoothed over 1/6 octave) reaches the trust level {:.3} \
                     (median noise-to-signal {:.1e}) from {lo:.1} to {hi:.1} Hz",
                    t.trust, t.median_nsr
                ));
                if !ext.peaks.is_empty() {
                    ext.peaks.sort_by(|a, b| a.0.total_cmp(&b.0));
                    let list: Vec<String> = (ext.peaks.iter())
                        .map(|(f, g)| format!("{f:.1} Hz (coherence {g:.3})"))
                        .collect();
                    lo = fb[ext.first];
                    hi = fb[ext.last];
                    plan.band_evidence.push(format!(
                        "isolated resonance(s) coherent beyond the trust level outside that \
                         range: {}; band extended to {lo:.1}-{hi:.1} Hz (lines between are \
                         weighted by their coherence)",
                        list.join(", ")
                    ));
                }
            }
        }
    }
    if let Some((a, b)) = user_band {
        let (na, nb) = (lo.max(a), hi.min(b));
        if na < nb {
            lo = na;
            hi = nb;
            plan.band_evidence
                .push(format!("narrowed by --fmin/--fmax to {lo:.1}-{hi:.1} Hz"));
        } else {
            plan.band_evidence.push(format!(
                "--fmin/--fmax {a}-{b} Hz lies outside the trusted band: used as given"
            ));
            lo = a.max(f.first().copied().unwrap_or(a));
            hi = b.min(f.last().copied().unwrap_or(b));
        }
    }
    plan.band_hz = [lo, hi];
    channel_bands(frf, &mut plan, isolated_resonances);
    plan
}

/// Where a (smoothed) coherence is trustworthy: the first and last line reaching the
/// trust level, the level and the median noise-to-signal ratio it came from.
struct Trusted {
    first: usize,
    last: usize,
    trust: f64,
    median_nsr: f64,
}

/// The trust rule of the module docs on one coherence curve `g` over lines `fb`.
fn trusted_range(fb: &[f64], g: &[f64]) -> Option<Trusted> {
    if fb.len() <= 8 {
        return None;
    }
    let sm = smooth_octave(fb, g, 1.0 / 12.0);
    let mut nsr: Vec<f64> = sm
        .iter()
        .map(|&g| (1.0 - g.clamp(1e-6, 1.0 - 1e-9)) / g.clamp(1e-6, 1.0))
        .collect();
    nsr.sort_by(f64::total_cmp);
    let median_nsr = nsr[nsr.len() / 2];
    let trust =
        MIN_TRUST_COHERENCE.max((1.0 / (1.0 + NSR_FACTOR * median_nsr)).min(MAX_TRUST_COHERENCE));
    let first = sm.iter().position(|&g| g >= trust)?;
    let last = sm.iter().rposition(|&g| g >= trust)?;
    (last > first + 8).then_some(Trusted {
        first,
        last,
        trust,
        median_nsr,
    })
}

/// An isolated resonance's peak stands at least this factor above the lowest magnitude
/// within ±1/6 octave on each side (noise ripple on a mode's flank does not; vmachine's
/// 62 Hz mode's lower flank showed "peaks" at 44 and 46 Hz without it).
pub const RESONANCE_PROMINENCE: f64 = 1.5;

/// Coherence on an isolated resonance's peak line that lets it extend the band even when
/// the trust level is higher: with `n` averages the estimate's relative scatter there is
/// about `sqrt((1 − γ²)/(2nγ²))`, 7.5 % at γ² = 0.9 and 10 hits, and pure noise reaches it
/// with probability `0.1^(n−1)`. The second generator's 73 Hz mode, the largest
/// receptance peak of its machine, shows 0.87-0.95 on its peak line at most poses (1/f
/// accelerometer noise over ω² sinks its flanks), and the trust level 0.95 left it out.
pub const RESONANCE_PEAK_COHERENCE: f64 = 0.9;

/// The trusted range grown to the isolated resonances outside it, and those resonances.
struct Resonances {
    first: usize,
    last: usize,
    /// (peak frequency, raw coherence on the peak line)
    peaks: Vec<(f64, f64)>,
}

/// Isolated resonances outside the trusted lines `first..=last` of a channel (frequencies
/// `fb`, raw coherence `g`, magnitude `mag`) that its data hold with confidence: the
/// magnitude's maximum over ±1/6 octave and [`RESONANCE_PROMINENCE`] times the lowest
/// magnitude there on each side, coherence at least `trust` (or
/// [`RESONANCE_PEAK_COHERENCE`] when lower) on the peak line and
/// at least [`MIN_TRUST_COHERENCE`] on a neighbour. The range grows to the run of lines
/// around each such peak with coherence at least [`MIN_TRUST_COHERENCE`]. A mode whose
/// flanks sink into low-frequency sensor noise (1/f accelerometer noise divided by ω²)
/// has a coherent peak but no smoothed coherence at the trust level: left out, the twin
/// lacks a mode that its own impact test saw (second generator: a 73 Hz mode with
/// coherence 0.98 on its peak line, band starting at 132 Hz).
fn coherent_resonances(
    fb: &[f64],
    g: &[f64],
    mag: &[f64],
    first: usize,
    last: usize,
    trust: f64,
) -> Resonances {
    let mut out = Resonances {
        first,
        last,
        peaks: Vec::new(),
    };
    let r = 2f64.powf(1.0 / 6.0);
    let n = fb.len();
    let is_peak = |k: usize| {
        // the lines within ±1/6 octave (sorted frequencies: one index range, not a scan)
        let (a, b) = (
            fb.partition_point(|&x| x < fb[k] / r),
            fb.partition_point(|&x| x <= fb[k] * r),
        );
        let low = |side: &[f64]| side.iter().copied().fold(f64::INFINITY, f64::min);
        g[k] >= trust.min(RESONANCE_PEAK_COHERENCE)
            && ((k > 0 && g[k - 1] >= MIN_TRUST_COHERENCE)
                || (k + 1 < n && g[k + 1] >= MIN_TRUST_COHERENCE))
            && mag[a..b].iter().all(|&m| m <= mag[k])
            && mag[k] >= RESONANCE_PROMINENCE * low(&mag[a..k])
            && mag[k] >= RESONANCE_PROMINENCE * low(&mag[k + 1..b])
    };
    for k in (0..first).chain(last + 1..n) {
        if !is_peak(k) {
            continue;
        }
        let (mut a, mut b) = (k, k);
        while a > 0 && g[a - 1] >= MIN_TRUST_COHERENCE {
            a -= 1;
        }
        while b + 1 < n && g[b + 1] >= MIN_TRUST_COHERENCE {
            b += 1;
        }
        out.first = out.first.min(a);
        out.last = out.last.max(b);
        out.peaks.push((fb[k], g[k]));
    }
    out
}

/// Each used channel with a coherence gets its own trusted band inside the pose band when
/// the trust rule, applied to its coherence alone, ends it more than 5 % (in frequency)
/// inside: a weak cross channel is not judged where it is noise.
fn channel_bands(frf: &Frf, plan: &mut PosePlan, isolated_resonances: bool) {
    let [lo, hi] = plan.band_hz;
    let f = &frf.freqs_hz;
    let in_band: Vec<usize> = (0..f.len()).filter(|&k| f[k] >= lo && f[k] <= hi).collect();
    let fb: Vec<f64> = in_band.iter().map(|&k| f[k]).collect();
    for (c, d) in frf.channels.iter().zip(plan.channels.iter_mut()) {
        let Some(g) = c.coherence.as_ref().filter(|_| d.used) else {
            continue;
        };
        let gb: Vec<f64> = in_band.iter().map(|&k| g[k]).collect();
        let Some(t) = trusted_range(&fb, &gb) else {
            continue;
        };
        let (a, b) = if isolated_resonances && c.channel.output == c.channel.input {
            let mb: Vec<f64> = in_band.iter().map(|&k| c.h[k].norm()).collect();
            let e = coherent_resonances(&fb, &gb, &mb, t.first, t.last, t.trust);
            (fb[e.first], fb[e.last])
        } else {
            (fb[t.first], fb[t.last])
        };
        if a > lo * 1.05 || b < hi / 1.05 {
            d.band_hz = Some([a, b]);
            d.reason.push_str(&format!(
                "; trusted (coherence >= {:.2}) only in {a:.0}-{b:.0} Hz: judged there",
                t.trust
            ));
        }
    }
}

/// A cross channel steers the poles of a pose fit when its coherence is significant on at
/// least this fraction of the band's lines and trusted over the whole band.
pub const STEER_FRACTION: f64 = 0.9;

/// Whether a used channel steers the poles of its pose fit: a direct channel (response
/// along its force) always; a cross channel when its coherence is significant on
/// [`STEER_FRACTION`] of the band's lines and trusted over all of it (or when there is no
/// coherence to judge). The others get their numerators with those poles held: a cross
/// channel coherent in part of the band only must not pull the common poles towards its
/// noise (measured on the 18 poses of the lumped generator's campaign, each identified
/// alone: xx and yy 69-98 % vs the truth with the z and cross channels steering,
/// 93-98.6 % without; a campaign's tracking still lets all used channels steer, see
/// [`crate::campaign`]).
pub fn steers(d: &ChannelDecision) -> bool {
    d.used
        && (d.channel.output == d.channel.input
            || (d.band_hz.is_none() && d.significant_fraction.is_none_or(|f| f >= STEER_FRACTION)))
}

/// The used channels of `plan` that steer the poles ([`steers`]).
pub fn steering_channels(plan: &PosePlan) -> Vec<Channel> {
    (plan.channels.iter())
        .filter(|d| steers(d))
        .map(|d| d.channel)
        .collect()
}

/// Channels that carry no coherent response at most poses (at least half of the poses
/// where they were measured): the campaign leaves them out everywhere, so every pose
/// model has the same channels.
pub fn campaign_exclusions(plans: &[PosePlan]) -> Vec<Channel> {
    let mut all: Vec<Channel> = Vec::new();
    for p in plans {
        for c in &p.channels {
            if !all.contains(&c.channel) {
                all.push(c.channel);
            }
        }
    }
    all.into_iter()
        .filter(|ch| {
            let (mut seen, mut unused) = (0usize, 0usize);
            for p in plans {
                if let Some(d) = p.channels.iter().find(|c| c.channel == *ch) {
                    seen += 1;
                    if !d.used {
                        unused += 1;
                    }
                }
            }
            seen > 0 && 2 * unused >= seen
        })
        .collect()
}

/// Channels of `plan` (one pose of a campaign whose first plans are `plans`) that the
/// campaign keeps ([`campaign_exclusions`] did not leave them out) but this pose's data
/// show no coherent response in: marked used and said to be stored as zero here, so that
/// every pose model has the same channels (pose models with other channels than their
/// neighbours cannot be interpolated; numerators fitted to noise alone reached 10x the
/// measured FRF). Returned for the fit to leave out and the twin to fill with zeros.
/// None when no channel of the pose passed (then all are used anyway).
pub fn hold_campaign_channels(
    plan: &mut PosePlan,
    plans: &[PosePlan],
    excluded: &[Channel],
) -> Vec<Channel> {
    let mut held = Vec::new();
    if plan.channels.iter().all(|d| !d.used) {
        return held;
    }
    for d in plan.channels.iter_mut() {
        if !d.used && !excluded.contains(&d.channel) {
            let kept_at = (plans.iter())
                .filter(|p| p.channels.iter().any(|c| c.channel == d.channel && c.used))
                .count();
            d.used = true;
            d.reason = format!(
                "{}; kept for the campaign (coherent at {kept_at} of {} poses): stored as \
                 zero at this pose (below the noise)",
                d.reason
                    .replacen("not identified (no coherent response): ", "", 1),
                plans.len()
            );
            held.push(d.channel);
        }
    }
    held
}

/// `frf` with only `channels` (in its own order).
pub fn select_channels(frf: &Frf, channels: &[Channel]) -> Frf {
    Frf {
        freqs_hz: frf.freqs_hz.clone(),
        channels: frf
            .channels
            .iter()
            .filter(|c| channels.contains(&c.channel))
            .cloned()
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use crate::frf::FrfChannel;
    use num_complex::Complex64;

    /// A file that does not state its averages: a channel of pure noise (coherence drawn
    /// from Beta(1, n-1) with n = 5, a shuffled quantile grid) gives back n = 5 and is
    /// left out, while a coherent channel is used; with every channel coherent nothing is
    /// estimated and both are used.
    #[test]
    fn averages_not_stated_are_estimated_from_a_noise_only_channel() {
        let n_lines = 400;
        let mut lcg = crate::test_util::Lcg(7);
        let mut noise: Vec<f64> = (0..n_lines)
            .map(|k| 1.0 - ((k as f64 + 0.5) / n_lines as f64).powf(1.0 / 4.0))
            .collect();
        for k in (1..n_lines).rev() {
            let j = ((lcg.uniform() + 0.5) * (k + 1) as f64) as usize;
            noise.swap(k, j.min(k));
        }
        let chan = |o, g: Vec<f64>| FrfChannel {
            channel: Channel {
                output: o,
                input: Axis::X,
            },
            h: vec![Complex64::new(1e-7, 1e-8); n_lines],
            coherence: Some(g),
        };
        let freqs: Vec<f64> = (0..n_lines).map(|k| 10.0 + 5.0 * k as f64).collect();
        let mut frf = Frf {
            freqs_hz: freqs,
            channels: vec![chan(Axis::X, vec![0.99; n_lines]), chan(Axis::Z, noise)],
        };
        let lines: Vec<usize> = (0..n_lines).collect();
        let (n, ch, m) = averages_from_noise_channel(&frf, &lines).unwrap();
        assert_eq!((n, ch.output), (5, Axis::Z), "median {m}");
        let plan = plan_pose(&frf, &EstimateFacts::default(), None, &[], false);
        let used: Vec<bool> = plan.channels.iter().map(|c| c.used).collect();
        assert_eq!(used, [true, false], "{:?}", plan.channels);
        assert!(plan.channels[1]
            .reason
            .contains("estimated from channel zx"));
        frf.channels[1].coherence = Some(vec![0.9; n_lines]);
        assert!(averages_from_noise_channel(&frf, &lines).is_none());
        let plan = plan_pose(&frf, &EstimateFacts::default(), None, &[], false);
        assert!(plan.channels.iter().all(|c| c.used));
    }

    #[test]
    fn line_noise_scale_finds_scatter_the_coherence_misses() {
        // a smooth FRF with white scatter 3x the variance the coherence predicts
        let mut lcg = crate::test_util::Lcg(3);
        let n = 400;
        let h: Vec<Complex64> = (0..n)
            .map(|k| {
                let x = k as f64 / n as f64;
                Complex64::new(1.0 + x, -x * x)
                    + Complex64::new(lcg.uniform(), lcg.uniform()) * 0.06
            })
            .collect();
        // uniform(-0.5, 0.5) * 0.06 per part: variance 2 * 0.06² / 12
        let true_var = 2.0 * 0.06f64.powi(2) / 12.0;
        let scale = crate::campaign::line_noise_scale(&h, &vec![true_var / 3.0; n]);
        assert!(scale > 2.3 && scale < 3.9, "{scale}");
        // scatter as predicted: no scale
        let one = crate::campaign::line_noise_scale(&h, &vec![true_var; n]);
        assert!(one < 1.4, "{one}");
    }

    #[test]
    fn isolated_coherent_resonance_below_the_trusted_range_extends_the_band() {
        // a resonance at 73 Hz seen with coherence 0.98 on its peak line, then noisy lines
        // (smoothed coherence below the trust level) up to 130 Hz, then clean data
        let f: Vec<f64> = (1..=400).map(|k| 3.0 * k as f64).collect();
        let mut lcg = crate::test_util::Lcg(11);
        let g = |x: f64, peak: bool| -> f64 {
            match x {
                x if peak && (72.0..=72.5).contains(&x) => 0.98,
                x if peak && (x == 69.0 || x == 75.0 || x == 78.0) => 0.88,
                x if x < 130.0 => 0.2 + 0.5 * (lcg.uniform() + 0.5),
                _ => 0.9995,
            }
        };
        let mag = |x: f64| 1.0 / ((1.0 - (x / 72.0).powi(2)).powi(2) + 0.01).sqrt();
        let case = |peak: bool, alone: bool, lcg_g: &mut dyn FnMut(f64, bool) -> f64| -> PosePlan {
            let frf = Frf {
                freqs_hz: f.clone(),
                channels: vec![FrfChannel {
                    channel: Channel::new(Axis::X, Axis::X),
                    h: f.iter().map(|&x| Complex64::new(mag(x), 0.0)).collect(),
                    coherence: Some(f.iter().map(|&x| lcg_g(x, peak)).collect()),
                }],
            };
            let facts = EstimateFacts {
                excitation_band_hz: Some((3.0, 1200.0)),
                averages: Some(8),
                method: "impact".into(),
                ..Default::default()
            };
            plan_pose(&frf, &facts, None, &[], alone)
        };
        let mut gen = g;
        let with = case(true, true, &mut gen);
        assert!(
            with.band_hz[0] > 66.0 && with.band_hz[0] < 70.0,
            "{:?} {:?}",
            with.band_hz,
            with.band_evidence
        );
        assert!(
            with.band_evidence
                .iter()
                .any(|e| e.contains("isolated resonance")),
            "{:?}",
            with.band_evidence
        );
        // the same noise without a coherent peak: the band starts where the trust does
        let without = case(false, true, &mut gen);
        assert!(without.band_hz[0] >= 125.0, "{:?}", without.band_hz);
        // a pose of a campaign: the band is the trusted range
        let campaign = case(true, false, &mut gen);
        assert!(campaign.band_hz[0] >= 125.0, "{:?}", campaign.band_hz);
        assert!(!without
            .band_evidence
            .iter()
            .any(|e| e.contains("isolated resonance")));
    }

    #[test]
    fn null_coherence_level_matches_beta_tail() {
        // P(γ² > x) = (1 − x)^(n−1) for pure noise with n averages
        for n in [2usize, 5, 30] {
            let x = null_coherence_99(n);
            assert!(((1.0 - x).powf(n as f64 - 1.0) - 0.01).abs() < 1e-12);
        }
        assert_eq!(null_coherence_99(1), 1.0);
    }

    #[test]
    fn noise_channel_is_left_out_and_band_trimmed_to_trusted_coherence() {
        let f: Vec<f64> = (1..=1000).map(|k| k as f64).collect();
        let mut lcg = crate::test_util::Lcg(7);
        let direct: Vec<f64> = f
            .iter()
            .map(|&x| if x < 50.0 { 0.3 } else { 0.995 })
            .collect();
        let noise: Vec<f64> = f.iter().map(|_| (lcg.uniform() + 0.5).powi(4)).collect();
        let ch = |o, g: Vec<f64>| FrfChannel {
            channel: Channel::new(o, Axis::X),
            h: vec![Complex64::new(1.0, 0.0); f.len()],
            coherence: Some(g),
        };
        // a cross channel whose response sinks into the noise above 400 Hz
        let cross: Vec<f64> = f
            .iter()
            .map(|&x| match x {
                x if x < 50.0 => 0.3,
                x if x < 400.0 => 0.9,
                _ => 0.5,
            })
            .collect();
        let frf = Frf {
            freqs_hz: f.clone(),
            channels: vec![ch(Axis::X, direct), ch(Axis::Z, noise), ch(Axis::Y, cross)],
        };
        let facts = EstimateFacts {
            excitation_band_hz: Some((1.0, 900.0)),
            averages: Some(5),
            averages_per_channel: None,
            method: "impact".into(),
            measured_as: None,
            coherence_dof: None,
        };
        let p = plan_pose(&frf, &facts, None, &[], true);
        assert!(p.channels[0].used && !p.channels[1].used, "{p:?}");
        assert!(
            p.band_hz[0] > 45.0 && p.band_hz[0] < 60.0,
            "{:?}",
            p.band_hz
        );
        assert!((p.band_hz[1] - 900.0).abs() < 1.0);
        // the direct channel has the pose band; the cross channel its own, judged there
        assert_eq!(p.channels[0].band_hz, None);
        let b = p.channels[2].band_hz.expect("cross channel band");
        assert!(b[1] > 350.0 && b[1] < 400.0, "{b:?}");
        assert_eq!(p.bands((50.0, 900.0)).of(p.channels[2].channel).1, b[1]);
        // the user band only narrows
        let q = plan_pose(&frf, &facts, Some((100.0, 2000.0)), &[], true);
        assert_eq!(q.band_hz, [100.0, 900.0]);
    }
}
