//! The binary built for x86-64-v3 (`.cargo/config.toml`) on a processor without it, emulated
//! by `qemu-x86_64 -cpu Nehalem` (SSE4.2, no AVX): it must say what is missing and how to
//! build for that processor, and exit with 2, where it would otherwise die of SIGILL. Where
//! qemu-user is not installed (`.ci/run` installs it where it can) the test says so and
//! checks nothing else; the decoding of `cpuid` itself is unit-tested in `src/cpu_check.rs`.

use std::process::Command;

#[test]
fn a_processor_without_x86_64_v3_is_told_how_to_build_for_it() {
    if !cfg!(all(target_arch = "x86_64", target_feature = "avx2")) {
        eprintln!("a portable build: nothing to check");
        return;
    }
    let bin = env!("CARGO_BIN_EXE_hyperslice");
    let run = |cpu: &str| {
        Command::new("qemu-x86_64")
            .args(["-cpu", cpu, bin, "--version"])
            .output()
    };
    let Ok(old) = run("Nehalem") else {
        eprintln!("qemu-x86_64 is not installed: skipped");
        return;
    };
    let stderr = String::from_utf8_lossy(&old.stderr);
    assert_eq!(old.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("x86-64-v3's AVX2, FMA"), "{stderr}");
    assert!(
        stderr.contains("RUSTFLAGS=\"-C target-cpu=native\""),
        "{stderr}"
    );
    // A processor with the features runs it.
    let new = run("Haswell").expect("qemu ran once");
    assert!(
        new.status.success(),
        "{}",
        String::from_utf8_lossy(&new.stderr)
    );
    assert!(String::from_utf8_lossy(&new.stdout).starts_with("hyperslice "));
}
