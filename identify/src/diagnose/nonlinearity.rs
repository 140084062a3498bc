//! Cause `nonlinearity`: a mode that moves with the force level; a cubic modal stiffness on
//! it, or the twin linearised at the high force level.

use super::candidate::{dominant_axis, map_models, retune, Cand};
use super::evidence::{
    evidence, force_mag, holdout_fit, is_impact, level_evidence, level_units, twin_points, Split,
};
use super::{trace, Cause};
use crate::modal_update::Points;
use crate::model::ModalModel;
use crate::simulate::{force_rows, Hold};
use crate::timeseries::TimeSeries;
use crate::twin::Twin;
use serde_json::{json, Map};

/// [`cand_nonlinearity`] needs the FRFs of the two force levels to disagree around the
/// mode by at least this many times their variance (mean over the lines; about 1 for a
/// linear structure, 0-0.2 on the second generator's linear cases; the weakest cubic
/// modes of the vmachine milling table, Welch estimates from records at different speeds,
/// reach 3.3-4).
const LEVEL_DISAGREEMENT_MIN: f64 = 2.5;

/// [`cand_by_level_pairs`]' least disagreement between the two heaviest of three or more
/// force levels: on the second generator's linear control of its nonlinearity case (20
/// seeds, the same hits and noise without the cubic spring) that pair reached 1.2-2.6,
/// and 3.16 at one seed whose lighter pair disagreed more (3.89, see
/// [`LEVEL_PAIRS_OVER_LIGHTER`]); its cubic springs that move a mode beyond noise gave
/// 3.44-126 (those at the 73 Hz mode, 0.2 % shifts, 1.4-1.6 as their linear control).
/// Beyond it the levels differ by a nonlinearity even when the response centroid near
/// the mode barely moves (the centroid over ±3 half-power bandwidths takes in the
/// unmoved neighbours of a close group: seed 18, the saddle guide's 566 Hz mode 0.34 %
/// higher at 1200 N than at 300 N beside modes at 576 and 615 Hz: centroid +0.10 %,
/// disagreement 3.65).
const LEVEL_PAIRS_DISAGREEMENT_MIN: f64 = 3.0;

/// How many times the next lighter pair's disagreement the heaviest pair's must reach
/// at the mode ([`cand_by_level_pairs`]).
const LEVEL_PAIRS_OVER_LIGHTER: f64 = 1.5;

