//! The filter's inner loops: the weights of a tap for a run of pixels (branch-free `f32`, so
//! they vectorise), and the per-row sweeps of a pass that sum those weights or apply them,
//! compiled for AVX2 where the CPU has it (`simd::wide!`).

use super::guides::{ALBEDO, FOOT_X, FOOT_Y, MISSED, NORMAL, POSITION, POSITION_LO, VAR};
use super::guides::{CHANNELS, COLOR_PLANES, Guides, PLANES, plane};
use super::{B3, offset};
use crate::simd;

/// A tap whose exponent exceeds this is dropped (weight below 1e-17 of its kernel weight).
pub(super) const CUTOFF: f32 = 40.0;
/// Pixels of a row filtered together: their guides and sums stay in the L1 cache while the
/// taps stream past.
const BLOCK: usize = 64;
/// The taps of a pixel in one frame: 5 x 5.
const FRAME_TAPS: usize = 25;
/// The lanes of the widest vectors the tap loops are compiled for (`f32` in AVX2).
const LANES: usize = 8;

/// `term` in `f32`, branch-free so that the tap loops vectorise.
#[inline(always)]
fn term32(d2: f32, s2: f32) -> f32 {
    let t = d2 / s2;
    // A NaN `s2` makes `t` NaN, so `s2 <= 0.0` covers the rest.
    let t = if t.is_nan() | (s2 <= 0.0) {
        f32::INFINITY
    } else {
        t
    };
    if d2 <= 0.0 { 0.0 } else { t }
}

/// `term32(d2, s2)` for a fixed `s2`, by a multiplication instead of a division: by `1 / s2`,
/// or by infinity where `s2` is not positive.
#[derive(Clone, Copy)]
pub(super) struct Term(f32);

impl Term {
    pub(super) fn new(s2: f64) -> Term {
        Term(if s2 > 0.0 {
            (1.0 / s2) as f32
        } else {
            f32::INFINITY
        })
    }

    #[inline(always)]
    fn of(self, d2: f32) -> f32 {
        let t = d2 * self.0;
        let t = if t.is_nan() { f32::INFINITY } else { t };
        if d2 <= 0.0 { 0.0 } else { t }
    }
}

/// `exp(-t)` for `0 <= t <= CUTOFF`, branch-free so that the tap loops vectorise (the C
/// library's `exp` is a call): `2^k exp(r)` with `k` the integer nearest to `-t / ln 2` and
/// `exp(r)`, `|r| <= ln(2) / 2`, from its Taylor series to degree 7 (truncation below 6e-9
/// relative; the result is within about an `f32` rounding of the exact value).
#[inline(always)]
fn exp_neg(t: f32) -> f32 {
    /// 1.5 * 2^23: adding it rounds to an integer, which lands in the low mantissa bits.
    const SHIFT: f32 = 12_582_912.0;
    /// ln 2 in two parts (Cephes'): `k * LN2_HI` is exact for `|k| < 2^15`.
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    const INV_FACTORIAL: [f32; 8] = [
        1.0,
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
    ];
    let x = -t;
    let kd = x * std::f32::consts::LOG2_E + SHIFT;
    let bits = kd.to_bits();
    let k = kd - SHIFT;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let mut p = INV_FACTORIAL[7];
    for c in INV_FACTORIAL[..7].iter().rev() {
        p = p * r + c;
    }
    // 2^k: the low bits of `bits` are `k` (two's complement), shifted into the exponent field.
    p * f32::from_bits(bits.wrapping_add(127) << 23)
}

/// Whether all three are finite (branch-free): `x - x` is zero for a finite `x` and NaN for an
/// infinite or NaN one, and the sum is zero only if all three are.
#[inline(always)]
#[allow(clippy::eq_op)]
fn finite3<
    T: std::ops::Sub<Output = T> + std::ops::Add<Output = T> + PartialEq + Default + Copy,
>(
    a: T,
    b: T,
    c: T,
) -> bool {
    (a - a) + (b - b) + (c - c) == T::default()
}

