//! realfft's even-length real-to-complex transform opened up, for the one-thread Welch
//! pairs: the complex FFT of half the length over the samples taken in pairs (rustfft,
//! planned as realfft plans it), run in place in the spectrum's own buffer, and the
//! post-processing that turns its output into the half spectrum done in blocks of line
//! pairs just before the lines are added to the sums.
//!
//! realfft post-processes its output in a pass of its own (every line read and written
//! once more), and the Welch sums then read every line again; here each line of the
//! complex FFT's output is read once, post-processed with realfft's own arithmetic and
//! twiddles (realfft 3.5) and added. The half spectra and so the sums are the same bit
//! for bit as realfft's added by [`super::pair_pass2`]: `frf_hash`
//! (`cargo run --release -p identify --example frf_hash`) is unchanged, and the test
//! `one_thread_in_pairs_equals_the_parallel_batches_bit_for_bit` compares this route
//! with the parallel batches, which keep realfft's transform, so a realfft whose
//! arithmetic changed would fail it.

use super::{kept, Cache};
use num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// The complex FFT of length `n / 2` and realfft's post-processing twiddles of a real DFT
/// of even length `n` (a multiple of 4, at least 8: see [`HalfDft::fits`]).
#[derive(Clone)]
pub(super) struct HalfDft {
    pub(super) fft: Arc<dyn Fft<f64>>,
    /// `0.5 e^{-2πi k/n}`, k = 1 .. n/4 - 1, computed as realfft computes them.
    twiddles: Arc<[Complex64]>,
}

thread_local! {
    /// Plans of the last few lengths ([`kept`]).
    static HALF_PLANS: Cache<HalfDft> = const { std::cell::RefCell::new(Vec::new()) };
}

impl HalfDft {
    /// Whether a real DFT of length `n` takes this route: `n` a multiple of 4 (realfft's
    /// even transform then has a centre line and pairs every other line with its mirror).
    pub(super) fn fits(n: usize) -> bool {
        n >= 8 && n % 4 == 0
    }

    /// The plan of length `n` ([`HalfDft::fits`]), kept per thread.
    pub(super) fn new(n: usize) -> Self {
        kept(&HALF_PLANS, n, || {
            // realfft's RealToComplexEven::new: twiddle i = compute_twiddle(i, n) · 0.5
            let constant = -2f64 * std::f64::consts::PI / n as f64;
            let twiddles = (1..n / 4)
                .map(|i| {
                    let angle = constant * i as f64;
                    Complex64::new(angle.cos(), angle.sin()) * 0.5
                })
                .collect();
            HalfDft {
                fft: FftPlanner::<f64>::new().plan_fft_forward(n / 2),
                twiddles,
            }
        })
    }

    /// Scratch the transform needs (in place).
    pub(super) fn scratch_len(&self) -> usize {
        self.fft.get_inplace_scratch_len()
    }
}

/// `buf` as the `2 · buf.len()` real samples the half-length complex FFT takes in pairs
/// (real part: even sample, imaginary part: odd sample), for [`super::fill_windowed`].
pub(super) fn as_samples(buf: &mut [Complex64]) -> &mut [f64] {
    bytemuck::cast_slice_mut(buf)
}

/// Lines `k` and `n/2 - k` of the half spectrum from the complex FFT's outputs `out` (at
/// k) and `out_rev` (at n/2 - k), with twiddle `tw` = `0.5 e^{-2πi k/n}`: realfft's
/// post-processing, operation for operation.
#[inline(always)]
fn post(tw: Complex64, out: Complex64, out_rev: Complex64) -> (Complex64, Complex64) {
    let sum = out + out_rev;
    let diff = out - out_rev;
    let half = 0.5;
    let twiddled_re_sum = sum * tw.re;
    let twiddled_im_sum = sum * tw.im;
    let twiddled_re_diff = diff * tw.re;
    let twiddled_im_diff = diff * tw.im;
    let half_sum_re = half * sum.re;
    let half_diff_im = half * diff.im;
    let output_twiddled_real = twiddled_re_sum.im + twiddled_im_diff.re;
    let output_twiddled_im = twiddled_im_sum.im - twiddled_re_diff.re;
    (
        Complex64::new(
            half_sum_re + output_twiddled_real,
            half_diff_im + output_twiddled_im,
        ),
        Complex64::new(
            half_sum_re - output_twiddled_real,
            output_twiddled_im - half_diff_im,
        ),
    )
}

/// The sums of one output: `Σ conj(F) Y` and `Σ |Y|²`, line k at index k - 1.
pub(super) type OutputSums<'a> = (&'a mut [Complex64], &'a mut [f64]);

/// Line pairs post-processed at a time into buffers that stay in the L1 cache, then
/// added by [`super::pair_pass`] / [`super::pair_pass2`] (the whole pass in one loop
/// spilled its registers: 12 post-processed lines live at once).
const BLOCK: usize = 64;

/// Lines of one spectrum for a block: `[0]` the block's lines k in rising order, `[1]`
/// their mirrors h - k in rising order too.
type Lines = [[Complex64; BLOCK]; 2];