/// Mean over the lines within ±3 half-power bandwidths of `f0` (at least ±3 lines), of
/// every channel both point sets hold, of `|H_low − H_high|² / (σ_low² + σ_high²)`: how
/// far the FRFs measured at two force levels disagree, in units of their variance.
///
/// Hits a few milliseconds apart make records of different lengths, so the two levels'
/// lines differ; the high level's FRF is carried to the low level's lines through its
/// ratio to `model` (the twin), which is smooth where the FRF is not: linear interpolation
/// of the FRF itself across a resonance (2.5 Hz lines, a 121 Hz mode 7 Hz wide) misses by
/// a few percent, ten times the variance of 1000 N hits, and named a linear structure
/// hit at three force levels with ±10 ms jitter a nonlinearity (tryout truth, 11.3 x).
/// Near a zero of the model (an antiresonance) the FRF is interpolated as it is.
fn level_disagreement(
    low: &[Points],
    high: &[Points],
    f0: f64,
    zeta: f64,
    model: &ModalModel,
) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for pl in low {
        let Some(ph) = high.iter().find(|p| p.channel == pl.channel) else {
            continue;
        };
        let spacing = |f: &[f64]| {
            f.windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min)
        };
        let (dl, dh) = (spacing(&pl.freqs_hz), spacing(&ph.freqs_hz));
        let half = (3.0 * zeta * f0).max(3.0 * dl.max(dh));
        for (i, &f) in pl.freqs_hz.iter().enumerate() {
            if (f - f0).abs() > half {
                continue;
            }
            // the high-force FRF at f: linear between its two neighbouring lines (the two
            // levels' records may differ in length, so in line spacing)
            let Some(j) = ph.freqs_hz.windows(2).position(|w| w[0] <= f && f <= w[1]) else {
                continue;
            };
            let (fa, fb) = (ph.freqs_hz[j], ph.freqs_hz[j + 1]);
            if fb - fa > 2.0 * dh {
                continue; // a gap (lines dropped for coherence)
            }
            let t = (f - fa) / (fb - fa);
            let linear = (
                ph.h[j] * (1.0 - t) + ph.h[j + 1] * t,
                ph.sigma[j] * (1.0 - t) + ph.sigma[j + 1] * t,
            );
            let (h, sh) = (model.channel_index(pl.channel))
                .and_then(|ci| {
                    let (ma, mb, mf) = (
                        model.eval_hz(ci, fa),
                        model.eval_hz(ci, fb),
                        model.eval_hz(ci, f),
                    );
                    let (na, nb, nf) = (ma.norm(), mb.norm(), mf.norm());
                    (na.min(nb).min(nf) > 0.2 * na.max(nb).max(nf)).then(|| {
                        (
                            mf * (ph.h[j] / ma * (1.0 - t) + ph.h[j + 1] / mb * t),
                            nf * (ph.sigma[j] / na * (1.0 - t) + ph.sigma[j + 1] / nb * t),
                        )
                    })
                })
                .unwrap_or(linear);
            let var = pl.sigma[i].powi(2) + sh * sh;
            if var > 0.0 {
                sum += (pl.h[i] - h).norm_sqr() / var;
                n += 1;
            }
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// Records at clearly different force levels (peak force ratio ≥ 2): each mode's
/// frequency and damping refitted on the low-force and on the high-force records; the mode
/// that moves most with the force level names the nonlinearity (frequency up = hardening,
/// down = softening, damping down with little frequency change = friction). The extension
/// is a cubic modal stiffness on that mode ([`fit_cubic`]; `simulate` and the FMU carry
/// it) when it explains both force levels better than the linear twin, else (and for
/// friction) the twin linearised at the high force level.
pub(super) fn cand_nonlinearity(
    twin: &Twin,
    parts: &[TimeSeries],
    band: (f64, f64),
    min_coh: f64,
    pose: [f64; 3],
    min_ratio: f64,
) -> Option<Cand> {
    let parts = &level_units(parts);
    let peak = |ts: &TimeSeries| force_mag(ts).iter().fold(0.0f64, |a, v| a.max(*v));
    let peaks: Vec<f64> = parts.iter().map(peak).collect();
    let (lo, hi) = peaks
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(*p), b.max(*p)));
    if !(lo > 0.0 && hi >= min_ratio * lo) {
        return None;
    }
    trace(|| format!("nonlinearity: force peaks {lo:.1}..{hi:.1} N"));
    let levels = force_level_clusters(&peaks);
    if levels.len() >= 3 && parts.iter().all(is_impact) {
        return cand_by_level_pairs(twin, parts, &peaks, &levels, band, pose);
    }
    let split = (lo * hi).sqrt();
    let group = |high: bool| -> Vec<TimeSeries> {
        parts
            .iter()
            .zip(&peaks)
            .filter(|(_, p)| (**p >= split) == high)
            .map(|(t, _)| t.clone())
            .collect()
    };
    let (low_recs, high_recs) = (group(false), group(true));
    let m0 = twin.model_at(pose).ok()?;
    let pts_of = |recs: &[TimeSeries]| -> Option<Vec<Points>> {
        let e = evidence(recs).ok()?;
        let p = twin_points(&e, twin, band, min_coh);
        (!p.is_empty()).then_some(p)
    };
    let (pl, ph) = (pts_of(&low_recs)?, pts_of(&high_recs)?);
    // per mode: relative frequency and damping change from light to hard hits
    let mut moves: Vec<(usize, f64, f64, ModalModel, ModalModel)> = Vec::new();
    for k in 0..m0.modes.len() {
        let (Ok(a), Ok(b)) = (retune(&m0, k, &pl), retune(&m0, k, &ph)) else {
            continue;
        };
        let df = b.model.modes[k].wn / a.model.modes[k].wn - 1.0;
        let dz = b.model.modes[k].zeta / a.model.modes[k].zeta - 1.0;
        // a retune that jumps to another resonance or smears a mode out (a weak mode of
        // the other axis, a close pair) is no move of this mode
        let moved_off = |m: &ModalModel| {
            let r = m.modes[k].wn / m0.modes[k].wn;
            let z = m.modes[k].zeta / m0.modes[k].zeta;
            !(0.8..=1.25).contains(&r) || !(0.25..=4.0).contains(&z)
        };
        if moved_off(&a.model) || moved_off(&b.model) {
            trace(|| format!("nonlinearity: mode {k}: retune left the mode (not a move)"));
            continue;
        }
        moves.push((k, df, dz, a.model, b.model));
    }
    for (k, df, dz, _, _) in &moves {
        trace(|| {
            format!(
                "nonlinearity: mode {k}: frequency {:+.3} %, damping {:+.1} %",
                100.0 * df,
                100.0 * dz
            )
        });
    }
    // the scatter of the frequency moves: most modes are linear, their moves are noise
    let med_df = {
        let mut v: Vec<f64> = moves.iter().map(|m| m.1.abs()).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    // the mode whose FREQUENCY moves most (≥ 0.5 %, or ≥ 0.15 % and 10× the median move of
    // all modes: well above their scatter); a neighbour it pushes changes its
    // damping more than its frequency. Without a frequency move, a damping drop ≥ 20 %
    // under hard hits is friction.
    let by_f = moves
        .iter()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .filter(|m| m.1.abs() >= 0.005 || (m.1.abs() >= 0.0015 && m.1.abs() >= 10.0 * med_df));
    let by_z = || {
        moves
            .iter()
            .filter(|m| m.2 <= -0.2)
            .min_by(|a, b| a.2.total_cmp(&b.2))
    };
    let (k, score, low, high) = match by_f.or_else(by_z) {
        Some((k, df, dz, a, b)) => (*k, df.abs().max(0.1 * dz.abs()), a.clone(), b.clone()),
        None => return None,
    };
    trace(|| {
        format!(
            "nonlinearity: mode {k} score {score:.4}: {:.2} -> {:.2} Hz",
            low.modes[k].freq_hz(),
            high.modes[k].freq_hz()
        )
    });
    // model-free evidence: the FRFs measured at the two force levels must themselves
    // disagree around the mode beyond their variance (retunes of a model that misses the
    // data for another reason -- a new mode, a changed structure -- move by chance)
    let disagreement = level_disagreement(&pl, &ph, low.modes[k].freq_hz(), low.modes[k].zeta, &m0);
    trace(|| {
        format!("nonlinearity: per-level FRFs around mode {k} disagree by {disagreement:.2} x their variance")
    });
    if disagreement < LEVEL_DISAGREEMENT_MIN {
        return None;
    }
    let df = high.modes[k].wn / low.modes[k].wn - 1.0;
    let dz = high.modes[k].zeta / low.modes[k].zeta - 1.0;
    let kind = if df.abs() >= 0.002 {
        if df > 0.0 {
            "hardening"
        } else {
            "softening"
        }
    } else if dz < 0.0 {
        "friction"
    } else {
        "softening"
    };
    build_candidate(twin, &m0, k, (&low, &high), kind, &high_recs, parts, split)
}