/// What one pass needs: the guides, the current demodulated colours and the pass's sigmas.
pub(super) struct Pass<'a> {
    pub(super) guides: &'a [Option<Guides>],
    /// The demodulated colours of every frame, as planes (see `Guides`).
    pub(super) cur: &'a [Vec<f64>],
    /// The same as `f32` pairs (see `split`), scaled like the variances.
    pub(super) cur32: &'a [Vec<f32>],
    /// For every frame, the frames its taps read (itself included), with their frame weights.
    pub(super) sources: Vec<Vec<(usize, f64)>>,
    /// Whether the taps reach into the previous and the next frame (then `sources` may hold
    /// them, and a pixel has three frames' taps to store).
    pub(super) temporal: bool,
    pub(super) step: usize,
    pub(super) sc2: f32,
    pub(super) sx2: f32,
    pub(super) albedo: Term,
    pub(super) normal: Term,
}

/// A run of pixels of a block and where one tap of theirs lies: pixels `lo..lo + n` of the
/// block have their tap at pixels `qx..qx + n` of row `qy` of frame `kq`.
#[derive(Clone, Copy)]
struct TapRun {
    lo: usize,
    n: usize,
    kq: usize,
    qy: usize,
    qx: usize,
}

/// What weighs one tap of a run of pixels, besides the guides.
struct Tap {
    /// Frame weight times kernel weight.
    base: f32,
    /// The tap's offset in pixels.
    ox: f32,
    oy: f32,
    /// Whether the tap lies in another frame.
    other: bool,
    sc2: f32,
    sx2: f32,
    albedo: Term,
    normal: Term,
}

