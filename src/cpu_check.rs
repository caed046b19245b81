//! A processor without the instructions this build was compiled for (`.cargo/config.toml`
//! asks for x86-64-v3 on x86-64: AVX2, FMA, BMI2 and the rest) would end the process at the
//! first one with SIGILL and no word of why, and `main`'s own first instructions are such. So
//! the check runs before `main`, from `.init_array`, in a function of integer instructions
//! only (`cpuid`, `xgetbv` and bit tests), and writes a report that is static text through the
//! standard library, which is built for plain x86-64. `std::is_x86_feature_detected!` cannot
//! do it: for a feature the build enables it answers yes without asking the processor.

// A portable build has no check to run: the rest is there for the tests.
#![cfg_attr(
    not(all(target_arch = "x86_64", target_feature = "avx2")),
    allow(dead_code)
)]

/// What `cpuid` and `xgetbv` say of the processor, where x86-64-v3's features are.
#[derive(Clone, Copy, Debug)]
pub struct Cpuid {
    /// Leaf 1, ECX: FMA (12), MOVBE (22), OSXSAVE (27), AVX (28), F16C (29).
    pub leaf1_ecx: u32,
    /// Leaf 7, EBX: BMI1 (3), AVX2 (5), BMI2 (8); 0 where the leaf does not exist.
    pub leaf7_ebx: u32,
    /// Leaf 0x8000_0001, ECX: LZCNT (5); 0 where the leaf does not exist.
    pub ext_ecx: u32,
    /// XCR0, where OSXSAVE says it can be read: the operating system saves the SSE (1) and
    /// AVX (2) registers.
    pub xcr0: u64,
}

/// Whether the processor `c` describes runs x86-64-v3 code.
pub fn runs_v3(c: Cpuid) -> bool {
    const LEAF1: u32 = 1 << 12 | 1 << 22 | 1 << 27 | 1 << 28 | 1 << 29;
    const LEAF7: u32 = 1 << 3 | 1 << 5 | 1 << 8;
    const EXT: u32 = 1 << 5;
    const XCR0: u64 = 1 << 1 | 1 << 2;
    c.leaf1_ecx & LEAF1 == LEAF1
        && c.leaf7_ebx & LEAF7 == LEAF7
        && c.ext_ecx & EXT == EXT
        && c.xcr0 & XCR0 == XCR0
}

/// What a processor without them is told, with how to build for it.
pub const REPORT: &str = "error: this build of hyperslice uses instructions this processor \
does not have (x86-64-v3: AVX2, FMA, BMI1, BMI2, LZCNT, MOVBE, F16C)\n  = note: x86-64 builds \
use them by default (.cargo/config.toml)\n  = help: build for this processor: \
RUSTFLAGS=\"-C target-cpu=native\" cargo build --release\n";

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod before_main {
    use super::{Cpuid, REPORT, runs_v3};
    use std::arch::x86_64::{__cpuid, __cpuid_count, __get_cpuid_max, _xgetbv};

    fn read() -> Cpuid {
        // SAFETY: `cpuid` exists on every x86-64 processor, leaves are read only up to the
        // highest one it reports, and `xgetbv` only where OSXSAVE says the OS enabled it.
        unsafe {
            let leaf1_ecx = __cpuid(1).ecx;
            let leaf7_ebx = match __get_cpuid_max(0).0 >= 7 {
                true => __cpuid_count(7, 0).ebx,
                false => 0,
            };
            let ext_ecx = match __get_cpuid_max(0x8000_0000).0 >= 0x8000_0001 {
                true => __cpuid(0x8000_0001).ecx,
                false => 0,
            };
            let xcr0 = match leaf1_ecx & 1 << 27 != 0 {
                true => _xgetbv(0),
                false => 0,
            };
            Cpuid {
                leaf1_ecx,
                leaf7_ebx,
                ext_ecx,
                xcr0,
            }
        }
    }

    extern "C" fn check() {
        if !runs_v3(read()) {
            let _ = std::io::Write::write_all(&mut std::io::stderr(), REPORT.as_bytes());
            std::process::exit(2);
        }
    }

    #[cfg(target_os = "linux")]
    #[used]
    #[unsafe(link_section = ".init_array")]
    static CHECK: extern "C" fn() = check;
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: Cpuid = Cpuid {
        leaf1_ecx: u32::MAX,
        leaf7_ebx: u32::MAX,
        ext_ecx: u32::MAX,
        xcr0: u64::MAX,
    };

    /// Each feature's bit, taken away alone, makes the processor one that cannot run the
    /// build; a processor with every bit runs it.
    #[test]
    fn every_feature_of_x86_64_v3_is_required() {
        assert!(runs_v3(ALL));
        let without = [
            Cpuid {
                leaf1_ecx: !(1 << 12),
                ..ALL
            },
            Cpuid {
                leaf1_ecx: !(1 << 22),
                ..ALL
            },
            Cpuid {
                leaf1_ecx: !(1 << 27),
                ..ALL
            },
            Cpuid {
                leaf1_ecx: !(1 << 28),
                ..ALL
            },
            Cpuid {
                leaf1_ecx: !(1 << 29),
                ..ALL
            },
            Cpuid {
                leaf7_ebx: !(1 << 3),
                ..ALL
            },
            Cpuid {
                leaf7_ebx: !(1 << 5),
                ..ALL
            },
            Cpuid {
                leaf7_ebx: !(1 << 8),
                ..ALL
            },
            Cpuid {
                ext_ecx: !(1 << 5),
                ..ALL
            },
            Cpuid {
                xcr0: !(1 << 2),
                ..ALL
            },
        ];
        for c in without {
            assert!(!runs_v3(c), "{c:?}");
        }
        assert!(REPORT.contains("RUSTFLAGS=\"-C target-cpu=native\""));
    }
}