/// The hit units' force levels when the test was run at distinct levels: the units
/// (indices into `peaks`) sorted by peak force, a new level wherever the next peak is at
/// least [`LEVEL_GAP`] times the last (hits of one level scatter less).
fn force_level_clusters(peaks: &[f64]) -> Vec<Vec<usize>> {
    let mut idx: Vec<usize> = (0..peaks.len()).filter(|&i| peaks[i] > 0.0).collect();
    idx.sort_by(|&a, &b| peaks[a].total_cmp(&peaks[b]));
    let mut out: Vec<Vec<usize>> = Vec::new();
    for i in idx {
        match out.last_mut() {
            Some(l) if peaks[i] < LEVEL_GAP * peaks[*l.last().unwrap_or(&i)] => l.push(i),
            _ => out.push(vec![i]),
        }
    }
    out
}

/// Ratio between consecutive sorted hit peaks that starts a new force level.
const LEVEL_GAP: f64 = 1.5;

/// Hits at three or more distinct force levels: the FRF of each level with standard
/// errors from the sensor's noise ([`level_evidence`]; a level may hold one or two hits,
/// and the lightest may be buried in noise at a low mode). The twin's mode around which
/// the two heaviest levels disagree most beyond their variance (at least
/// [`LEVEL_PAIRS_DISAGREEMENT_MIN`], and [`LEVEL_PAIRS_OVER_LIGHTER`] times the next
/// lighter pair there) is the nonlinear one; the response centroid near it on each of the
/// two levels' FRF says how it moves (up with the force level = hardening). Pooling the levels in two groups would mix them (a middle level with the
/// hard one blurs both and their coherence).
fn cand_by_level_pairs(
    twin: &Twin,
    parts: &[TimeSeries],
    peaks: &[f64],
    levels: &[Vec<usize>],
    band: (f64, f64),
    pose: [f64; 3],
) -> Option<Cand> {
    let m0 = twin.model_at(pose).ok()?;
    let recs_of =
        |l: &[usize]| -> Vec<TimeSeries> { l.iter().map(|&i| parts[i].clone()).collect() };
    let level_peak = |l: &[usize]| l.iter().map(|&i| peaks[i]).fold(0.0, f64::max);
    let pts: Vec<Vec<Points>> = levels
        .iter()
        .map(|l| {
            level_evidence(&recs_of(l), parts)
                .map(|e| level_points(&e, &m0, band))
                .unwrap_or_default()
        })
        .collect();
    trace(|| {
        format!(
            "nonlinearity: {} force levels, peaks {:.0?} N",
            levels.len(),
            levels.iter().map(|l| level_peak(l)).collect::<Vec<_>>()
        )
    });
    // a stiffness that grows with the deflection (a cubic spring) moves a mode with the
    // square of the amplitude: the two heaviest levels differ most (16 times the two
    // lighter ones' shift for 300 and 1200 N after 60 N), and they have the best
    // signal-to-noise ratio; a pair with the lightest level is where noise disagrees
    // (second generator's linear control of this case, 20 seeds, any pair at 2.5 x:
    // 5 `nonlinearity`, all at 73-137 Hz, 4 of them with the 60 N level)
    let n = levels.len();
    let (a, b) = (n - 2, n - 1);
    let (dis, k) = (m0.modes.iter().enumerate())
        .filter(|(_, m)| m.freq_hz() >= band.0 && m.freq_hz() <= band.1)
        .map(|(k, m)| {
            (
                level_disagreement(&pts[a], &pts[b], m.freq_hz(), m.zeta, &m0),
                k,
            )
        })
        .max_by(|x, y| x.0.total_cmp(&y.0))?;
    // and more than the next lighter pair does at that mode: a cubic spring's shift
    // between 60 and 300 N is 6 % of the one between 300 and 1200 N, while noise (1/f
    // at a low mode, the lightest level's) makes every pair disagree alike (linear
    // control seed 19: 3.89 between 60 and 300 N, 3.16 between 300 and 1200 N at 74 Hz)
    let (fk, zk) = (m0.modes[k].freq_hz(), m0.modes[k].zeta);
    let lighter = level_disagreement(&pts[n - 3], &pts[a], fk, zk, &m0);
    trace(|| {
        format!(
            "nonlinearity: levels {a} and {b} disagree most around mode {k} ({fk:.1} Hz): \
             {dis:.2} x their variance, levels {} and {a} there {lighter:.2} x",
            n - 3
        )
    });
    if dis < LEVEL_PAIRS_DISAGREEMENT_MIN || dis < LEVEL_PAIRS_OVER_LIGHTER * lighter {
        return None;
    }
    // how the force level moves the mode: the centroid of the response power above the
    // noise near it, per level (model-free; a refit of one mode of a close pair on a few
    // noisy hits jumps between the two)
    let f0 = m0.modes[k].freq_hz();
    let half = (3.0 * m0.modes[k].zeta * f0).max(0.05 * f0);
    let (ca, cb) = (
        centroid(&pts[a], f0 - half, f0 + half)?,
        centroid(&pts[b], f0 - half, f0 + half)?,
    );
    let df = cb / ca - 1.0;
    trace(|| {
        format!(
            "nonlinearity: mode {k}: response centroid {ca:.2} Hz ({:.0} N) -> {cb:.2} Hz ({:.0} N), {:+.2} %",
            level_peak(&levels[a]),
            level_peak(&levels[b]),
            100.0 * df
        )
    });
    let kind = if df > 0.0 { "hardening" } else { "softening" };
    // the light level as the twin, the hard one as the twin with the mode moved
    let low = m0.clone();
    let mut high = m0.clone();
    high.modes[k].wn *= 1.0 + df;
    let split = (level_peak(&levels[a]) * level_peak(&levels[b])).sqrt();
    let mut c = build_candidate(
        twin,
        &m0,
        k,
        (&low, &high),
        kind,
        &recs_of(&levels[b]),
        parts,
        split,
    )?;
    c.details.insert("level_disagreement".into(), json!(dis));
    c.details.insert(
        "force_levels_compared_n".into(),
        json!([level_peak(&levels[a]), level_peak(&levels[b])]),
    );
    c.details
        .insert("response_centroid_hz".into(), json!([ca, cb]));
    Some(c)
}

