//! The SDF evaluation benchmark (docs: `docs/performance.md`, "SDF evaluation: the VM against
//! native Rust and fidget").
//!
//! Every scene is evaluated over two point sets (uniform random points, and the points a sphere
//! tracer visits) by every contender: native scalar and packet code, fidget's interpreter and JIT,
//! and the project's VM (batched, one point per call, and on the pruned tapes of
//! the renderer's cells). Each contender gets a warm-up run, then
//! `--runs` timed runs taken round-robin across contenders; we report the median ns per point,
//! the ratio to the native packet code, and the largest difference from the native scalar result.
//! Single-threaded throughout.
//!
//!     cargo run --release -p hyperslice-bench [-- --points N --runs K --scene NAME]

mod contenders;
mod fidget_eval;
mod native;
mod num;
mod packet;
mod report;
mod rng;
mod scenes;
mod sdf;
mod vm;
mod workload;

use clap::Parser;
use contenders::{Cells, Contender, Fidget, Native, Vm};
use report::Row;
use scenes::{D4Tiled, Room, Scene, Spheres16, Spheres1024, Union200};
use std::path::PathBuf;
use std::time::Instant;
use vm::VmCells;

#[derive(Parser)]
#[command(about = "SDF evaluation benchmark: the hyperslice VM against native Rust and fidget")]
pub struct Opts {
    /// Number of uniform random points.
    #[arg(long, default_value_t = 65536)]
    points: usize,
    /// Timed runs per contender (after one warm-up run); the median is reported.
    #[arg(long, default_value_t = 7)]
    runs: usize,
    /// Only scenes whose name contains this.
    #[arg(long)]
    scene: Option<String>,
    /// Points per fidget evaluator call.
    #[arg(long, default_value_t = 1024)]
    fidget_chunk: usize,
    /// Also write each scene's `.4ds` source into this directory.
    #[arg(long)]
    emit: Option<PathBuf>,
}

fn main() {
    let opts = Opts::parse();
    assert!(opts.runs >= 1 && opts.points >= 1 && opts.fidget_chunk >= 1);
    report::header(&opts);
    let mut rows = Vec::new();
    bench(&Spheres16::new(), &opts, &mut rows);
    bench(&D4Tiled::new(), &opts, &mut rows);
    bench(&Room::new(), &opts, &mut rows);
    bench(&Union200::new(), &opts, &mut rows);
    bench(&Spheres1024::new(), &opts, &mut rows);
    report::table(&rows);
    report::targets(&rows);
}

/// Benchmarks every contender on one scene, over both workloads.
fn bench<S: Scene>(scene: &S, opts: &Opts, rows: &mut Vec<Row>) {
    if opts
        .scene
        .as_ref()
        .is_some_and(|f| !scene.name().contains(f.as_str()))
    {
        return;
    }
    let source = scene.source();
    if let Some(dir) = &opts.emit {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join(format!("{}.4ds", scene.name())), &source).unwrap();
    }

    let interp = Fidget::<fidget::vm::VmFunction>::new("fidget interp", scene, opts.fidget_chunk);
    let jit = Fidget::<fidget::jit::JitFunction>::new("fidget JIT", scene, opts.fidget_chunk);
    let vm_batched = Vm::batched(&source);
    let (vm_ops, vm_regs) = vm_batched.tape_size();
    println!(
        "{}: {} bytes of .4ds; VM tape {vm_ops} instructions in {vm_regs} registers; fidget tape {} ops",
        scene.name(),
        source.len(),
        interp.tape_len()
    );
    let mut contenders: Vec<Box<dyn Contender + '_>> = vec![
        Box::new(Native::scalar(scene)),
        Box::new(Native::packet(scene)),
        Box::new(interp),
        Box::new(jit),
        Box::new(vm_batched),
        Box::new(Vm::point(&source)),
        Box::new(Cells(VmCells::compile(&source))),
    ];

    let cam = workload::Camera::at(scene.camera());
    assert!(
        native::scalar(scene)(cam.origin) > 0.0,
        "{}: camera inside a surface",
        scene.name()
    );
    let workloads = [
        ("random", workload::uniform(opts.points, scene.half_width())),
        ("march", workload::march(native::scalar(scene), &cam)),
    ];

    for (workload, pts) in &workloads {
        let n = pts.len();
        let mut reference = vec![0.0; n];
        contenders[0].run(pts, &mut reference);
        let reference_ids = contenders[0].ids().map(<[f32]>::to_vec);
        let mut outs = vec![vec![f32::NAN; n]; contenders.len()];
        for (c, out) in contenders.iter_mut().zip(&mut outs) {
            c.run(pts, out); // warm-up
        }
        // Round-robin, so that a burst of noise from other processes hits every contender.
        let mut times = vec![Vec::new(); contenders.len()];
        for _ in 0..opts.runs {
            for ((c, out), t) in contenders.iter_mut().zip(&mut outs).zip(&mut times) {
                let start = Instant::now();
                c.run(pts, out);
                t.push(start.elapsed().as_secs_f64());
            }
        }
        for ((c, out), mut t) in contenders.iter().zip(&outs).zip(times) {
            t.sort_by(f64::total_cmp);
            let id_mismatches = match (c.ids(), &reference_ids) {
                (Some(ids), Some(r)) => Some(ids.iter().zip(r).filter(|(a, b)| a != b).count()),
                _ => None,
            };
            let ns_per_point = t[t.len() / 2] * 1e9 / n as f64;
            rows.push(Row::new(
                scene.name(),
                workload,
                c.name(),
                n,
                ns_per_point,
                out,
                &reference,
                c.reach(),
                id_mismatches,
            ));
        }
    }
}