/// Runs of `n` pixels of every plane of a row (guides and colours), from pixel `x`.
struct Run<'a> {
    a: [&'a [f32]; 3],
    n: [&'a [f32]; 4],
    x: [&'a [f32]; 4],
    x_lo: [&'a [f32]; 4],
    fx: &'a [f32],
    fy: &'a [f32],
    var: &'a [f32],
    missed: &'a [f32],
    c: [&'a [f32]; 3],
    c_lo: [&'a [f32]; 3],
}

impl<'a> Run<'a> {
    #[inline(always)]
    fn new(guides: &'a [f32], colors: &'a [f32], s: usize, x: usize, n: usize) -> Run<'a> {
        let g = |g| plane(guides, s, g, x, n);
        let c = |c| plane(colors, s, c, x, n);
        Run {
            a: [g(ALBEDO), g(ALBEDO + 1), g(ALBEDO + 2)],
            n: [g(NORMAL), g(NORMAL + 1), g(NORMAL + 2), g(NORMAL + 3)],
            x: [
                g(POSITION),
                g(POSITION + 1),
                g(POSITION + 2),
                g(POSITION + 3),
            ],
            x_lo: [
                g(POSITION_LO),
                g(POSITION_LO + 1),
                g(POSITION_LO + 2),
                g(POSITION_LO + 3),
            ],
            fx: g(FOOT_X),
            fy: g(FOOT_Y),
            var: g(VAR),
            missed: g(MISSED),
            c: [c(0), c(1), c(2)],
            c_lo: [c(CHANNELS), c(CHANNELS + 1), c(CHANNELS + 2)],
        }
    }

    /// Pixels `a..a + m` of the runs.
    #[inline(always)]
    fn slice(&self, a: usize, m: usize) -> Run<'a> {
        let r = |s: &'a [f32]| &s[a..a + m];
        Run {
            a: self.a.map(r),
            n: self.n.map(r),
            x: self.x.map(r),
            x_lo: self.x_lo.map(r),
            fx: r(self.fx),
            fy: r(self.fy),
            var: r(self.var),
            missed: r(self.missed),
            c: self.c.map(r),
            c_lo: self.c_lo.map(r),
        }
    }
}

/// The weights `out[i]` of one tap (see the module notes) of the pixels `p` (runs of their
/// guides and colours) whose tap pixels are `q`: zero where the tap's colour is not finite, the
/// pixels do not agree on having missed or the exponent exceeds `CUTOFF`.
#[inline(always)]
fn tap_weights(out: &mut [f32], p: &Run, q: &Run, tap: &Tap) {
    let n = out.len();
    // Whole vectors of `LANES`, and the rest as one more vector that overlaps the last (its
    // lanes come out the same twice) instead of a slow scalar remainder.
    let whole = n - n % LANES;
    let spans = if whole == n || n < LANES {
        [(0, n), (0, 0)]
    } else {
        [(0, whole), (n - LANES, LANES)]
    };
    let mut t = [0.0; BLOCK];
    for (a, m) in spans {
        exponents(&mut t[a..a + m], &p.slice(a, m), &q.slice(a, m), tap);
    }
    // The exponentials in a loop of their own: a short body, so that many lanes are in flight.
    for (a, m) in spans {
        for (o, t) in out[a..a + m].iter_mut().zip(&t[a..a + m]) {
            let e = exp_neg(if *t < CUTOFF { *t } else { CUTOFF });
            *o = if *t <= CUTOFF { tap.base * e } else { 0.0 };
        }
    }
}

/// The exponents `out[i]` of the weights of `tap_weights`, infinite where the weight is zero
/// whatever the exponent. Branch-free, so it vectorises.
#[inline(always)]
fn exponents(out: &mut [f32], p: &Run, q: &Run, tap: &Tap) {
    let n = out.len();
    let [pa0, pa1, pa2] = p.a.map(|s| &s[..n]);
    let [qa0, qa1, qa2] = q.a.map(|s| &s[..n]);
    let [pn0, pn1, pn2, pn3] = p.n.map(|s| &s[..n]);
    let [qn0, qn1, qn2, qn3] = q.n.map(|s| &s[..n]);
    let [px0, px1, px2, px3] = p.x.map(|s| &s[..n]);
    let [qx0, qx1, qx2, qx3] = q.x.map(|s| &s[..n]);
    let [pl0, pl1, pl2, pl3] = p.x_lo.map(|s| &s[..n]);
    let [ql0, ql1, ql2, ql3] = q.x_lo.map(|s| &s[..n]);
    let [pc0, pc1, pc2] = p.c.map(|s| &s[..n]);
    let [qc0, qc1, qc2] = q.c.map(|s| &s[..n]);
    let [pd0, pd1, pd2] = p.c_lo.map(|s| &s[..n]);
    let [qd0, qd1, qd2] = q.c_lo.map(|s| &s[..n]);
    let (pfx, pfy, pv, pm) = (&p.fx[..n], &p.fy[..n], &p.var[..n], &p.missed[..n]);
    let (qfx, qfy, qv, qm) = (&q.fx[..n], &q.fy[..n], &q.var[..n], &q.missed[..n]);
    for i in 0..n {
        let (d0, d1, d2) = (pa0[i] - qa0[i], pa1[i] - qa1[i], pa2[i] - qa2[i]);
        let ta = tap.albedo.of(d0 * d0 + d1 * d1 + d2 * d2);
        let (d0, d1, d2, d3) = (
            pn0[i] - qn0[i],
            pn1[i] - qn1[i],
            pn2[i] - qn2[i],
            pn3[i] - qn3[i],
        );
        let tn = tap.normal.of(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3);
        // The footprint of the pair (the mean of both), so the weight is symmetric.
        let fx = 0.5 * (pfx[i] + qfx[i]);
        let fy = 0.5 * (pfy[i] + qfy[i]);
        let f2 = (tap.ox * fx) * (tap.ox * fx) + (tap.oy * fy) * (tap.oy * fy);
        let f2 = f2 + if tap.other { fx * fy } else { 0.0 };
        let (d0, d1, d2, d3) = (
            (px0[i] - qx0[i]) + (pl0[i] - ql0[i]),
            (px1[i] - qx1[i]) + (pl1[i] - ql1[i]),
            (px2[i] - qx2[i]) + (pl2[i] - ql2[i]),
            (px3[i] - qx3[i]) + (pl3[i] - ql3[i]),
        );
        let tx = term32(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3, tap.sx2 * f2);
        let (d0, d1, d2) = (
            (qc0[i] - pc0[i]) + (qd0[i] - pd0[i]),
            (qc1[i] - pc1[i]) + (qd1[i] - pd1[i]),
            (qc2[i] - pc2[i]) + (qd2[i] - pd2[i]),
        );
        let tc = term32(d0 * d0 + d1 * d1 + d2 * d2, tap.sc2 * (pv[i] + qv[i]));
        // Two missed pixels have zero normals and positions: `tn = tx = 0`. A centre without a
        // valid colour is weighed without the colour term.
        let t = ta + tn + tx;
        let t = t + if finite3(pc0[i], pc1[i], pc2[i]) {
            tc
        } else {
            0.0
        };
        let keep = finite3(qc0[i], qc1[i], qc2[i]) & (pm[i] == qm[i]);
        out[i] = if keep { t } else { f32::INFINITY };
    }
}

impl Pass<'_> {
    /// The weights a pixel stores (see `block_taps`): a frame's taps, or three frames'.
    pub(super) fn taps(&self) -> usize {
        (if self.temporal { 3 } else { 1 }) * FRAME_TAPS
    }

    /// Call `sink.tap(run, weights)` for every tap of the pixels `x0..x0 + len` (at most
    /// `BLOCK`) of row `y` of frame `k`, in the order previous / same / next frame, then rows,
    /// then columns: `weights[i]` is the weight of pixel `x0 + run.lo + i`'s tap (zero where it
    /// does not count), the centre included (weight = kernel weight where the colour is valid).
    /// Weights are symmetric: the tap `q` of `p` has `p` as a tap with the same weight. A centre
    /// whose own colour is not valid gets weights without the colour term.
    ///
    /// With `Weights::Store`, the weights are also stored in the row's `taps()` rows of weights
    /// (the tap numbered `i` at `[i * w..(i + 1) * w]`); with `Weights::Load` they are taken from
    /// there instead of computed.
    #[inline(always)]
    fn block_taps(
        &self,
        (k, y): (usize, usize),
        (x0, len): (usize, usize),
        weights: &mut Weights,
        sink: &mut impl Sink,
    ) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        let (w, h, s) = (g.w, g.h, g.s);
        let colors = |k: usize, y: usize| {
            (
                &self.cur32[k][y * COLOR_PLANES * s..(y + 1) * COLOR_PLANES * s],
                &self.cur[k][y * CHANNELS * s..(y + 1) * CHANNELS * s],
            )
        };
        let (p, (pc, pc64)) = (g.row(y), colors(k, y));
        // The block's own guides and colours, copied to planes of stride `BLOCK`: the same for
        // every tap, and then addressed from one base.
        let mut own = [0.0; (PLANES + COLOR_PLANES) * BLOCK];
        if !matches!(weights, Weights::Load(_)) {
            for g in 0..PLANES {
                own[g * BLOCK..g * BLOCK + len].copy_from_slice(plane(p, s, g, x0, len));
            }
            for c in 0..COLOR_PLANES {
                own[(PLANES + c) * BLOCK..(PLANES + c) * BLOCK + len]
                    .copy_from_slice(plane(pc, s, c, x0, len));
            }
        }
        let (own, own_colors) = own.split_at(PLANES * BLOCK);
        let mut buf = [0.0; BLOCK];
        let step = self.step as isize;
        for &(kq, frame_weight) in &self.sources[k] {
            let other = kq != k;
            let frame_slot = (if self.temporal { kq + 1 - k } else { 0 }) * FRAME_TAPS;
            let Some(src) = &self.guides[kq] else {
                continue;
            };
            for (j, ky) in B3.iter().enumerate() {
                let dy = j as isize - 2;
                let Some(qy) = offset(y, dy, self.step, h) else {
                    continue;
                };
                let (q, (qc, _)) = (src.row(qy), colors(kq, qy));
                for (i, kx) in B3.iter().enumerate() {
                    let ox = (i as isize - 2) * step;
                    // The pixels of the block whose tap lies inside the row.
                    let lo = (x0 as isize).max(-ox);
                    let hi = ((x0 + len) as isize).min(w as isize - ox);
                    if lo >= hi {
                        continue;
                    }
                    let run = TapRun {
                        lo: lo as usize - x0,
                        n: (hi - lo) as usize,
                        kq,
                        qy,
                        qx: (lo + ox) as usize,
                    };
                    let slot = (frame_slot + j * B3.len() + i) * w + lo as usize;
                    if let Weights::Load(stored) = weights {
                        sink.tap(run, &stored[slot..slot + run.n]);
                        continue;
                    }
                    let out = &mut buf[..run.n];
                    let base = (frame_weight * kx * ky) as f32;
                    if !other && ox == 0 && dy == 0 {
                        for (o, x) in out.iter_mut().zip(x0..) {
                            let ok = finite3(pc64[x], pc64[s + x], pc64[2 * s + x]);
                            *o = if ok { base } else { 0.0 };
                        }
                    } else {
                        let tap = Tap {
                            base,
                            ox: ox as f32,
                            oy: (dy * step) as f32,
                            other,
                            sc2: self.sc2,
                            sx2: self.sx2,
                            albedo: self.albedo,
                            normal: self.normal,
                        };
                        let (pr, qr) = (
                            Run::new(own, own_colors, BLOCK, run.lo, run.n),
                            Run::new(q, qc, s, run.qx, run.n),
                        );
                        tap_weights(out, &pr, &qr, &tap);
                    }
                    if let Weights::Store(stored) = weights {
                        stored[slot..slot + run.n].copy_from_slice(out);
                    }
                    sink.tap(run, out);
                }
            }
        }
    }

    /// Row `y` of the weight sums of frame `k`'s pixels, and the row's weights (see
    /// `block_taps`).
    pub(super) fn sums_row(&self, (k, y): (usize, usize), out: &mut [f64], stored: &mut [f32]) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        // The tap loops at `LANES` wide.
        simd::wide!({
            let mut weights = Weights::Store(stored);
            for (b, out) in out[..g.w].chunks_mut(BLOCK).enumerate() {
                let mut sums = Sums([0.0; BLOCK]);
                self.block_taps((k, y), (b * BLOCK, out.len()), &mut weights, &mut sums);
                out.copy_from_slice(&sums.0[..out.len()]);
            }
        })
    }

    /// Row `y` of the demodulated colours of frame `k` after this pass (as planes). With `flux`
    /// (the weight sums of every pixel) the update is in flux form,
    /// `c_p + sum_q w_pq (c_q - c_p) / max(W_p, W_q)`, which moves as much colour from `p` to
    /// `q` as from `q` to `p` and so keeps the sum of the image; without, the usual normalised
    /// average `sum_q w_pq c_q / W_p`. A pixel whose colour is not valid takes the normalised
    /// average in either case.
    ///
    /// The weights are computed, or with `flux` taken from its row of weights, where `sums_row`
    /// left them.
    pub(super) fn update_row(&self, (k, y): (usize, usize), flux: Option<Flux>, out: &mut [f64]) {
        let Some(g) = &self.guides[k] else {
            return;
        };
        // The tap loops at `LANES` wide.
        simd::wide!({
            let sums = flux.map(|f| f.0);
            let mut weights = match flux {
                Some((_, stored)) => Weights::Load(stored),
                None => Weights::Compute,
            };
            let (w, s) = (g.w, g.s);
            let cur = &self.cur[k][y * CHANNELS * s..(y + 1) * CHANNELS * s];
            for x0 in (0..w).step_by(BLOCK) {
                let len = BLOCK.min(w - x0);
                let cp = [0, 1, 2].map(|c| &cur[c * s + x0..c * s + x0 + len]);
                let mut valid = [false; BLOCK];
                for (i, v) in valid[..len].iter_mut().enumerate() {
                    *v = finite3(cp[0][i], cp[1][i], cp[2][i]);
                }
                let mut acc = Update {
                    cur: self.cur,
                    s,
                    cp,
                    flux: sums.map(|sums| (sums, &sums[k][y * s + x0..y * s + x0 + len])),
                    // The normalised average is needed for every pixel without `sums`, else only
                    // for those without a valid colour.
                    average: sums.is_none() || valid[..len].contains(&false),
                    delta: [[0.0; BLOCK]; CHANNELS],
                    sum: [[0.0; BLOCK]; CHANNELS],
                    wsum: [0.0; BLOCK],
                };
                self.block_taps((k, y), (x0, len), &mut weights, &mut acc);
                for (i, valid) in valid[..len].iter().enumerate() {
                    let c = [cp[0][i], cp[1][i], cp[2][i]];
                    let v = if sums.is_some() && *valid {
                        [
                            c[0] + acc.delta[0][i],
                            c[1] + acc.delta[1][i],
                            c[2] + acc.delta[2][i],
                        ]
                    } else if acc.wsum[i] > 0.0 {
                        [
                            acc.sum[0][i] / acc.wsum[i],
                            acc.sum[1][i] / acc.wsum[i],
                            acc.sum[2][i] / acc.wsum[i],
                        ]
                    } else {
                        c
                    };
                    let v = if finite3(v[0], v[1], v[2]) { v } else { c };
                    for (ch, v) in v.iter().enumerate() {
                        out[ch * s + x0 + i] = *v;
                    }
                }
            }
        })
    }
}