/// Centroid \[Hz\] of the response power above the noise, `Σ f (|H|² − σ²)⁺ / Σ (|H|² − σ²)⁺`,
/// over the lines of `pts` between `lo` and `hi`.
fn centroid(pts: &[Points], lo: f64, hi: f64) -> Option<f64> {
    let (mut sw, mut swf) = (0.0, 0.0);
    for p in pts {
        for ((f, h), s) in p.freqs_hz.iter().zip(&p.h).zip(&p.sigma) {
            if *f >= lo && *f <= hi {
                let w = (h.norm_sqr() - s * s).max(0.0);
                sw += w;
                swf += w * f;
            }
        }
    }
    (sw > 0.0).then(|| swf / sw)
}

/// Every channel of `ev` that `model` holds, its lines in `band` whose standard error
/// (from the sensor noise) is known, floored at 0.5 % of the point.
fn level_points(
    ev: &super::evidence::Evidence,
    model: &ModalModel,
    band: (f64, f64),
) -> Vec<Points> {
    ev.channels
        .iter()
        .zip(&ev.sigma)
        .filter(|((c, _, _), sig)| model.channel_index(*c).is_some() && !sig.is_empty())
        .map(|((c, h, _), sig)| {
            let keep: Vec<usize> = (0..ev.freqs_hz.len())
                .filter(|&i| ev.freqs_hz[i] >= band.0 && ev.freqs_hz[i] <= band.1)
                .filter(|&i| sig[i].is_finite() && sig[i] > 0.0)
                .collect();
            Points {
                channel: *c,
                freqs_hz: keep.iter().map(|&i| ev.freqs_hz[i]).collect(),
                h: keep.iter().map(|&i| h[i]).collect(),
                sigma: keep
                    .iter()
                    .map(|&i| sig[i].max(5e-3 * h[i].norm()))
                    .collect(),
            }
        })
        .filter(|p| !p.h.is_empty())
        .collect()
}

