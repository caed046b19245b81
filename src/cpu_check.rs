//! A processor without the instructions this build was compiled for (`.cargo/config.toml`
//! asks for x86-64-v3 on x86-64: AVX2, FMA, BMI2 and the rest) would end the process at the
//! first one with SIGILL and no word of why, and `main`'s own first instructions are such. So
//! the check runs before `main`, from `.init_array`, in a function of integer instructions
//! only (`cpuid`, `xgetbv` and bit tests), and writes a report that is static text through the
//! standard library, which is built for plain x86-64. `std::is_x86_feature_detected!` cannot
//! do it: for a feature the build enables it answers yes without asking the processor.

// A portable build has no check to run: the rest is there for the tests.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

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

/// Bit `bit`, where `enabled`.
const fn on(bit: u32, enabled: bool) -> u32 {
    if enabled { 1 << bit } else { 0 }
}

/// The features of x86-64-v3 this build was compiled to use: all of them as `.cargo/config.toml`
/// asks, and only some where `-C target-cpu=native` built for a processor with some (a
/// virtual machine may hide MOVBE and show AVX2).
pub const BUILT: Cpuid = {
    let avx = cfg!(target_feature = "avx");
    Cpuid {
        leaf1_ecx: on(12, cfg!(target_feature = "fma"))
            | on(22, cfg!(target_feature = "movbe"))
            | on(27, avx)
            | on(28, avx)
            | on(29, cfg!(target_feature = "f16c")),
        leaf7_ebx: on(3, cfg!(target_feature = "bmi1"))
            | on(5, cfg!(target_feature = "avx2"))
            | on(8, cfg!(target_feature = "bmi2")),
        ext_ecx: on(5, cfg!(target_feature = "lzcnt")),
        xcr0: if avx { 1 << 1 | 1 << 2 } else { 0 },
    }
};

/// Whether the processor `c` describes has every feature of `required`.
pub fn has(c: Cpuid, required: Cpuid) -> bool {
    c.leaf1_ecx & required.leaf1_ecx == required.leaf1_ecx
        && c.leaf7_ebx & required.leaf7_ebx == required.leaf7_ebx
        && c.ext_ecx & required.ext_ecx == required.ext_ecx
        && c.xcr0 & required.xcr0 == required.xcr0
}

/// What a processor without them is told, with how to build for it.
pub const REPORT: &str = "error: this build of hyperslice uses instructions this processor \
does not have (of x86-64-v3's AVX2, FMA, BMI1, BMI2, LZCNT, MOVBE, F16C)\n  = note: x86-64 builds \
use them by default (.cargo/config.toml)\n  = help: build for this processor: \
RUSTFLAGS=\"-C target-cpu=native\" cargo build --release\n";

#[cfg(all(
    target_arch = "x86_64",
    any(
        target_feature = "avx",
        target_feature = "fma",
        target_feature = "bmi1",
        target_feature = "lzcnt",
        target_feature = "movbe",
        target_feature = "f16c"
    )
))]
mod before_main {
    use super::{BUILT, Cpuid, REPORT, has};
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
        if !has(read(), BUILT) {
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

    /// x86-64-v3's features, where `cpuid` and `xgetbv` show them.
    const V3: Cpuid = Cpuid {
        leaf1_ecx: 1 << 12 | 1 << 22 | 1 << 27 | 1 << 28 | 1 << 29,
        leaf7_ebx: 1 << 3 | 1 << 5 | 1 << 8,
        ext_ecx: 1 << 5,
        xcr0: 1 << 1 | 1 << 2,
    };

    const ALL: Cpuid = Cpuid {
        leaf1_ecx: u32::MAX,
        leaf7_ebx: u32::MAX,
        ext_ecx: u32::MAX,
        xcr0: u64::MAX,
    };

    /// Each feature's bit, taken away alone, makes the processor one that cannot run a v3
    /// build; a processor with every bit runs it. This build requires what it was built for.
    #[test]
    fn every_feature_of_x86_64_v3_is_required() {
        assert!(has(ALL, V3));
        // Every bit of V3, cleared alone.
        let bits = |mask: u64| (0..64).filter(move |b| mask >> b & 1 == 1);
        let without = (bits(V3.leaf1_ecx.into()).map(|b| Cpuid {
            leaf1_ecx: !(1 << b),
            ..ALL
        }))
        .chain(bits(V3.leaf7_ebx.into()).map(|b| Cpuid {
            leaf7_ebx: !(1 << b),
            ..ALL
        }))
        .chain(bits(V3.ext_ecx.into()).map(|b| Cpuid {
            ext_ecx: !(1 << b),
            ..ALL
        }))
        .chain(bits(V3.xcr0).map(|b| Cpuid {
            xcr0: !(1 << b),
            ..ALL
        }));
        for c in without {
            assert!(!has(c, V3), "{c:?}");
        }
        assert!(REPORT.contains("RUSTFLAGS=\"-C target-cpu=native\""));
        let v3 = cfg!(all(target_feature = "avx2", target_feature = "fma"));
        assert!(!v3 || has(BUILT, V3) && has(V3, BUILT), "{BUILT:?}");
    }
}
