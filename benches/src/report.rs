//! What the benchmark prints: the machine and settings, a table of results, and the targets.

use crate::Opts;

/// One contender on one scene and workload.
pub struct Row {
    scene: &'static str,
    workload: &'static str,
    contender: &'static str,
    points: usize,
    ns_per_point: f64,
    max_abs_err: f32,
    /// Points off the native scalar result by more than 1e-4 * max(1, |d|).
    disagreeing: usize,
    id_mismatches: Option<usize>,
}

impl Row {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &'static str,
        workload: &'static str,
        contender: &'static str,
        points: usize,
        ns_per_point: f64,
        out: &[f32],
        reference: &[f32],
        reach: Option<&[f32]>,
        id_mismatches: Option<usize>,
    ) -> Row {
        let mut max_abs_err = 0.0f32;
        let mut disagreeing = 0;
        for (i, (&a, &r)) in out.iter().zip(reference).enumerate() {
            // At or beyond its reach, a pruned value is a bound: only exceeding the distance
            // is an error.
            let bound = reach.is_some_and(|reach| a >= reach[i]);
            let err = if bound {
                (a - r).max(0.0)
            } else {
                (a - r).abs()
            };
            // NaN counts as a disagreement, and as an infinite error.
            let err = if err.is_nan() { f32::INFINITY } else { err };
            max_abs_err = max_abs_err.max(err);
            if err > 1e-4 * r.abs().max(1.0) {
                disagreeing += 1;
            }
        }
        Row {
            scene,
            workload,
            contender,
            points,
            ns_per_point,
            max_abs_err,
            disagreeing,
            id_mismatches,
        }
    }
}

pub fn header(opts: &Opts) {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| {
            l.strip_prefix("model name")
                .map(|m| m.trim_start_matches([' ', '\t', ':']))
        })
        .unwrap_or("unknown CPU");
    let threads = std::thread::available_parallelism().map_or(0, |n| n.get());
    let args: Vec<String> = std::env::args().skip(1).collect();
    println!("# SDF evaluation benchmark (hyperslice-bench)");
    println!(
        "machine:  {model}, {threads} hardware threads; native kernels use {}",
        crate::native::isa()
    );
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let load: Vec<&str> = load.split_whitespace().take(3).collect();
    println!(
        "load:     {} (1, 5, 15 min averages at start; other processes add noise)",
        load.join(" ")
    );
    println!(
        "command:  cargo run --release -p hyperslice-bench -- {}",
        args.join(" ")
    );
    println!(
        "settings: {} random points; march = 64x64 rays, <= 64 steps each; {} timed runs after 1 \
         warm-up, round-robin, median; fidget chunk {} points; single thread",
        opts.points, opts.runs, opts.fidget_chunk
    );
    println!();
}

fn find<'a>(rows: &'a [Row], scene: &str, workload: &str, contender: &str) -> Option<&'a Row> {
    rows.iter()
        .find(|r| r.scene == scene && r.workload == workload && r.contender == contender)
}

const PACKET: &str = "native packet [f32;8]";

pub fn table(rows: &[Row]) {
    println!();
    println!(
        "| {:<10} | {:<8} | {:>7} | {:<21} | {:>9} | {:>9} | {:>11} | {:<12} |",
        "scene",
        "workload",
        "points",
        "contender",
        "ns/point",
        "/packet",
        "max abs err",
        "agreement"
    );
    println!(
        "|{:-<12}|{:-<10}|{:-<9}|{:-<23}|{:->11}|{:->11}|{:->13}|{:-<14}|",
        "", "", "", "", "", "", "", ""
    );
    for r in rows {
        let packet = find(rows, r.scene, r.workload, PACKET).map_or(f64::NAN, |p| p.ns_per_point);
        let mut agreement = if r.disagreeing == 0 {
            "ok".to_string()
        } else {
            format!("{} differ", r.disagreeing)
        };
        if let Some(m) = r.id_mismatches {
            agreement += &format!(
                ", ids {}",
                if m == 0 {
                    "ok".to_string()
                } else {
                    format!("{m} differ")
                }
            );
        }
        println!(
            "| {:<10} | {:<8} | {:>7} | {:<21} | {:>9.2} | {:>9.2} | {:>11.2e} | {:<12} |",
            r.scene,
            r.workload,
            r.points,
            r.contender,
            r.ns_per_point,
            r.ns_per_point / packet,
            r.max_abs_err,
            agreement
        );
    }
}

/// The VM's targets: batched within 1.25x of native packets, no slower than fidget's JIT, and at
/// least 20x faster than fidget's interpreter.
pub fn targets(rows: &[Row]) {
    println!();
    println!(
        "targets: VM batched / native packet <= 1.25, VM batched / fidget JIT <= 1.0, fidget interp / VM batched >= 20"
    );
    let mut seen = Vec::new();
    for r in rows {
        if seen.contains(&(r.scene, r.workload)) {
            continue;
        }
        seen.push((r.scene, r.workload));
        let ns = |c| find(rows, r.scene, r.workload, c).map_or(f64::NAN, |r| r.ns_per_point);
        let vm = ns("VM batched");
        let checks = [
            ("VM/packet", vm / ns(PACKET), vm / ns(PACKET) <= 1.25),
            (
                "VM/JIT",
                vm / ns("fidget JIT"),
                vm / ns("fidget JIT") <= 1.0,
            ),
            (
                "interp/VM",
                ns("fidget interp") / vm,
                ns("fidget interp") / vm >= 20.0,
            ),
        ];
        let line: Vec<String> = checks
            .iter()
            .map(|(what, v, ok)| format!("{what} {v:6.2} {}", if *ok { "pass" } else { "FAIL" }))
            .collect();
        println!("  {:<10} {:<8} {}", r.scene, r.workload, line.join("   "));
    }
}
