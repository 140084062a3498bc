//! Sums over many terms in interleaved partial sums.
//!
//! A single running sum waits for each addition to finish before the next; [`LANES`]
//! independent partial sums let the processor add terms side by side (and the
//! compiler keep them in vector registers). The result differs from a running sum only
//! by rounding.

/// Number of interleaved partial sums.
pub(crate) const LANES: usize = 4;

/// `Σ_{k < n} f(k)`, each of the `V` components of the terms in [`LANES`] interleaved
/// partial sums.
#[inline(always)]
pub(crate) fn sum<const V: usize>(n: usize, f: impl Fn(usize) -> [f64; V]) -> [f64; V] {
    let mut acc = [[0.0f64; LANES]; V];
    let full = n - n % LANES;
    for k0 in (0..full).step_by(LANES) {
        for l in 0..LANES {
            for (a, t) in acc.iter_mut().zip(f(k0 + l)) {
                a[l] += t;
            }
        }
    }
    for k in full..n {
        for (a, t) in acc.iter_mut().zip(f(k)) {
            a[0] += t;
        }
    }
    acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_every_term_once_for_any_length() {
        for n in 0..11 {
            let [s, q] = sum(n, |k| [k as f64, (k * k) as f64]);
            let m = n as f64;
            assert_eq!(s, m * (m - 1.0) / 2.0, "n = {n}");
            assert_eq!(q, (0..n).map(|k| (k * k) as f64).sum::<f64>(), "n = {n}");
        }
    }
}