/// The nonlinearity candidate of mode `k`, refitted as `low` and `high` at a light and a
/// hard force level (the hard level's records `high_recs`), from the build records `parts`.
#[allow(clippy::too_many_arguments)]
fn build_candidate(
    twin: &Twin,
    m0: &ModalModel,
    k: usize,
    (low, high): (&ModalModel, &ModalModel),
    kind: &str,
    high_recs: &[TimeSeries],
    parts: &[TimeSeries],
    split: f64,
) -> Option<Cand> {
    let df = high.modes[k].wn / low.modes[k].wn - 1.0;
    let mut d = Map::new();
    // the extension: a cubic modal stiffness when it explains both force levels better than
    // the linear twin does, else the twin linearised at the high force level
    let cubic = if kind == "friction" {
        None
    } else {
        fit_cubic(twin, m0, k, df, high_recs, parts)
    };
    let ext = match cubic {
        Some((t, kappa, fit_lin, fit_cubic)) => {
            d.insert("kappa".into(), json!(kappa));
            d.insert(
                "extension".into(),
                json!(format!(
                    "cubic modal stiffness on mode {} ({:.0} Hz, modes numbered from 1): \
                     q'' + 2 zeta w q' + w^2 q (1 + kappa q^2) = F, kappa = {kappa:.4e} (in mtwin \
                     simulate and the FMU); build-data fit {fit_lin:.2} % -> {fit_cubic:.2} %",
                    k + 1,
                    m0.modes[k].freq_hz()
                )),
            );
            t
        }
        None => map_models(twin, |m| {
            let mut m = m.clone();
            crate::modal_update::apply_change(&mut m, m0, high, 1.0);
            m
        }),
    };
    d.insert("freq_hz".into(), json!(m0.modes[k].freq_hz()));
    d.insert("kind".into(), json!(kind));
    d.insert("mode".into(), json!(k));
    d.insert("freq_low_force_hz".into(), json!(low.modes[k].freq_hz()));
    d.insert("freq_high_force_hz".into(), json!(high.modes[k].freq_hz()));
    d.insert("damping_low_force".into(), json!(low.modes[k].zeta));
    d.insert("damping_high_force".into(), json!(high.modes[k].zeta));
    d.insert("force_split_n".into(), json!(split));
    d.insert("axis".into(), json!(dominant_axis(m0, k).to_string()));
    Some(Cand {
        cause: Cause::Nonlinearity,
        chi: f64::NAN,
        twin: ext,
        details: d,
        per_record: Vec::new(),
        local_chi: None,
        fitted_in_time: false,
    })
}

