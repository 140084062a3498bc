//! Stabilization diagram and the number of physical modes (what MATLAB `modalsd` does,
//! paper section 2.2).
//!
//! The poles of every model order come from one poly-reference least-squares
//! complex-frequency estimator (pLSCF, the PolyMAX family): a common denominator
//! `D(z) = Σ αⱼ zʲ` with real coefficients, `z = exp(jω Ts)`, `Ts = 1 / (2 f_max)`,
//! fitted to all channels at once. Because the basis is a Fourier basis, the normal
//! equations are Toeplitz: they are built once for the highest order from `O(N n)` sums,
//! and the numerators are eliminated channel by channel (the "reduced normal
//! equations"). The matrices of any lower order are leading blocks of the highest-order
//! ones, so every order costs one small solve plus the roots of its denominator.
//!
//! A pole is *stable in frequency* (damping) when a pole of the previous order lies within
//! [`StabilizationOptions::tol_freq`] ([`StabilizationOptions::tol_damping`]). Poles that
//! stay stable in both over [`StabilizationOptions::min_stable_orders`] consecutive orders,
//! have a physical damping ratio and lie where the data are usable (weight > 0, i.e. good
//! coherence) are the *physical modes* ([`StabilizationDiagram::physical`]).
//!
//! The orders run from 2 up to [`StabilizationOptions::max_order`], but the diagram stops
//! earlier once it has gone [`StabilizationOptions::quiet_orders`] orders without a new
//! physical mode and its order is at least [`MIN_TOP_ORDER`] and four times the number of
//! physical modes (twice the poles they need): beyond that the extra orders only add
//! computational poles, and their roots cost O(n³) each (set `quiet_orders = 0` for every
//! order up to the top).

use crate::eigen;
use crate::error::{Error, Result};
use crate::frf::Frf;
use crate::linalg;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// The diagram never stops early below this order (see the module docs).
pub const MIN_TOP_ORDER: usize = 32;

/// Settings of the stabilization diagram.
#[derive(Debug, Clone, PartialEq)]
pub struct StabilizationOptions {
    /// Highest denominator order (number of poles, even). Orders 2, 4, … up to it are
    /// computed. Clamped to what the number of lines supports.
    pub max_order: usize,
    /// Relative frequency tolerance between consecutive orders (default 1 %).
    pub tol_freq: f64,
    /// Relative damping tolerance between consecutive orders (default 5 %).
    pub tol_damping: f64,
    /// A pole is physical when it is stable in frequency and damping over at least this
    /// many consecutive orders (default 4).
    pub min_stable_orders: usize,
    /// Poles with a larger damping ratio are never physical (default 0.2).
    pub max_damping: f64,
    /// Stop below `max_order` after this many orders without a new physical mode (at an
    /// order of at least [`MIN_TOP_ORDER`] and four times the physical modes); 0 = never
    /// stop early (default 24).
    pub quiet_orders: usize,
}

impl Default for StabilizationOptions {
    fn default() -> Self {
        StabilizationOptions {
            max_order: 64,
            tol_freq: 0.01,
            tol_damping: 0.05,
            min_stable_orders: 4,
            max_damping: 0.2,
            quiet_orders: 24,
        }
    }
}

/// One pole of one order of the diagram (the one with positive imaginary part).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagramPole {
    /// Natural frequency |s| / 2π \[Hz\].
    pub f_hz: f64,
    /// Damping ratio −Re(s) / |s| (negative for an unstable pole).
    pub zeta: f64,
    /// The nearest pole of the previous order lies within the frequency tolerance.
    pub stable_freq: bool,
    /// … and within the damping tolerance.
    pub stable_damping: bool,
    /// Number of consecutive orders (ending here) over which this pole was stable in both,
    /// counting this one; 1 for a new pole.
    pub stable_orders: usize,
    /// The pole lies inside the fitted band where the data are usable (weight > 0).
    pub in_good_band: bool,
    /// Identifier of the chain of poles linked across orders.
    pub chain: usize,
}

/// All poles of one model order.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderPoles {
    /// Denominator order (number of poles).
    pub order: usize,
    /// Poles with positive imaginary part, sorted by frequency.
    pub poles: Vec<DiagramPole>,
}