/// The flux form's weight sums of every frame, and the weights of the row being updated.
type Flux<'a> = (&'a [Vec<f64>], &'a [f32]);

/// Where `Pass::block_taps` takes the weights from.
enum Weights<'a> {
    Compute,
    /// Compute them and store them here.
    Store(&'a mut [f32]),
    /// Take them from here.
    Load(&'a [f32]),
}

/// What takes the weights of a block's taps (see `Pass::block_taps`).
trait Sink {
    fn tap(&mut self, run: TapRun, weights: &[f32]);
}

/// The weight sums of a block's pixels.
struct Sums([f64; BLOCK]);

impl Sink for Sums {
    #[inline(always)]
    fn tap(&mut self, run: TapRun, weights: &[f32]) {
        for (a, wq) in self.0[run.lo..run.lo + run.n].iter_mut().zip(weights) {
            *a += *wq as f64;
        }
    }
}

/// The sums of the update of a block's pixels.
struct Update<'a> {
    /// The demodulated colours of every frame.
    cur: &'a [Vec<f64>],
    /// The frames' plane stride.
    s: usize,
    /// The block's colours (per channel).
    cp: [&'a [f64]; CHANNELS],
    /// For the flux form: the weight sums of every frame, and of the block's pixels.
    flux: Option<(&'a [Vec<f64>], &'a [f64])>,
    /// Whether to sum the normalised average too.
    average: bool,
    /// The flux form's `sum_q w_pq (c_q - c_p) / max(W_p, W_q)`.
    delta: [[f64; BLOCK]; CHANNELS],
    /// The normalised average's `sum_q w_pq c_q` and `W_p`.
    sum: [[f64; BLOCK]; CHANNELS],
    wsum: [f64; BLOCK],
}

impl Sink for Update<'_> {
    #[inline(always)]
    fn tap(&mut self, run: TapRun, weights: &[f32]) {
        let (lo, n, s) = (run.lo, run.n, self.s);
        let wts = &weights[..n];
        let src = &self.cur[run.kq][run.qy * CHANNELS * s..(run.qy + 1) * CHANNELS * s];
        let [cq0, cq1, cq2] = [0, 1, 2].map(|c| plane(src, s, c, run.qx, n));
        if let Some((sums, wp)) = self.flux {
            let wp = &wp[lo..lo + n];
            let wq = &sums[run.kq][run.qy * s + run.qx..run.qy * s + run.qx + n];
            let [d0, d1, d2] = &mut self.delta;
            let (d0, d1, d2) = (
                &mut d0[lo..lo + n],
                &mut d1[lo..lo + n],
                &mut d2[lo..lo + n],
            );
            let [cp0, cp1, cp2] = self.cp.map(|c| &c[lo..lo + n]);
            // A tap not kept (weight zero) may have a colour that is not finite: its term is
            // zeroed by taking `p`'s own colour for `q`'s, not by keeping `delta` as it was,
            // which compiles to masked stores (microcoded and slow on some CPUs). `m > 0` for
            // every pixel with a valid colour (its centre weighs); `delta` is not read for the
            // others.
            for i in 0..n {
                let wt = wts[i] as f64;
                let m = if wp[i] > wq[i] { wp[i] } else { wq[i] };
                let f = wt / m;
                let take = wt > 0.0;
                let q = |cq: &[f64], cp: &[f64]| if take { cq[i] } else { cp[i] };
                d0[i] += f * (q(cq0, cp0) - cp0[i]);
                d1[i] += f * (q(cq1, cp1) - cp1[i]);
                d2[i] += f * (q(cq2, cp2) - cp2[i]);
            }
        }
        if self.average {
            let [s0, s1, s2] = &mut self.sum;
            let (s0, s1, s2) = (
                &mut s0[lo..lo + n],
                &mut s1[lo..lo + n],
                &mut s2[lo..lo + n],
            );
            let ws = &mut self.wsum[lo..lo + n];
            // A tap not kept weighs zero and its colour may not be finite: clamped to the
            // finite numbers (NaN to the largest), its term is zero without a select, which
            // would compile to masked stores (see above).
            for i in 0..n {
                let wt = wts[i] as f64;
                // Not `clamp`, which keeps a NaN.
                #[allow(clippy::manual_clamp)]
                let q = |cq: &[f64]| cq[i].min(f64::MAX).max(f64::MIN);
                s0[i] += wt * q(cq0);
                s1[i] += wt * q(cq1);
                s2[i] += wt * q(cq2);
                ws[i] += wt;
            }
        }
    }
}