/// Cubic modal stiffness κ on mode `k` (sign from the frequency move `df` under hard
/// hits): started from the backbone `ω_eff² = ω² (1 + ¾ κ A²)` at the largest modal
/// amplitude `A` the hard records reach, then a golden-section search over κ (κ0/3 to
/// 100 κ0) for the best time fit on all build records (light and hard). Returns the
/// extended twin, κ and the build fits of the linear and the cubic twin, when the cubic
/// term gains.
fn fit_cubic(
    twin: &Twin,
    m0: &ModalModel,
    k: usize,
    df: f64,
    high: &[TimeSeries],
    build: &[TimeSeries],
) -> Option<(Twin, f64, f64, f64)> {
    use crate::simulate::Simulator;
    // largest modal amplitude of mode k under the hard hits (linear simulation)
    let mut amp: f64 = 0.0;
    for ts in high {
        let f = force_rows(ts);
        let mut sim = Simulator::new(m0.modes.len(), Hold::Foh);
        for i in 1..f.len() {
            sim.step(m0, &f[i - 1], &f[i], ts.dt);
            for j in 0..3 {
                amp = amp.max(sim.state()[k * 3 + j][0].abs());
            }
        }
    }
    if !(amp > 0.0 && amp.is_finite()) {
        return None;
    }
    let kappa0 = ((1.0 + df).powi(2) - 1.0) / (0.75 * amp * amp);
    if !kappa0.is_finite() || kappa0 == 0.0 {
        return None;
    }
    let splits: Vec<Split> = build
        .iter()
        .map(|t| Split {
            full: t.clone(),
            holdout_start: 0,
        })
        .collect();
    let with = |kappa: f64| {
        let mut t = twin.clone();
        t.extensions.cubic.retain(|c| c.mode != k);
        t.extensions
            .cubic
            .push(crate::twin::CubicStiffness { mode: k, kappa });
        t
    };
    let fit_of =
        |x: f64| holdout_fit(&with(kappa0 * x.exp()), &splits).unwrap_or(f64::NEG_INFINITY);
    let fit_lin = holdout_fit(twin, &splits).ok()?;
    // golden section on ln(κ/κ0) in [−ln 3, ln 100]: the measured shift averages the
    // decaying amplitude of the hits while A is their largest, so κ0 is low
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (-(3f64.ln()), 100f64.ln());
    let (mut c, mut e) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fe) = (fit_of(c), fit_of(e));
    for _ in 0..16 {
        if fc > fe {
            b = e;
            e = c;
            fe = fc;
            c = b - g * (b - a);
            fc = fit_of(c);
        } else {
            a = c;
            c = e;
            fc = fe;
            e = a + g * (b - a);
            fe = fit_of(e);
        }
    }
    let (x, best) = if fc > fe { (c, fc) } else { (e, fe) };
    trace(|| {
        format!(
            "nonlinearity: cubic on mode {k}: amplitude {amp:.3e}, kappa0 {kappa0:.3e}, best x {:.3} -> fit {fit_lin:.2} -> {best:.2} %",
            x.exp()
        )
    });
    (best > fit_lin).then(|| (with(kappa0 * x.exp()), kappa0 * x.exp(), fit_lin, best))
}
