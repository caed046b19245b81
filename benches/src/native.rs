//! The native contenders: a scene's generic formula instantiated with `f32` (one point at a time)
//! and with `F8` (eight points at a time).
//!
//! Both kernels are compiled for AVX2 (chosen at run time by `hyperslice::simd::wide`, as
//! fidget's JIT does; the default x86-64 target is SSE2, where `f32::round` and `floor` become
//! library calls). Everything below the kernel is `#[inline(always)]`, so each scene's formula is
//! inlined into the AVX2 function and the `[f32; 8]` loops become 256-bit instructions.

use crate::packet::{F8, LANES};
use crate::scenes::Scene;
use crate::sdf::v4;
use crate::workload::Points;
use hyperslice::simd::{self, has_avx2_fma};

/// The native scalar closure of a scene (distance only).
pub fn scalar<S: Scene>(scene: &S) -> impl Fn([f32; 4]) -> f32 + '_ {
    move |p| scene.dist(&p)
}

/// Distances (and, for multi-object scenes, nearest-object ids) one point at a time.
pub fn eval_scalar<S: Scene>(scene: &S, pts: &Points, out: &mut [f32], ids: &mut [f32]) {
    simd::wide!({
        for i in 0..pts.len() {
            let p = pts.get(i);
            if S::MULTI {
                (out[i], ids[i]) = scene.dist_id(&p);
            } else {
                out[i] = scene.dist(&p);
            }
        }
    })
}

/// Distances (and ids) eight points at a time; a ragged tail is padded with copies of its first
/// point.
pub fn eval_packet<S: Scene>(scene: &S, pts: &Points, out: &mut [f32], ids: &mut [f32]) {
    simd::wide!({
        let n = pts.len();
        let cols = [&pts.xs, &pts.ys, &pts.zs, &pts.ws];
        let full = n - n % LANES;
        for i in (0..full).step_by(LANES) {
            let p = v4(|k| F8::load(&cols[k][i..]));
            packet_store(scene, &p, out, ids, i, LANES);
        }
        if full < n {
            let p = v4(|k| {
                let mut lanes = [cols[k][full]; LANES];
                lanes[..n - full].copy_from_slice(&cols[k][full..]);
                F8(lanes)
            });
            packet_store(scene, &p, out, ids, full, n - full);
        }
    })
}

/// Evaluates one packet and stores its first `n` lanes at `out[at..]` (and `ids[at..]`).
#[inline(always)]
fn packet_store<S: Scene>(
    scene: &S,
    p: &[F8; 4],
    out: &mut [f32],
    ids: &mut [f32],
    at: usize,
    n: usize,
) {
    if S::MULTI {
        let (d, id) = scene.dist_id(p);
        out[at..at + n].copy_from_slice(&d.0[..n]);
        ids[at..at + n].copy_from_slice(&id.0[..n]);
    } else {
        out[at..at + n].copy_from_slice(&scene.dist(p).0[..n]);
    }
}

/// The ISA the native kernels run with on this machine, for the report.
pub fn isa() -> &'static str {
    if has_avx2_fma() {
        "AVX2+FMA"
    } else {
        "baseline"
    }
}