/// Post-processes the block of line pairs starting at pair `j0` (lines `j0 + 1 ..` and
/// their mirrors) of the FFT output `v` (length h) into `out`.
#[inline(always)]
fn post_block(tw: &[Complex64], v: &[Complex64], j0: usize, out: &mut Lines) {
    let nb = tw.len();
    let h = v.len();
    let fwd = &v[j0 + 1..j0 + 1 + nb];
    let rev = &v[h - j0 - nb..h - j0];
    let [lo, hi] = out;
    let (lo, hi) = (&mut lo[..nb], &mut hi[..nb]);
    for b in 0..nb {
        let (p, q) = post(tw[b], fwd[b], rev[nb - 1 - b]);
        lo[b] = p;
        hi[nb - 1 - b] = q;
    }
}

/// Adds two consecutive segments of one input (`fs`: the complex FFT outputs of their
/// windowed forces, `n/2` each) to the sums of one or two outputs (`outs`, `ys[o]`: the
/// two segments' FFT outputs of output `o`) and, when `gff` is not empty, to the force's
/// auto spectrum, line k = 1 .. n/2 - 1 of each post-processed as realfft does: the same
/// terms in the same order as realfft's spectra added by [`super::pair_pass`] /
/// [`super::pair_pass2`], the same sums bit for bit. `scale`
/// (`scale[i]`: line i + 1's factor, the acceleration-to-displacement conversion) multiplies
/// each response line on the way. Two outputs come with the force's auto spectrum (`gff`
/// not empty), as [`super::pair_pass2`] adds it.
pub(super) fn add_pair(
    dft: &HalfDft,
    gff: &mut [f64],
    outs: &mut [OutputSums],
    fs: [&[Complex64]; 2],
    ys: &[[&[Complex64]; 2]],
    scale: Option<&[Complex64]>,
) {
    // (one loop each, the unscaled one without the multiplications)
    match scale {
        Some(s) => add_pair_by(dft, gff, outs, fs, ys, |k, y| y * s[k]),
        None => add_pair_by(dft, gff, outs, fs, ys, |_, y| y),
    }
}

/// [`add_pair`] with the response lines through `scale` (sum index, line).
fn add_pair_by(
    dft: &HalfDft,
    gff: &mut [f64],
    outs: &mut [OutputSums],
    fs: [&[Complex64]; 2],
    ys: &[[&[Complex64]; 2]],
    scale: impl Fn(usize, Complex64) -> Complex64,
) {
    let c = dft.twiddles.len() + 1; // the centre line, n/4
    let h = 2 * c; // n/2: the FFT's length; the sums hold lines 1 .. h - 1
    let no = outs.len().min(ys.len()).min(2);
    debug_assert!(
        no < 2 || !gff.is_empty(),
        "two outputs without the force's sums"
    );
    let fs = fs.map(|f| &f[..h]);
    let mut pf = [[[Complex64::ZERO; BLOCK]; 2]; 2];
    let mut py = [[[[Complex64::ZERO; BLOCK]; 2]; 2]; 2];
    // the sums of the lines `at` (indices into the sums) from the block's lines `half`
    // (0: lines k, 1: mirrors), `nb` of them
    let mut add =
        |at: std::ops::Range<usize>, half: usize, pf: &[Lines; 2], py: &[[Lines; 2]; 2]| {
            let nb = at.len();
            let base = at.start;
            let g = if gff.is_empty() {
                &mut [][..]
            } else {
                &mut gff[at.clone()]
            };
            let f = [&pf[0][half][..nb], &pf[1][half][..nb]];
            let y = |o: usize| [&py[o][0][half][..nb], &py[o][1][half][..nb]];
            let sc = |k: usize, v: Complex64| scale(base + k, v);
            match &mut outs[..no] {
                [(gfy0, gyy0), (gfy1, gyy1)] => super::pair_pass2(
                    (&mut gfy0[at.clone()], &mut gyy0[at.clone()]),
                    (&mut gfy1[at.clone()], &mut gyy1[at.clone()]),
                    g,
                    f,
                    y(0),
                    y(1),
                    sc,
                ),
                [(gfy, gyy)] => {
                    super::pair_pass(&mut gfy[at.clone()], &mut gyy[at.clone()], g, f, y(0), sc)
                }
                _ => {}
            }
        };
    let mut j0 = 0;
    while j0 < c - 1 {
        let nb = BLOCK.min(c - 1 - j0);
        let tw = &dft.twiddles[j0..j0 + nb];
        for (v, p) in fs.iter().zip(&mut pf) {
            post_block(tw, v, j0, p);
        }
        for (y, p) in ys[..no].iter().zip(&mut py) {
            for (v, p) in y.iter().zip(p) {
                post_block(tw, &v[..h], j0, p);
            }
        }
        // lines j0 + 1 .. at sums j0 .., their mirrors h - j0 - nb .. at h - j0 - nb - 1 ..
        add(j0..j0 + nb, 0, &pf, &py);
        add(h - j0 - nb - 1..h - j0 - 1, 1, &pf, &py);
        j0 += nb;
    }
    // the centre line: realfft leaves the FFT's value there, its imaginary part negated
    for (v, p) in fs.iter().zip(&mut pf) {
        p[0][0] = v[c].conj();
    }
    for (y, p) in ys[..no].iter().zip(&mut py) {
        for (v, p) in y.iter().zip(p) {
            p[0][0] = v[c].conj();
        }
    }
    add(c - 1..c, 0, &pf, &py);
}

thread_local! {
    /// The scratch buffer of the half-length transforms.
    pub(super) static SCRATCH: std::cell::RefCell<Vec<Complex64>> = const { std::cell::RefCell::new(Vec::new()) };
}