/// A mode judged physical from the diagram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicalMode {
    /// Natural frequency \[Hz\] (at the highest order of its chain).
    pub f_hz: f64,
    /// Damping ratio.
    pub zeta: f64,
    /// Longest run of consecutive stable orders.
    pub stable_orders: usize,
}

/// The stabilization diagram: poles per order and the physical modes read from it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StabilizationDiagram {
    /// Poles of each computed order, lowest first.
    pub orders: Vec<OrderPoles>,
    /// The physical modes, sorted by frequency.
    pub physical: Vec<PhysicalMode>,
}

impl StabilizationDiagram {
    /// Number of physical modes (the automatic model order in pole pairs).
    pub fn n_physical(&self) -> usize {
        self.physical.len()
    }

    /// Natural frequencies (Hz) of the physical modes, ascending.
    pub fn stable_freqs_hz(&self) -> Vec<f64> {
        self.physical.iter().map(|m| m.f_hz).collect()
    }
}

/// Roots of a real polynomial, `coeffs[0]` the coefficient of the highest power
/// (numpy `roots` convention): eigenvalues of the balanced companion matrix (as numpy
/// and MATLAB `roots`). Leading zeros are ignored; a constant polynomial has no roots.
pub fn poly_roots(coeffs: &[f64]) -> Vec<Complex64> {
    let first = coeffs.iter().position(|c| *c != 0.0);
    let Some(first) = first else {
        return Vec::new();
    };
    let c = &coeffs[first..];
    let n = c.len() - 1;
    if n == 0 {
        return Vec::new();
    }
    let monic: Vec<f64> = c[1..].iter().map(|v| v / c[0]).collect();
    eigen::companion_roots(&monic)
}

