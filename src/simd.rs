//! Runtime SIMD dispatch, the one way the hot loops (the VM interpreter, the a-trous filter's
//! rows, the benchmark's native kernels) get wide vectors. They are written once as plain lane
//! loops the compiler vectorises; [`wide!`](crate::wide) runs such a loop compiled for AVX2 and
//! FMA where the CPU has them (8 `f32` lanes instead of SSE2's 4, SSE4.1's `floor` and `round`
//! inline instead of C library calls), so one binary still runs on every x86-64 CPU and other
//! targets.
//!
//! The features change speed, not results: Rust never fuses `a * b + c` on its own, and
//! `mul_add` is fused either way.

pub use crate::wide;

/// Whether the CPU has AVX2 and FMA. std caches what CPUID said, so this costs two loads.
#[inline]
pub fn has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `simd::wide!(body)` evaluates the expression `body` compiled with AVX2 and FMA when the CPU
/// has them, else as it is; `simd::wide!(worth, body)` only checks the CPU where `worth` (say,
/// whether there are lanes to vectorise) holds. On the wide path `body` runs in a closure, so
/// a `return`, `?` or `break` in it would act on the closure: keep them out of it.
///
/// A macro, not a function taking a closure, so that the `#[target_feature]` wrapper is an item
/// of the caller's module and compiled in the caller's codegen unit: with the wrapper in this
/// module's, the VM's one-point interpreter (which has no wrapper) was compiled differently and
/// ran 8-13% slower in `hyperslice-bench`.
#[macro_export]
macro_rules! wide {
    ($body:expr) => {
        $crate::simd::wide!(true, $body)
    };
    ($worth:expr, $body:expr) => {{
        #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
        fn avx2_fma<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        if $worth && $crate::simd::has_avx2_fma() {
            // Everything inlined into the wrapper gets its features, hence `inline(always)`.
            #[allow(unused_unsafe)]
            // SAFETY: the CPU has the features, just checked.
            unsafe {
                avx2_fma(
                    #[inline(always)]
                    || $body,
                )
            }
        } else {
            $body
        }
    }};
}