/// Computes the pLSCF stabilization diagram of `frf` (all channels share the poles).
///
/// `weights[c][k]` is the amplitude weight of channel `c` at line `k` (0 = line not
/// usable, e.g. low coherence). Use it on a band-limited FRF ([`Frf::band`]).
pub fn diagram(
    frf: &Frf,
    weights: &[Vec<f64>],
    opts: &StabilizationOptions,
) -> Result<StabilizationDiagram> {
    let nf = frf.freqs_hz.len();
    if frf.channels.is_empty() || nf < 4 {
        return Err(Error::BadInput(
            "stabilization diagram: need at least one channel and 4 frequency lines".into(),
        ));
    }
    if weights.len() != frf.channels.len() || weights.iter().any(|w| w.len() != nf) {
        return Err(Error::BadInput(
            "stabilization diagram: one weight per channel and line is required".into(),
        ));
    }
    let f_max = frf.freqs_hz[nf - 1];
    if f_max <= 0.0 {
        return Err(Error::BadInput(
            "stabilization diagram: the band must contain positive frequencies".into(),
        ));
    }
    let used: usize = (0..nf)
        .filter(|&k| weights.iter().any(|w| w[k] > 0.0))
        .count();
    // Each order n needs n+1 real denominator unknowns; keep them well below the data.
    let max_order = (opts.max_order.min(used.saturating_sub(2)) / 2) * 2;
    if max_order < 2 {
        return Err(Error::BadInput(
            "stabilization diagram: too few usable lines (raise the coherence or widen the band)"
                .into(),
        ));
    }
    let ts = 1.0 / (2.0 * f_max);
    let n = max_order;
    let omegas: Vec<Complex64> = frf
        .freqs_hz
        .iter()
        .map(|f| Complex64::from_polar(1.0, 2.0 * PI * f * ts))
        .collect();

    // Toeplitz generators per channel (only their real parts enter the real normal
    // equations): r(m) = Σ w² cos mθ, t(m) = Σ w² |h|² cos mθ, and for the cross terms
    // Re Σ w² h Ω^(±m) = a(m) ∓ b(m) with a(m) = Σ w² Re h cos mθ, b(m) = Σ w² Im h sin mθ
    // (m = 0..n, θ the line's angle): one product of the cosine and sine tables
    // (lines × n+1, column m = cos mθ resp. sin mθ of every line) with the channels'
    // weighted data. The tables are filled column by column, so the recurrence
    // Ωᵐ⁺¹ = Ωᵐ Ω is one independent product per line.
    let mut cos = linalg::pooled_zeros(nf, n + 1);
    let mut sin = linalg::pooled_zeros(nf, n + 1);
    let mut z = vec![Complex64::new(1.0, 0.0); nf];
    for m in 0..=n {
        let (c, s) = (
            &mut cos.as_mut_slice()[m * nf..(m + 1) * nf],
            &mut sin.as_mut_slice()[m * nf..(m + 1) * nf],
        );
        for (((c, s), z), om) in c.iter_mut().zip(s).zip(&mut z).zip(&omegas) {
            *c = z.re;
            *s = z.im;
            *z *= om;
        }
    }
    let mut chans = Vec::with_capacity(frf.channels.len());
    for (ch, w) in frf.channels.iter().zip(weights) {
        let Some(scale) = crate::frf::weighted_rms(&ch.h, w) else {
            continue;
        };
        chans.push((ch, w, scale));
    }
    let mut by_cos = DMatrix::<f64>::zeros(nf, 3 * chans.len());
    let mut by_sin = DMatrix::<f64>::zeros(nf, chans.len());
    for (c, (ch, w, scale)) in chans.iter().enumerate() {
        for k in 0..nf {
            let w2 = w[k] * w[k];
            if w2 == 0.0 {
                continue;
            }
            let h = ch.h[k] / *scale;
            if !h.re.is_finite() || !h.im.is_finite() {
                return Err(Error::BadInput(format!(
                    "channel {}: non-finite FRF value at {} Hz",
                    ch.channel, frf.freqs_hz[k]
                )));
            }
            by_cos[(k, 3 * c)] = w2;
            by_cos[(k, 3 * c + 1)] = h.norm_sqr() * w2;
            by_cos[(k, 3 * c + 2)] = h.re * w2;
            by_sin[(k, c)] = h.im * w2;
        }
    }
    let gen_cos = cos.tr_mul(&by_cos);
    let gen_sin = sin.tr_mul(&by_sin);
    linalg::release(cos);
    linalg::release(sin);
    let mut m_red = DMatrix::<f64>::zeros(n + 1, n + 1);
    let mut blocks = Vec::with_capacity(chans.len());
    for c in 0..chans.len() {
        let (r, t, a, b) = (
            gen_cos.column(3 * c),
            gen_cos.column(3 * c + 1),
            gen_cos.column(3 * c + 2),
            gen_sin.column(c),
        );
        let rr = DMatrix::from_fn(n + 1, n + 1, |i, j| r[i.abs_diff(j)]);
        let tt = DMatrix::from_fn(n + 1, n + 1, |i, j| t[i.abs_diff(j)]);
        // ss(i, j) = -Re s(j - i) for j ≥ i, -Re s̄(i - j) below
        let ss = DMatrix::from_fn(n + 1, n + 1, |i, j| {
            let m = i.abs_diff(j);
            if j >= i {
                b[m] - a[m]
            } else {
                -a[m] - b[m]
            }
        });
        blocks.push((rr, ss, tt));
    }
    if blocks.is_empty() {
        return Err(Error::BadInput(
            "stabilization diagram: every channel is zero or has zero weight".into(),
        ));
    }

    // Good band: lines with positive weight in some channel.
    let good: Vec<bool> = (0..nf)
        .map(|k| weights.iter().any(|w| w[k] > 0.0))
        .collect();
    let in_good = |f: f64| -> bool {
        if f < frf.freqs_hz[0] || f > f_max {
            return false;
        }
        let k = frf.freqs_hz.partition_point(|&x| x < f).min(nf - 1);
        good[k] && (k == 0 || good[k - 1])
    };

    // The reduced normal matrix of order o (size q = o + 1) is Σ_c T_q − S_qᵀ R_q⁻¹ S_q
    // over the leading q×q blocks. With the Cholesky factor R = L Lᵀ of the full block,
    // L_q is the leading block of L and L_q⁻¹ S_q the leading block of Z = L⁻¹ S, so
    // S_qᵀ R_q⁻¹ S_q = Σ_{i<q} (row i of Z)ᵀ(row i of Z) on the leading columns: one
    // factorisation per channel and rank-one updates as the order grows (O(n³) instead
    // of a factorisation per order, O(n⁴)). A channel whose full block is not positive
    // definite (few lines, high orders) is reduced order by order as before.
    let mut acc = DMatrix::<f64>::zeros(n + 1, n + 1);
    let mut nested: Vec<DMatrix<f64>> = Vec::new();
    let mut per_order: Vec<&(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> = Vec::new();
    for blk in &blocks {
        let (rr, ss, tt) = blk;
        match rr.clone().cholesky() {
            Some(chol) => match chol.l().solve_lower_triangular(ss) {
                Some(z) if z.iter().all(|v| v.is_finite()) => {
                    acc += tt;
                    nested.push(z);
                }
                _ => per_order.push(blk),
            },
            None => per_order.push(blk),
        }
    }
    let mut rows_done = 0usize;

    let mut orders: Vec<OrderPoles> = Vec::new();
    let mut next_chain = 0usize;
    let (mut physical_so_far, mut last_new) = (0usize, 0usize);
    for order in (2..=n).step_by(2) {
        let q = order + 1;
        while rows_done < q {
            for z in &nested {
                let row = z.row(rows_done);
                acc -= row.transpose() * row;
            }
            rows_done += 1;
        }
        m_red.fill(0.0);
        m_red
            .view_mut((0, 0), (q, q))
            .copy_from(&acc.view((0, 0), (q, q)));
        for &(rr, ss, tt) in &per_order {
            let r = rr.view((0, 0), (q, q)).into_owned();
            let s = ss.view((0, 0), (q, q)).into_owned();
            let t = tt.view((0, 0), (q, q));
            let Some(chol) = r.cholesky() else {
                continue;
            };
            let rs = chol.solve(&s);
            let red = t - s.transpose() * rs;
            let mut blk = m_red.view_mut((0, 0), (q, q));
            blk += red;
        }
        // α_order = 1: M[0..o, 0..o] α = -M[0..o, o]
        let a = m_red.view((0, 0), (order, order)).into_owned();
        let b = -m_red.view((0, order), (order, 1)).into_owned();
        let alpha = match a.clone().cholesky() {
            Some(c) => c.solve(&b),
            None => match a.lu().solve(&b) {
                Some(x) => x,
                None => continue,
            },
        };
        let alpha = DVector::from_iterator(order, alpha.iter().copied());
        // descending powers for poly_roots: z^order + α_{o-1} z^{o-1} + … + α_0
        let mut desc = vec![1.0];
        desc.extend(alpha.iter().rev());
        let mut poles: Vec<DiagramPole> = poly_roots(&desc)
            .into_iter()
            .filter(|z| z.im > 0.0 && z.norm() > 0.0)
            .map(|z| {
                let s = z.ln() / ts;
                let wn = s.norm();
                let f_hz = wn / (2.0 * PI);
                DiagramPole {
                    f_hz,
                    zeta: -s.re / wn,
                    stable_freq: false,
                    stable_damping: false,
                    stable_orders: 1,
                    in_good_band: in_good(f_hz),
                    chain: 0,
                }
            })
            .filter(|p| p.f_hz.is_finite() && p.zeta.is_finite())
            .collect();
        poles.sort_by(|a, b| a.f_hz.total_cmp(&b.f_hz));
        link_to_previous(&mut poles, orders.last(), opts, &mut next_chain);
        orders.push(OrderPoles { order, poles });
        if opts.quiet_orders > 0 {
            let n_phys = physical_modes(&orders, opts).len();
            if n_phys > physical_so_far {
                physical_so_far = n_phys;
                last_new = order;
            }
            let floor = (4 * physical_so_far).max(MIN_TOP_ORDER);
            if order >= last_new + opts.quiet_orders && order >= floor {
                break;
            }
        }
    }
    let physical = physical_modes(&orders, opts);
    Ok(StabilizationDiagram { orders, physical })
}

/// Sets the stability flags of `poles` against the previous order, one-to-one nearest
/// in frequency.
fn link_to_previous(
    poles: &mut [DiagramPole],
    prev: Option<&OrderPoles>,
    opts: &StabilizationOptions,
    next_chain: &mut usize,
) {
    let prev = prev.map(|p| p.poles.as_slice()).unwrap_or(&[]);
    // candidate links sorted by closeness, then assigned greedily one-to-one
    let mut cand: Vec<(f64, usize, usize)> = Vec::new();
    for (i, p) in poles.iter().enumerate() {
        for (j, q) in prev.iter().enumerate() {
            let df = (p.f_hz - q.f_hz).abs() / q.f_hz;
            if df < 4.0 * opts.tol_freq {
                cand.push((df, i, j));
            }
        }
    }
    cand.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut used_p = vec![false; poles.len()];
    let mut used_q = vec![false; prev.len()];
    for (df, i, j) in cand {
        if used_p[i] || used_q[j] {
            continue;
        }
        used_p[i] = true;
        used_q[j] = true;
        let (p, q) = (&mut poles[i], &prev[j]);
        p.stable_freq = df < opts.tol_freq;
        p.stable_damping = p.zeta > 0.0
            && q.zeta > 0.0
            && (p.zeta - q.zeta).abs() < opts.tol_damping * q.zeta.max(p.zeta);
        if p.stable_freq && p.stable_damping {
            p.stable_orders = q.stable_orders + 1;
            p.chain = q.chain;
        } else {
            p.chain = *next_chain;
            *next_chain += 1;
        }
    }
    for (i, p) in poles.iter_mut().enumerate() {
        if !used_p[i] {
            p.chain = *next_chain;
            *next_chain += 1;
        }
    }
}

/// Chains of poles stable over enough orders, physically damped, in the usable band.
/// Chains that never coexist in one order and lie within the frequency tolerance are
/// the same mode (a chain that broke once).
fn physical_modes(orders: &[OrderPoles], opts: &StabilizationOptions) -> Vec<PhysicalMode> {
    use std::collections::BTreeMap;
    // chain id -> (first order, last order, last pole, best run)
    let mut chains: BTreeMap<usize, (usize, usize, DiagramPole, usize)> = BTreeMap::new();
    for op in orders {
        for p in &op.poles {
            let ok = p.stable_orders >= opts.min_stable_orders
                && p.zeta > 0.0
                && p.zeta < opts.max_damping
                && p.in_good_band;
            if !ok {
                continue;
            }
            let e = chains
                .entry(p.chain)
                .or_insert((op.order, op.order, *p, p.stable_orders));
            e.1 = op.order;
            e.2 = *p;
            e.3 = e.3.max(p.stable_orders);
        }
    }
    let mut list: Vec<(usize, usize, DiagramPole, usize)> = chains.into_values().collect();
    // longer chains first, so merges keep the best-established estimate
    list.sort_by(|a, b| b.3.cmp(&a.3).then(b.1.cmp(&a.1)));
    let mut out: Vec<(usize, usize, PhysicalMode)> = Vec::new();
    for (lo, hi, p, run) in list {
        let dup = out.iter().any(|(olo, ohi, m)| {
            let overlap = lo <= *ohi && *olo <= hi;
            !overlap && (m.f_hz - p.f_hz).abs() < opts.tol_freq * m.f_hz
        });
        if !dup {
            out.push((
                lo,
                hi,
                PhysicalMode {
                    f_hz: p.f_hz,
                    zeta: p.zeta,
                    stable_orders: run,
                },
            ));
        }
    }
    let mut modes: Vec<PhysicalMode> = out.into_iter().map(|x| x.2).collect();
    modes.sort_by(|a, b| a.f_hz.total_cmp(&b.f_hz));
    modes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_of_quadratic() {
        // (z - 2)(z + 3) = z² + z - 6
        let mut r = poly_roots(&[1.0, 1.0, -6.0]);
        r.sort_by(|a, b| a.re.total_cmp(&b.re));
        assert!((r[0].re + 3.0).abs() < 1e-12 && (r[1].re - 2.0).abs() < 1e-12);
        // z² + 1
        let r = poly_roots(&[0.0, 1.0, 0.0, 1.0]);
        assert!(r
            .iter()
            .all(|z| (z.norm() - 1.0).abs() < 1e-12 && z.re.abs() < 1e-12));
    }
}
