//! The VM against the plain IR: for every example and test scene the optimised bytecode must
//! agree with a tree-walking evaluation of the unoptimised graph; the batched and one-point
//! paths must agree exactly; derivatives must match central differences; interval bounds must
//! contain every value; and every primitive and operation must be a distance bound.

use hyperslice::Compilation;
use hyperslice::ir;
use hyperslice::ir::Var;
use hyperslice::ir::eval::{Reference, vars};
use hyperslice::ir::exact::Reach;
use hyperslice::ir::interval::{Along, I, Intervals};
use hyperslice::scene::Scene;
use hyperslice::vm::{self, Dual, LANES, Program, Regs, Tape};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f64::consts::FRAC_1_SQRT_2;
use std::path::{Path, PathBuf};

fn scene_files() -> Vec<PathBuf> {
    let mut out = vec![];
    for dir in ["examples", "tests/in"] {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "4ds") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn compile_file(p: &Path) -> Scene {
    let c = Compilation::from_path(p);
    assert!(
        !c.has_errors(),
        "{}: {}",
        p.display(),
        c.render_diagnostics(false)
    );
    c.scene.unwrap()
}

fn compile_text(src: &str) -> Scene {
    let c = Compilation::from_source("test.4ds", src);
    assert!(!c.has_errors(), "{src}\n{}", c.render_diagnostics(false));
    c.scene.unwrap()
}

fn random_point(rng: &mut Pcg64Mcg, r: f64) -> [f64; 4] {
    std::array::from_fn(|_| rng.random_range(-r..r))
}

fn random_unit(rng: &mut Pcg64Mcg) -> [f64; 4] {
    let v = random_point(rng, 1.0);
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-9);
    v.map(|x| x / n)
}

fn to32(p: [f64; 4]) -> [f32; 4] {
    p.map(|x| x as f32)
}

/// f32 evaluation of long chains drifts from f64: allow a relative error that grows with the
/// magnitudes involved.
fn close(vm: f32, reference: f64, scale: f64) -> bool {
    let (a, b) = (vm as f64, reference);
    if a.is_infinite() || b.is_infinite() {
        return a == b;
    }
    (a - b).abs() <= 2e-4 * (1.0 + b.abs() + scale)
}

#[test]
fn optimised_bytecode_matches_the_plain_ir() {
    let mut rng = Pcg64Mcg::seed_from_u64(1);
    let mut checked = 0;
    for file in scene_files() {
        let scene = compile_file(&file);
        let raw = ir::lower(&scene);
        let prog = hyperslice::compile::program(&raw, None);
        let roots = raw.roots();
        let mut reference = Reference::new(&raw.graph, &roots);
        let mut one = Regs::<f32, 1>::new(&prog.scene);
        for _ in 0..2000 {
            let p = random_point(&mut rng, 4.0);
            let n = random_unit(&mut rng);
            let t = rng.random_range(0.0..1.0);
            reference.run(&vars(p, n, t));
            let want = |id| reference.value(id);
            let scale = p.iter().map(|x| x.abs()).sum::<f64>();
            let got = vm::eval_point(&prog.scene, &mut one, to32(p), to32(n), t as f32);
            let d = want(raw.distance);
            assert!(
                close(got[0], d, scale),
                "{}: scene distance at {p:?} t={t}: vm {} vs ir {d}",
                file.display(),
                got[0]
            );
            for (o, tapes) in raw.objects.iter().zip(&prog.objects) {
                let got = vm::eval_point(&tapes.distance, &mut one, to32(p), to32(n), t as f32);
                let d = want(o.distance);
                assert!(
                    close(got[0], d, scale),
                    "{}: object {} at {p:?}: vm {} vs ir {d}",
                    file.display(),
                    o.name,
                    got[0]
                );
                let got = vm::eval_point(&tapes.material, &mut one, to32(p), to32(n), t as f32);
                for (g, id) in got.iter().zip(o.material.roots()) {
                    assert!(
                        close(*g, want(id), scale),
                        "{}: material of {} at {p:?}: vm {g} vs ir {}",
                        file.display(),
                        o.name,
                        want(id)
                    );
                }
            }
            // The nearest object agrees unless two objects are equally near.
            let id = got_nearest(&prog, &mut one, p, n, t);
            let want_id = want(raw.nearest);
            if id != want_id as f32 {
                let gap = (want(raw.objects[id as usize].distance) - d).abs();
                assert!(
                    gap < 1e-3 * (1.0 + scale),
                    "{}: nearest {id} vs {want_id}",
                    file.display()
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 2000 * 19, "checked {checked} points");
}

fn got_nearest(prog: &Program, regs: &mut Regs<f32, 1>, p: [f64; 4], n: [f64; 4], t: f64) -> f32 {
    vm::eval_point(&prog.scene, regs, to32(p), to32(n), t as f32)[1]
}

#[test]
fn batched_and_single_point_paths_agree_exactly() {
    let mut rng = Pcg64Mcg::seed_from_u64(2);
    for file in scene_files() {
        let prog = hyperslice::compile::Compiled::new(&compile_file(&file)).program(None);
        let n = 1000;
        let pts: Vec<[f32; 4]> = (0..n).map(|_| to32(random_point(&mut rng, 5.0))).collect();
        let soa: [Vec<f32>; 4] = std::array::from_fn(|a| pts.iter().map(|p| p[a]).collect());
        for tape in prog
            .tapes()
            .filter(|t| t.inputs.iter().all(|v| v.index() < 4 || v.index() == 8))
        {
            let mut batch = Regs::<f32, LANES>::new(tape);
            let mut out = vec![0.0; n];
            vm::eval_slices(
                tape,
                &mut batch,
                [&soa[0], &soa[1], &soa[2], &soa[3]],
                0.25,
                &mut out,
            );
            let mut one = Regs::<f32, 1>::new(tape);
            for (p, b) in pts.iter().zip(&out) {
                let s = vm::eval_point(tape, &mut one, *p, [0.0; 4], 0.25)[0];
                assert!(
                    s.to_bits() == b.to_bits() || (s.is_nan() && b.is_nan()),
                    "{} tape {}: batched {b} vs single {s} at {p:?}",
                    file.display(),
                    tape.name
                );
            }
        }
    }
}

/// Central differences in f64 on the reference, kept only where the field is smooth (two step
/// sizes agree), against the forward-mode gradient of the optimised tape.
#[test]
fn gradients_match_central_differences() {
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let (mut smooth, mut total) = (0, 0);
    for file in scene_files() {
        let scene = compile_file(&file);
        let raw = ir::lower(&scene);
        let prog = hyperslice::compile::program(&raw, None);
        for (o, tapes) in raw.objects.iter().zip(&prog.objects) {
            let mut reference = Reference::new(&raw.graph, &[o.distance]);
            let mut f = |p: [f64; 4]| {
                reference.run(&vars(p, [0.0; 4], 0.5));
                reference.value(o.distance)
            };
            let mut regs = Regs::<Dual, 8>::new(&tapes.distance);
            for _ in 0..100 {
                let p = random_point(&mut rng, 3.0);
                let fd = |f: &mut dyn FnMut([f64; 4]) -> f64, h: f64| -> [f64; 4] {
                    std::array::from_fn(|a| {
                        let (mut lo, mut hi) = (p, p);
                        lo[a] -= h;
                        hi[a] += h;
                        (f(hi) - f(lo)) / (2.0 * h)
                    })
                };
                let (g1, g2) = (fd(&mut f, 1e-4), fd(&mut f, 5e-5));
                total += 1;
                if g1.iter().zip(&g2).any(|(a, b)| (a - b).abs() > 1e-4)
                    || g1.iter().any(|x| !x.is_finite())
                {
                    continue;
                }
                smooth += 1;
                let d = vm::gradient(&tapes.distance, &mut regs, &[to32(p)], 0.5)[0];
                for (a, want) in g1.iter().enumerate() {
                    assert!(
                        (d.g[a] as f64 - want).abs() < 2e-3 * (1.0 + want.abs()),
                        "{} {}: d/d{a} at {p:?}: forward {} vs central {want}",
                        file.display(),
                        o.name,
                        d.g[a],
                    );
                }
            }
        }
    }
    assert!(
        smooth * 2 > total,
        "only {smooth} of {total} points were smooth"
    );
}

#[test]
fn interval_bounds_contain_every_value() {
    let mut rng = Pcg64Mcg::seed_from_u64(4);
    for file in scene_files() {
        let prog = hyperslice::compile::Compiled::new(&compile_file(&file)).program(None);
        let g = &prog.ir.graph;
        let mut one = Regs::<f32, 1>::new(&prog.scene);
        for _ in 0..40 {
            let c = random_point(&mut rng, 4.0);
            let r = rng.random_range(0.0..1.5);
            let n = random_unit(&mut rng);
            let vars = |v: Var| match v.index() {
                a @ 0..4 => I::new(c[a] - r, c[a] + r),
                a @ 4..8 => I::point(n[a - 4]),
                _ => I::new(0.0, 1.0),
            };
            let bounds = Intervals::of(g, &vars, None);
            for (tape, roots) in tapes_and_roots(&prog) {
                for _ in 0..30 {
                    let p: [f32; 4] =
                        std::array::from_fn(|a| (c[a] + rng.random_range(-r..=r)) as f32);
                    let t = rng.random_range(0.0..1.0);
                    let v = vm::eval_point(tape, &mut one, p, to32(n), t as f32);
                    for (root, x) in roots.iter().zip(&v) {
                        let b = bounds.get(*root);
                        let x = *x as f64;
                        let slack = 1e-4 * (1.0 + x.abs());
                        assert!(
                            I::new(b.lo - slack, b.hi + slack).contains(x),
                            "{} tape {}: {x} outside {b:?} at {p:?}",
                            file.display(),
                            tape.name
                        );
                    }
                }
            }
        }
    }
}

/// The reference's inputs at 17 points evenly along the stretch of `len` from `o` along `d`
/// (at time 0.5), each with its distance along the stretch.
fn stretch(o: [f64; 4], d: [f64; 4], len: f64) -> impl Iterator<Item = (f64, [f64; 9])> {
    (0..=16).map(move |k| {
        let s = len * k as f64 / 16.0;
        (
            s,
            vars(std::array::from_fn(|a| o[a] + d[a] * s), [0.0; 4], 0.5),
        )
    })
}

/// Bounds along a stretch of a ray (`Intervals::along`, what escape proofs and crawling rays'
/// leaps rest on) hold every value the reference takes on it, for the examples, the test
/// scenes and generated ones, over stretches from none to the rest of the ray; over no
/// stretch they are the value itself.
#[test]
fn bounds_along_a_stretch_contain_every_value_on_it() {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let mut scenes: Vec<(Scene, f64)> = (scene_files().iter())
        .map(|f| (compile_file(f), 4.0))
        .collect();
    for seed in 1..=60 {
        let g = hyperslice::generate::generate(seed);
        let c = Compilation::from_source("generated.4ds", &g.source);
        scenes.push((c.scene.expect("a generated scene"), 4.0 * g.scale));
    }
    let mut along = Along::default();
    for (scene, scale) in &scenes {
        let prog = hyperslice::compile::Compiled::new(scene).program(Some(0.5));
        let ir = &prog.ir;
        let roots: Vec<_> = [ir.distance]
            .into_iter()
            .chain(ir.interior.map(|i| i.0))
            .collect();
        let mut reference = Reference::new(&ir.graph, &roots);
        for _ in 0..20 {
            let o = random_point(&mut rng, *scale);
            let d = random_unit(&mut rng);
            let len = [0.0, 1e-3, 0.1, 1.0, 10.0][rng.random_range(0..5)] * scale;
            let bounds = Intervals::along(&mut along, &ir.graph, o, d, len);
            for (s, at) in stretch(o, d, len) {
                reference.run(&at);
                for root in &roots {
                    let (b, x) = (bounds.get(*root), reference.value(*root));
                    let slack = 1e-9 * (scale + x.abs());
                    assert!(
                        I::new(b.lo - slack, b.hi + slack).contains(x),
                        "{x} outside {b:?} at s = {s} of {len} from {o:?} along {d:?}"
                    );
                    if len == 0.0 && x.is_finite() {
                        assert!((b.lo - x).abs() <= slack && (b.hi - x).abs() <= slack);
                    }
                }
            }
        }
    }
}

/// A stretch `Escape::clear` proves clear meets no surface: the reference distance stays above
/// zero all along it. On the examples, the test scenes and generated ones, over random
/// stretches; and down a channel of the D4 packing, where the stretch is split at the
/// lattice's cells and proven piece by piece, the whole of it (at most 32 cells).
#[test]
fn stretches_proven_clear_meet_no_surface() {
    use glam::DVec4;
    use hyperslice::vm::escape::{Escape, Proofs};
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    // (scene, scale, stretches, their lengths): the D4 packing's short ones, about a cell
    // long, end near its cells' sides.
    let d4 = Path::new("examples/d4_packing.4ds");
    let mut scenes: Vec<(Scene, f64, u32, &[f64])> = (scene_files().iter())
        .map(|f| (compile_file(f), 4.0, 40, &[0.1, 1.0, 10.0, 100.0][..]))
        .collect();
    scenes.push((compile_file(d4), 4.0, 2000, &[0.05, 0.1, 0.2, 0.3]));
    for seed in 1..=60 {
        let g = hyperslice::generate::generate(seed);
        let c = Compilation::from_source("generated.4ds", &g.source);
        let scene = c.scene.expect("a generated scene");
        scenes.push((scene, 4.0 * g.scale, 40, &[0.1, 1.0, 10.0, 100.0]));
    }
    let escape_of = |scene: &Scene| {
        let ir = hyperslice::compile::Compiled::new(scene)
            .program(Some(0.5))
            .ir;
        let scene = (ir.distance, ir.nearest);
        let escape = Escape::new(
            &ir.graph,
            ((DVec4::ZERO, DVec4::ZERO), (DVec4::ZERO, DVec4::ZERO)),
            &[],
            (scene, None),
            (0.5, false),
        );
        (escape, ir)
    };
    let mut proofs = Proofs::default();
    let (mut proven, mut long) = (0, 0);
    for (scene, scale, stretches, lengths) in &scenes {
        let (escape, ir) = escape_of(scene);
        let mut reference = Reference::new(&ir.graph, &[ir.distance]);
        for _ in 0..*stretches {
            let o = DVec4::from_array(random_point(&mut rng, *scale));
            let d = DVec4::from_array(random_unit(&mut rng));
            let len = lengths[rng.random_range(0..lengths.len())] * scale;
            let clear = escape.clear(o, d, len, false, &mut proofs);
            assert!((0.0..=len).contains(&clear), "{clear} of {len}");
            proven += (clear > 0.0) as u32;
            long += (clear > 0.25 * scale) as u32;
            for k in 0..=256 {
                let p = o + d * (clear * k as f64 / 256.0);
                reference.run(&vars(p.to_array(), [0.0; 4], 0.5));
                let x = reference.value(ir.distance);
                assert!(
                    clear == 0.0 || x > -1e-9 * scale,
                    "distance {x} at {p} on the {clear} proven clear from {o} along {d}"
                );
            }
        }
    }
    assert!(
        proven > 2000 && long > 200,
        "{proven} stretches proven, {long} long"
    );
    // Down a channel of the D4 packing (every lattice point at least sqrt(0.75) from its axis,
    // the spheres 0.6): 20 units cross about 28 cells, each side a loose bound alone.
    let (escape, _) = escape_of(&compile_file(d4));
    let (o, d) = (DVec4::new(0.3, 0.5, 0.5, 0.5), DVec4::X);
    assert_eq!(escape.clear(o, d, 20.0, false, &mut proofs), 20.0);
    // Towards the sphere at the lattice point (2, 0, 0, 0), met at x = 1.4: proven up to the
    // side of its cell (x = 1), where the piece that holds it begins.
    let (o, d) = (DVec4::new(0.7, 0.0, 0.0, 0.0), DVec4::X);
    let clear = escape.clear(o, d, 5.0, false, &mut proofs);
    assert!((clear - 0.3).abs() < 1e-12, "{clear}");
}

/// Every tape of a program with the graph roots it computes.
fn tapes_and_roots(prog: &vm::Program) -> Vec<(&Tape, Vec<hyperslice::ir::Id>)> {
    let ir = &prog.ir;
    let mut out = vec![(&prog.scene, vec![ir.distance, ir.nearest])];
    if let (Some(t), Some((d, n))) = (&prog.interior, ir.interior) {
        out.push((t, vec![d, n]));
    }
    for (o, oi) in prog.objects.iter().zip(&ir.objects) {
        out.push((&o.distance, vec![oi.distance]));
        out.push((&o.material, oi.material.roots()));
    }
    out
}

/// No instruction writes a register it reads, and every register is in range.
#[test]
fn register_allocation_is_sound() {
    for file in scene_files() {
        let prog = hyperslice::compile::Compiled::new(&compile_file(&file)).program(None);
        for tape in prog.tapes() {
            for ins in &tape.code {
                let (r, w) = (ins.reads(), ins.writes());
                assert!(
                    w.iter().all(|x| !r.contains(x)),
                    "{}: {ins} overwrites an operand",
                    tape.name
                );
                assert!(r.iter().chain(&w).all(|x| (*x as usize) < tape.regs));
            }
            assert!(tape.outputs.iter().all(|x| (*x as usize) < tape.regs));
        }
    }
}

/// Shapes each of which must be a distance bound, with points known to lie on their surface.
const SHAPES: &[(&str, &[[f64; 4]])] = &[
    (
        "hypersphere(1.2)",
        &[
            [1.2, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, -1.2],
            [0.6, 0.6, 0.6, 0.6],
        ],
    ),
    (
        "halfspace([1, 2, 0, -1], offset: 0.5)",
        &[[0.0, 0.0, 0.0, -0.5 * 2.449489742783178]],
    ),
    (
        "hyperbox([1, 0.5, 2, 0.7])",
        &[
            [1.0, 0.0, 0.0, 0.0],
            [1.0, 0.5, 2.0, 0.7],
            [0.3, -0.5, 0.1, 0.0],
        ],
    ),
    (
        "hyperbox(1, radius: 0.25)",
        &[[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.5]],
    ),
    (
        "spherinder(radius: 0.8, height: 0.5)",
        &[[0.8, 0.0, 0.0, 0.2], [0.0, 0.0, 0.3, 0.5]],
    ),
    (
        "cubinder(radius: 0.8, height: 0.5)",
        &[[0.0, 0.8, 0.1, 0.2], [0.1, 0.0, 0.5, 0.3]],
    ),
    (
        "duocylinder(radius1: 0.8, radius2: 0.5)",
        &[[0.8, 0.0, 0.5, 0.0], [0.0, 0.8, 0.3, 0.0]],
    ),
    ("cell5(1)", &[]),
    (
        "cell16(1)",
        &[[1.0, 0.0, 0.0, 0.0], [0.25, 0.25, 0.25, 0.25]],
    ),
    (
        "cell24(1)",
        &[
            [FRAC_1_SQRT_2, FRAC_1_SQRT_2, 0.0, 0.0],
            [FRAC_1_SQRT_2, 0.0, 0.0, 0.0],
        ],
    ),
    (
        "union(hypersphere(1), hyperbox(0.5) |> translate([1.5, 0, 0, 0]))",
        &[[-1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0]],
    ),
    (
        "union(hypersphere(1), hypersphere(1) |> translate([1.5, 0, 0, 0]), smooth: 0.3)",
        &[[-1.0, 0.0, 0.0, 0.0]],
    ),
    (
        "intersect(hypersphere(1), hyperbox(0.7))",
        &[[0.7, 0.0, 0.0, 0.0]],
    ),
    ("intersect(hypersphere(1), hyperbox(0.7), smooth: 0.2)", &[]),
    (
        "subtract(hyperbox(1), hypersphere(0.5))",
        &[[0.5, 0.0, 0.0, 0.0], [1.0, 0.2, 0.0, 0.0]],
    ),
    ("subtract(hyperbox(1), hypersphere(0.5), smooth: 0.1)", &[]),
    (
        "onion(hypersphere(1), thickness: 0.2)",
        &[[1.1, 0.0, 0.0, 0.0], [0.0, 0.9, 0.0, 0.0]],
    ),
    ("round(hyperbox(0.5), 0.2)", &[[0.7, 0.0, 0.0, 0.0]]),
    (
        "translate(hypersphere(1), [1, 2, 3, 4])",
        &[[2.0, 2.0, 3.0, 4.0]],
    ),
    (
        "rotate(hyperbox([1, 0.2, 0.2, 0.2]), xw, 90deg)",
        &[[0.0, 0.0, 0.0, 1.0], [0.2, 0.0, 0.0, 0.0]],
    ),
    (
        "hyperbox([1, 0.3, 0.2, 0.1]) |> rotate(xy, 30deg) |> rotate(zw, 45deg) |> rotate(yw, 10deg)",
        &[],
    ),
    ("scale(hyperbox(0.5), 3)", &[[1.5, 0.0, 0.0, 0.0]]),
    (
        "symmetry(hypersphere(0.5) |> translate([1, 0, 0, 0]), [1, 0, 0, 0])",
        &[[-1.5, 0.0, 0.0, 0.0], [1.5, 0.0, 0.0, 0.0]],
    ),
    (
        "hypersphere(0.6) |> tile(d4(1))",
        &[[1.6, 1.0, 0.0, 0.0], [0.6, 0.0, 0.0, 0.0]],
    ),
    (
        "hyperbox(0.4) |> tile(grid(2, limit: [2, 0, 1, 0]))",
        &[[4.4, 0.0, 0.0, 0.0], [2.0, 0.4, 2.0, 0.0]],
    ),
    (
        "hypersphere(0.5) |> tile(grid([1.5, 2, 3, 4]))",
        &[[3.5, 0.0, 0.0, 0.0]],
    ),
    ("sdf |p| length(p) - 1", &[[1.0, 0.0, 0.0, 0.0]]),
    ("hypersphere(0.5 + 0.5 * t)", &[]),
    ("hyperbox(1) |> rotate(xw, t * 90deg)", &[]),
    // A blend that grows with `t` has no constant ball.
    (
        "union(hypersphere(0.5) |> translate([-1, 0, 0, 0]), hypersphere(0.5) |> translate([1, 0, 0, 0]), smooth: 2 + 2 * t)",
        &[],
    ),
];

/// Shapes whose balls (`Shape::bounds`) come from more than their primitives' radii: turned
/// about the origin off their centre (at a fixed angle and with `t`), mirrored off their
/// centre, tiled on a limited grid, alone and turned, and polytopes rounded or peeled (whose
/// distances grow their vertices faster than their faces), alone, scaled and blended, and
/// blends of three and four parts (a chain of smooth minima reaches deeper than one).
const BOUNDED: &[&str] = &[
    "hypersphere(0.5) |> translate([2, 1, 0, 0]) |> rotate(xy, 70deg) |> rotate(yw, -30deg)",
    "hyperbox(0.3) |> translate([0, 0, 1.5, 0.5]) |> rotate(zw, t * 180deg)",
    "hypersphere(0.4) |> translate([1, 0.5, 0, 0]) |> symmetry([1, 1, 0, 0])",
    "hypersphere(0.3) |> tile(grid([1, 0.8, 1.2, 0.9], limit: [2, 1, 2, 3]))",
    "round(hypersphere(0.2) |> tile(grid(0.7, limit: [1, 2, 0, 1])), 0.1) |> translate([3, 0, 0, 0]) |> rotate(xz, 40deg)",
    "round(cell16(1), 0.5)",
    "onion(cell5(1), 0.4) |> translate([0.5, 0, 0, 0])",
    "round(cell24(1), 0.3) |> scale(2)",
    "union(round(cell16(0.5), 0.2), hypersphere(0.3) |> translate([1, 0, 0, 0]), smooth: 0.5)",
    "union(hypersphere(1), hypersphere(1.001), hypersphere(0.999), smooth: 1)",
    "union(cell5(1), cell5(1.001), cell5(0.999), hypersphere(0.2), smooth: 0.8)",
];

/// Every shape with a ball (`Shape::bounds`) lies in it: random points around the ball, just
/// outside it and up to twice its radius, are outside the shape (its reference distance is
/// positive there), and so are the known surface points of `SHAPES` inside it. Over the
/// shapes above and every object of 300 generated scenes (tilings, turns, sums of all the
/// parts, at scales from 1e-3 to 1e4).
#[test]
fn every_bounded_shape_lies_in_its_ball() {
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let written = SHAPES
        .iter()
        .map(|(s, on)| (format!("object s {{ shape = {s} }}"), *on))
        .chain(
            BOUNDED
                .iter()
                .map(|s| (format!("object s {{ shape = {s} }}"), &[][..])),
        );
    let generated = (1..=300).map(|seed| (hyperslice::generate::generate(seed).source, &[][..]));
    let mut checked = 0;
    for (source, surface) in written.chain(generated) {
        let scene = compile_text(&source);
        let raw = ir::lower(&scene);
        for (object, lowered) in scene.objects.iter().zip(&raw.objects) {
            let Some((c, r)) = object.shape.bounds() else {
                assert!(
                    !BOUNDED.iter().any(|b| source.contains(b)),
                    "{source}: no ball"
                );
                continue;
            };
            let id = lowered.distance;
            let mut eval = Reference::new(&raw.graph, &[id]);
            let mut at = |p: [f64; 4], t: f64| {
                eval.run(&vars(p, [0.0; 4], t));
                eval.value(id)
            };
            let slack = 1e-9 * (r + c.iter().map(|x| x.abs()).sum::<f64>());
            // A distance bound is at most the distance to the shape, so at the centre at most
            // the radius: a ball in the wrong place fails here whatever its size.
            if BOUNDED.iter().any(|b| source.contains(b)) {
                let d = at(c, 0.5);
                assert!(
                    d <= r + slack,
                    "{source}: distance {d} at its ball's centre {c:?}, radius {r}"
                );
            }
            for p in surface {
                let d: f64 = (0..4).map(|i| (p[i] - c[i]).powi(2)).sum::<f64>().sqrt();
                assert!(
                    d <= r + slack,
                    "{source}: surface point {p:?} outside its ball {c:?}, {r}"
                );
            }
            for _ in 0..400 {
                // Most of them close to the sphere, where a ball a little too small shows.
                let u: f64 = rng.random_range(0.0..1.0);
                let reach = r * (1.0 + 1e-6 + u * u * u);
                let v = random_unit(&mut rng);
                let p = std::array::from_fn(|i| c[i] + v[i] * reach);
                let t = rng.random_range(0.0..1.0);
                let d = at(p, t);
                assert!(
                    d > -slack,
                    "{source}: distance {d} at {p:?} (t = {t}), outside its ball {c:?}, {r}"
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 300, "only {checked} bounded objects");
}

/// Interval bounds prove a box around a custom field of a few spheres (`proven_box`), and none
/// around a halfspace or a D4 packing; no point outside a proven box is inside its object
/// (the reference distance there is positive), just outside its faces or far from it. Over
/// the fields below and every object without a ball in 300 generated scenes.
#[test]
fn proven_boxes_hold_their_objects() {
    const GRID: &str = "sdf |p| length(vec4(p.x - (clamp(floor(p.x / 3 + 2), 0, 3) - 1.5) * 3, \
        p.y - 1, p.z - (clamp(floor(p.z / 3 + 2), 0, 3) - 1.5) * 3, p.w)) - 1";
    // Each field, whether it has a box, and points inside it, which the box must hold.
    let written: [(&str, bool, &[[f64; 4]]); 7] = [
        (
            "sdf |p| length(p - [1, 2, 0, -3]) - 0.5",
            true,
            &[[1.0, 2.0, 0.0, -3.0]],
        ),
        (
            GRID,
            true,
            &[
                [-4.5, 1.0, -4.5, 0.0],
                [4.5, 1.0, 4.5, 0.0],
                [4.5, 1.9, -4.5, 0.9],
            ],
        ),
        (
            "sdf |p| length(p) - 1 - 0.5 * t",
            true,
            &[[1.2, 0.0, 0.0, 0.0]],
        ),
        ("halfspace([0, 1, 0, 0], offset: 0)", false, &[]),
        ("hypersphere(0.5) |> tile(d4(2))", false, &[]),
        ("sdf |p| p.y - 0.5 * floor(p.x)", false, &[]),
        // Bounds of `log` over all of space are NaN below, which a `min` would drop.
        ("sdf |p| min(log(p.y), length(p) - 1)", false, &[]),
    ];
    let written = written.map(|(s, bounded, inside)| {
        (
            format!("object s {{ shape = {s} }}"),
            Some((bounded, inside)),
        )
    });
    let generated = (1..=300).map(|seed| (hyperslice::generate::generate(seed).source, None));
    let mut rng = Pcg64Mcg::seed_from_u64(12);
    let mut checked = 0;
    for (source, expect) in written.into_iter().chain(generated) {
        let scene = compile_text(&source);
        let t = 0.5;
        let program = hyperslice::compile::Compiled::new(&scene).program(Some(t));
        let raw = ir::lower(&scene);
        for (i, object) in scene.objects.iter().enumerate() {
            if object.shape.bounds().is_some() {
                continue;
            }
            let found =
                vm::escape::proven_box(&program.ir.graph, program.ir.objects[i].distance, t);
            if let Some((bounded, _)) = expect {
                assert_eq!(found.is_some(), bounded, "{source}: {found:?}");
            }
            let Some((lo, hi)) = found else {
                continue;
            };
            for p in expect.map_or(&[][..], |e| e.1) {
                assert!(
                    (0..4).all(|a| lo[a] <= p[a] && p[a] <= hi[a]),
                    "{source}: {p:?} outside {lo} .. {hi}"
                );
            }
            let id = raw.objects[i].distance;
            let mut eval = Reference::new(&raw.graph, &[id]);
            let size = (hi - lo).max_element();
            let slack = 1e-9 * (size + lo.abs().max(hi.abs()).max_element());
            for _ in 0..2000 {
                // Uniform in a box three times the size, or just outside one face.
                let mut p: [f64; 4] =
                    std::array::from_fn(|a| lo[a] - size + 3.0 * size * rng.random_range(0.0..1.0));
                if rng.random_bool(0.5) {
                    let a = rng.random_range(0..4);
                    let out = size * rng.random_range(1e-6..1e-2);
                    p[a] = if rng.random_bool(0.5) {
                        hi[a] + out
                    } else {
                        lo[a] - out
                    };
                }
                if (0..4).all(|a| lo[a] <= p[a] && p[a] <= hi[a]) {
                    continue;
                }
                eval.run(&vars(p, [0.0; 4], t));
                let d = eval.value(id);
                assert!(
                    d > -slack,
                    "{source}: distance {d} at {p:?}, outside its box {lo} .. {hi}"
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} objects bounded by intervals");
}

/// An object's cover (`ir::exact::cover`: forms `f_i` with `x >= min_i f_i`) lets an escape
/// proof meet forms instead of bounding the object's graph: a ray that meets none of them
/// must meet nothing of the object. Over every object of 300 generated scenes that gets one,
/// on random rays around it (from random points, in random directions) that the cover says
/// meet none of its forms (each starts outside, has no first meeting, and was not given up),
/// the object's distance, walked in `f64` at 600 points along the ray out to 300 times the
/// scene's size, stays above zero. It fails with a rule broken: a union covered by one of its
/// operands (as an intersection is), or a smooth union's forms not lowered by a quarter of
/// the blend.
#[test]
fn covers_hold_their_objects() {
    let mut rng = Pcg64Mcg::seed_from_u64(13);
    let (mut covered, mut clear, mut reached) = (0, 0, 0);
    for seed in 1..=300 {
        let source = hyperslice::generate::generate(seed).source;
        let scene = compile_text(&source);
        let program = hyperslice::compile::Compiled::new(&scene).program(Some(0.0));
        let g = &program.ir.graph;
        let (from, to) = (scene.camera.from, scene.camera.to);
        let size = (0..4)
            .map(|a| (from[a] - to[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        for object in &program.ir.objects {
            let id = object.distance;
            let Some(cover) = ir::exact::cover(g, id) else {
                continue;
            };
            covered += 1;
            let mut eval = Reference::new(g, &[id]);
            for _ in 0..300 {
                let o: [f64; 4] =
                    std::array::from_fn(|a| to[a] + size * rng.random_range(-3.0..3.0));
                let d = random_unit(&mut rng);
                let reach: Vec<Reach> = cover.forms.iter().map(|f| f.reach(o, d).0).collect();
                if cover.exact && reach.contains(&Reach::Reached) {
                    reached += 1;
                    // Where the ray starts outside the object, it reaches it where it first
                    // reaches a form: the distance is zero there, and positive before.
                    let first = (cover.forms.iter())
                        .filter_map(|f| f.meet(o, d, (f64::INFINITY, ir::exact::CELLS)).first)
                        .fold(f64::INFINITY, f64::min);
                    let mut at = |t: f64| {
                        let p: [f64; 4] = std::array::from_fn(|a| o[a] + t * d[a]);
                        eval.run(&vars(p, [0.0; 4], 0.0));
                        eval.value(id)
                    };
                    let tol = 1e-9 * size;
                    if at(0.0) > tol {
                        let x = at(first);
                        assert!(
                            x.abs() < tol,
                            "{source}\nobject {id:?}: distance {x} where the ray ({o:?} along \
                             {d:?}) first reaches its exact cover, at t = {first}"
                        );
                        for k in 1..20 {
                            let t = first * k as f64 / 20.0;
                            let x = at(t);
                            assert!(
                                x > -tol,
                                "{source}\nobject {id:?}: distance {x} at t = {t}, before the \
                                 ray ({o:?} along {d:?}) reaches its exact cover at {first}"
                            );
                        }
                    }
                }
                if reach.iter().any(|r| *r != Reach::Missed) {
                    continue;
                }
                clear += 1;
                for k in 0..600 {
                    // Evenly to 3 sizes, then growing to 300.
                    let t = match k {
                        0..300 => size * 3.0 * k as f64 / 300.0,
                        _ => size * 3.0 * 1.016f64.powi(k - 299),
                    };
                    let p: [f64; 4] = std::array::from_fn(|a| o[a] + t * d[a]);
                    eval.run(&vars(p, [0.0; 4], 0.0));
                    let x = eval.value(id);
                    assert!(
                        x > -1e-9 * size,
                        "{source}\nobject {id:?}: distance {x} at t = {t} on a ray its cover \
                         clears ({o:?} along {d:?})"
                    );
                }
            }
        }
    }
    assert!(
        covered >= 100 && clear >= 5_000 && reached >= 1_000,
        "{covered} covers, {clear} rays clear, {reached} reaching exact ones"
    );
}

#[test]
fn every_primitive_and_operation_is_a_distance_bound() {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    for (shape, surface) in SHAPES {
        let scene = compile_text(&format!("object s {{ shape = {shape} }}"));
        let raw = ir::lower(&scene);
        let id = raw.objects[0].distance;
        let mut r = Reference::new(&raw.graph, &[id]);
        let mut f = |p: [f64; 4], t: f64| {
            r.run(&vars(p, [0.0; 4], t));
            r.value(id)
        };
        // The gradient of a distance bound never exceeds 1 in length, which catches a blend
        // that overshoots in a thin region random pairs rarely straddle.
        let prog = hyperslice::compile::program(&raw, None);
        let mut regs = Regs::<Dual, 1>::new(&prog.objects[0].distance);
        for _ in 0..3000 {
            let p = random_point(&mut rng, 2.5);
            let t = rng.random_range(0.0..1.0);
            let g = vm::gradient(&prog.objects[0].distance, &mut regs, &[to32(p)], t as f32)[0].g;
            let len = g.iter().map(|x| x * x).sum::<f32>().sqrt();
            assert!(len <= 1.0 + 1e-3, "{shape}: gradient length {len} at {p:?}");
        }
        for _ in 0..3000 {
            let a = random_point(&mut rng, 4.0);
            let step = 10f64.powf(rng.random_range(-3.0..0.5));
            let dir = random_unit(&mut rng);
            let b: [f64; 4] = std::array::from_fn(|i| a[i] + step * dir[i]);
            let t = rng.random_range(0.0..1.0);
            let (fa, fb) = (f(a, t), f(b, t));
            assert!(
                (fa - fb).abs() <= step * (1.0 + 1e-4) + 1e-12,
                "{shape}: |f(a) - f(b)| = {} > |a - b| = {step} at a = {a:?}",
                (fa - fb).abs()
            );
        }
        for p in *surface {
            let d = f(*p, 0.0);
            assert!(
                d.abs() < 1e-9,
                "{shape}: f = {d} at the surface point {p:?}"
            );
        }
    }
}

#[test]
fn cell5_vertices_lie_on_its_surface() {
    let scene = compile_text("object s { shape = cell5(2) }");
    let raw = ir::lower(&scene);
    let mut r = Reference::new(&raw.graph, &[raw.objects[0].distance]);
    for v in ir::lower::simplex_vertices() {
        r.run(&vars(v.map(|x| 2.0 * x), [0.0; 4], 0.0));
        assert!(r.value(raw.objects[0].distance).abs() < 1e-9);
    }
}

/// The distance to the nearest D4 point by brute force over the even-sum points near `p`.
fn d4_brute(p: [f64; 4]) -> f64 {
    let base = p.map(f64::floor);
    let mut best = f64::INFINITY;
    for m in 0..256 {
        let q: [f64; 4] = std::array::from_fn(|i| base[i] - 1.0 + ((m >> (2 * i)) & 3) as f64);
        if (q.iter().sum::<f64>() as i64).rem_euclid(2) == 0 {
            let d: f64 = (0..4).map(|i| (p[i] - q[i]).powi(2)).sum();
            best = best.min(d);
        }
    }
    best.sqrt()
}

#[test]
fn d4_decoder_finds_the_nearest_point_even_far_away() {
    let mut rng = Pcg64Mcg::seed_from_u64(6);
    for scale in [1.0, 1e3, 1e6] {
        for _ in 0..20000 {
            let p = random_point(&mut rng, scale);
            let o = hyperslice::math::kernel::d4(p);
            let cell = [o[4], o[5], o[6], o[7]];
            assert_eq!(
                (cell.iter().sum::<f64>() as i64).rem_euclid(2),
                0,
                "odd point for {p:?}"
            );
            let d = (0..4).map(|i| (p[i] - cell[i]).powi(2)).sum::<f64>().sqrt();
            assert!(
                (d - d4_brute(p)).abs() < 1e-9,
                "{p:?}: decoder {d} vs brute force {}",
                d4_brute(p)
            );
        }
    }
}

/// The scene compiled per frame (t folded in) agrees with the tape that reads t.
#[test]
fn frames_specialised_on_t_agree() {
    let scene = compile_file(&PathBuf::from("examples/tesseract.4ds"));
    let free = hyperslice::compile::Compiled::new(&scene).program(None);
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    let mut one = Regs::<f32, 1>::new(&free.scene);
    for t in [0.0, 0.3, 1.0] {
        let fixed = hyperslice::compile::Compiled::new(&scene).program(Some(t));
        assert!(fixed.scene.code.len() <= free.scene.code.len());
        assert!(!fixed.scene.inputs.contains(&hyperslice::ir::Var::T));
        for _ in 0..500 {
            let p = to32(random_point(&mut rng, 3.0));
            let a = vm::eval_point(&free.scene, &mut one, p, [0.0; 4], t as f32)[0];
            let b = vm::eval_point(&fixed.scene, &mut one, p, [0.0; 4], 0.0)[0];
            assert!((a - b).abs() < 1e-4 * (1.0 + a.abs()), "t={t}: {a} vs {b}");
        }
    }
}

/// A frame of a moving scene compiles to tapes as short as the same scene with its motion
/// written as constants: with `t` folded in, a turn by `a * t` (four products and two sums)
/// and a move by `v * t` (a difference beside a `length`) merge into the affine rows and
/// offsets that constant ones lower to. 300 generated scenes set moving, at a later frame;
/// before the optimiser merged such chains, 174 of them had longer tapes.
#[test]
fn moving_frames_compile_to_the_still_ones_forms() {
    for seed in 1..=300u64 {
        let g = hyperslice::generate::generate_moving(seed);
        let t = (seed % 4 + 1) as f64 / 4.0;
        let still = g.source.replace(" * t)", &format!(" * {t:?})"));
        assert!(!still.contains("* t"), "{still}");
        let lengths = |source: &str| {
            let scene = compile_text(source);
            let program = hyperslice::compile::Compiled::new(&scene).program(Some(t));
            program
                .tapes()
                .map(|tape| tape.code.len())
                .collect::<Vec<_>>()
        };
        assert_eq!(
            lengths(&g.source),
            lengths(&still),
            "seed {seed}:\n{}",
            g.source
        );
    }
}

/// The optimiser's merges keep what the kernel computes where a custom field is infinite or
/// NaN (a reviewer's cases): a row over such a node would multiply it by 0 in its unused slots
/// (`inf` becomes NaN, which a `max` then drops) or drop terms that cancel (and their NaN).
/// The optimised tape gives the plain IR's value, infinite or NaN alike.
#[test]
fn merged_rows_keep_infinities_and_nans() {
    let fields: [(&str, [f64; 4]); 4] = [
        (
            "max(length(p) - 1, (1 / max(p.x, 0) - 4) * 0.5)",
            [-0.5, 0.0, 0.0, 0.0],
        ),
        ("p.x + 0 * sqrt(p.y)", [0.5, -1.0, 0.0, 0.0]),
        (
            "(2 * p.x + 2 * sqrt(p.y)) - 2 * sqrt(p.y)",
            [0.5, -1.0, 0.0, 0.0],
        ),
        (
            "max(length(p) - 1, (max(p.x, inf) - 1) * 2)",
            [0.0, 0.0, 0.0, 0.0],
        ),
    ];
    for (field, p) in fields {
        let scene = compile_text(&format!("object s {{ shape = sdf |p| {field} }}"));
        let compiled = hyperslice::compile::Compiled::new(&scene);
        let mut reference = Reference::new(&compiled.ir.graph, &[compiled.ir.distance]);
        reference.run(&vars(p, [0.0; 4], 0.0));
        let want = reference.value(compiled.ir.distance);
        let program = compiled.program(Some(0.0));
        let mut regs = Regs::<f32, 1>::new(&program.scene);
        let got = vm::eval_point(&program.scene, &mut regs, to32(p), [0.0; 4], 0.0)[0] as f64;
        let same = got == want || got.is_nan() && want.is_nan();
        assert!(same, "{field} at {p:?}: {got} against {want}");
    }
}

#[test]
fn tapes_hold_only_what_their_roots_need() {
    // A tape keeps only what its roots need: an object's distance tape has no material ops.
    let scene = compile_text(
        "object a { shape = hypersphere(1)  material = |p, n| diffuse(albedo: rgb(fract(p.x))) }",
    );
    let prog = hyperslice::compile::Compiled::new(&scene).program(None);
    let tapes: Vec<&Tape> = prog.tapes().collect();
    assert_eq!(tapes[1].code.len(), 1, "{}", tapes[1]);
    assert!(
        tapes[2]
            .code
            .iter()
            .any(|i| i.to_string().contains("fract")),
        "{}",
        tapes[2]
    );
}

/// `--emit bytecode` for a frame prints exactly the tapes the renderer builds for that frame
/// (scene, interior, every object), for every frame of an animated scene with glass and lights:
/// those the whole-tape marchers run, and the objects' normals and materials. The cells'
/// marcher runs tapes pruned per cell (`emitted_cell_bytecode_is_what_the_marcher_runs`).
#[test]
fn emitted_bytecode_is_what_each_frame_renders() {
    use hyperslice::At;
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::{Build, FrameSource};
    use hyperslice::render::march::MarcherKind;
    for example in ["examples/glass_box.4ds", "examples/tesseract.4ds"] {
        let c = Compilation::from_path(Path::new(example));
        let scene = c.scene.as_ref().expect("the example compiles");
        let frames = Frames::new(scene);
        for f in 0..scene.render.frames {
            let fs = frames.frame(f, Build::marcher(MarcherKind::Cells));
            let mut rendered = format!("{}\n", fs.scene);
            if let Some(t) = &fs.interior {
                rendered += &format!("{t}\n");
            }
            for o in &fs.objects {
                rendered += &format!("{}\n{}\n", o.distance, o.material);
            }
            let emitted = c.emit_bytecode(At::Frame(f)).expect("bytecode");
            assert_eq!(emitted, rendered, "{example} frame {f}");
        }
    }
}

/// `--emit bytecode --cell X,Y,Z,W` prints the cell the cells' marcher runs at that point:
/// camera rays (and, where the scene has interiors, rays inside objects from where those hit)
/// marched through each frame's cells with a trace on; at the first point of every cell in
/// which some ray ran a tape or met the exact pieces, the text the library call behind the
/// flag emits for that point (from a frame and a tree of its own) is the text of the cell the
/// marcher ran: the same cell (depth and corner), the same bounds, pieces and tapes. Cells
/// outside the cube that a ray ran after proving some unbounded objects out of its way are
/// not named by a point and only counted.
#[test]
fn emitted_cell_bytecode_is_what_the_marcher_runs() {
    use hyperslice::At;
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::{Build, FrameSource};
    use hyperslice::render::march::{Hit, Marcher, MarcherKind, Ray, Trace};
    // More boxes than a cell meets exactly without splitting (`FEW_PIECES`).
    let many = (0..40)
        .map(|i| {
            let (x, z) = ((i % 6) as f64 - 2.5, (i / 6) as f64 * 1.5);
            format!(
                "object s{i} {{ shape = hyperbox([0.3, 0.3, 0.3, 0.3]) |> rotate(xz, {i}deg) \
                 |> translate([{x}, 0.3, {z}, 0]) material = glass() }}\n"
            )
        })
        .collect::<String>();
    let many = format!(
        "render {{ size = 32 x 24 }}\ncamera {{ from = [0, 1.5, -4, 0] to = [0, 0, 2, 0] }}\n\
         sky = rgb(1)\nobject floor {{ shape = halfspace(normal: [0, 1, 0, 0], offset: 0) }}\n{many}"
    );
    let mut scenes: Vec<(String, Compilation)> = ["glass_box", "d4_packing", "room", "polytopes"]
        .iter()
        .map(|e| {
            let path = format!("examples/{e}.4ds");
            (path.clone(), Compilation::from_path(Path::new(&path)))
        })
        .collect();
    scenes.push((
        "many boxes".into(),
        Compilation::from_source("many.4ds", &many),
    ));
    let (mut compared, mut deep, mut subsets) = (0, 0, 0);
    for (name, c) in &scenes {
        let scene = c
            .scene
            .as_ref()
            .unwrap_or_else(|| panic!("{name}: {}", c.render_diagnostics(false)));
        let source = Frames::new(scene);
        let frames = scene.render.frames;
        for f in [0, frames - 1] {
            let fs = source.frame(f, Build::marcher(MarcherKind::Cells));
            let limits = source.shot.limits;
            let (w, h) = (8, 6);
            let rays: Vec<Ray> = (0..w * h)
                .map(|k| Ray {
                    o: fs.camera.position,
                    d: fs
                        .camera
                        .direction((k % w) as f64 + 0.5, (k / w) as f64 + 0.5, w, h),
                    tmax: f64::INFINITY,
                    interior: false,
                })
                .collect();
            let mut marcher = Marcher::default();
            marcher.trace = Some(Trace::default());
            let mut hits = vec![];
            marcher.march(fs.field(), &rays, limits, &mut hits);
            if fs.features.interiors {
                let inside: Vec<Ray> = (rays.iter().zip(&hits))
                    .filter_map(|(r, h)| match *h {
                        Hit::Surface { t, .. } => Some(Ray {
                            o: r.o + r.d * (t + 4.0 * limits.epsilon),
                            interior: true,
                            ..*r
                        }),
                        _ => None,
                    })
                    .collect();
                marcher.march(fs.field(), &inside, limits, &mut hits);
            }
            let trace = marcher.trace.expect("traced");
            assert!(
                !trace.visits.is_empty(),
                "{name} frame {f}: no ray ran a cell"
            );
            let mut seen = vec![false; trace.cells.len()];
            for v in &trace.visits {
                if v.keep.is_some() {
                    subsets += 1;
                    continue;
                }
                if std::mem::replace(&mut seen[v.cell], true) {
                    continue;
                }
                let emitted = c
                    .emit_cell_bytecode(At::Frame(f), v.p.to_array())
                    .expect("a finite point of a compiled scene");
                assert_eq!(
                    emitted, trace.cells[v.cell],
                    "{name} frame {f}: at {:?} (cell {:?}) the marcher ran the second",
                    v.p, v.id
                );
                let header = emitted.lines().next().expect("a header");
                assert!(
                    header.contains(&format!("depth {},", v.id.0)),
                    "{name}: {header}"
                );
                compared += 1;
                deep += (v.id.0 >= 2) as usize;
            }
        }
    }
    // The cells compared include deep ones, whose parents (and siblings) print otherwise.
    assert!(compared >= 20 && deep >= 5, "{compared} cells, {deep} deep");
    eprintln!("{compared} cells compared, {deep} at depth 2 or more, {subsets} subset visits");
}

/// Pruned tapes compute what the whole scene tape computes wherever they are used: at random
/// points around the camera and the objects, and along the camera's rays, in the cell that
/// holds each point (exact affine cells included; outside the cells' cube, a bound), for every example and test scene, on the
/// first and last frame. Distances agree to f32 rounding; the nearest object agrees unless
/// two objects are equally near there.
#[test]
fn pruned_cells_agree_with_the_whole_tape() {
    use glam::DVec4;
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::Build;
    use hyperslice::render::march::MarcherKind;
    let mut rng = Pcg64Mcg::seed_from_u64(12);
    let (mut checked, mut pruned, mut cuts) = (0usize, 0usize, 0usize);
    let (mut partial_points, mut inner_points) = (0usize, 0usize);
    for file in scene_files() {
        let scene = compile_file(&file);
        let frames = Frames::new(&scene);
        for t in [0.0, 1.0] {
            let fs = frames.at(t, Build::marcher(MarcherKind::Cells));
            let mut one = Regs::<f32, 1>::new(&fs.scene);
            let cam = fs.camera.position;
            let mut points: Vec<DVec4> = (0..400)
                .map(|_| cam + DVec4::from_array(random_point(&mut rng, 6.0)))
                .collect();
            for _ in 0..40 {
                let d = fs.camera.direction(
                    rng.random_range(0.0..64.0),
                    rng.random_range(0.0..48.0),
                    64,
                    48,
                );
                points.extend((0..40).map(|k| cam + d * (k as f64 * 0.25)));
            }
            'point: for p in points {
                let cell = fs.cells.as_ref().expect("cells").find(p);
                let whole = vm::eval_point(&fs.scene, &mut one, to32(p.to_array()), [0.0; 4], 0.0);
                let local = (p - cell.origin).as_vec4().to_array();
                let mut part = vm::eval_point(&cell.scene, &mut one, local, [0.0; 4], 0.0);
                let at = (p - cell.origin).to_array();
                let nearest = |pieces: &[hyperslice::ir::exact::Piece]| {
                    (pieces.iter())
                        .map(|l| (l.form.value(at), l.object))
                        .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a })
                };
                if let Some(pieces) = &cell.exact {
                    let (d, o) = nearest(pieces);
                    part = vec![d as f32, o as f32];
                }
                let mut parts = vec![part];
                // A partial cell: its pieces and the rest's tape, together, must agree too.
                if let Some(partial) = cell.partial() {
                    let (d, o) = nearest(&partial.pieces);
                    let rest = vm::eval_point(&partial.rest, &mut one, local, [0.0; 4], 0.0);
                    parts.push(if (d as f32) < rest[0] {
                        vec![d as f32, o as f32]
                    } else {
                        rest
                    });
                    partial_points += 1;
                }
                let tol = 2e-5 * (1.0 + (whole[0] as f64).abs() + p.abs().max_element());
                for part in parts {
                    let (a, b) = (whole[0] as f64, part[0] as f64);
                    if !cell.size.is_finite() {
                        // Outside the cells' cube only the unbounded objects are left: the
                        // distance can only grow (the marcher stops steps at the cube).
                        assert!(b >= a - tol, "{}: {b} outside, {a} whole", file.display());
                        continue 'point;
                    }
                    // Beyond the cell's reach its tapes give a lower bound, itself past the reach.
                    let cut = (a - b).abs() > tol && b <= a + tol && b >= cell.reach - tol;
                    cuts += cut as usize;
                    assert!(
                        (a - b).abs() <= tol || (a.is_infinite() && a == b) || cut,
                        "{} t={t}: distance {b} in the cell at {:?} (edge {}), {a} whole, at {p:?}",
                        file.display(),
                        cell.lo,
                        cell.size
                    );
                    if whole[1] != part[1] && part[1] >= 0.0 && b < cell.reach {
                        // A tie: the object the cell names is as near as the nearest.
                        let o = &fs.objects[part[1] as usize].distance;
                        let d = vm::eval_point(o, &mut one, to32(p.to_array()), [0.0; 4], 0.0)[0];
                        assert!(
                            ((d - whole[0]) as f64).abs() <= tol,
                            "{} t={t}: nearest {} in the cell, {} whole, at {p:?}",
                            file.display(),
                            part[1],
                            whole[1]
                        );
                    }
                }
                if let (Some(wi), Some(ci)) = (&fs.interior, &cell.interior) {
                    let a = vm::eval_point(wi, &mut one, to32(p.to_array()), [0.0; 4], 0.0)[0];
                    // Rays inside objects meet the cell's inner pieces where it has them.
                    let b = match &cell.inner {
                        Some(pieces) => {
                            inner_points += 1;
                            nearest(pieces).0 as f32
                        }
                        None => vm::eval_point(ci, &mut one, local, [0.0; 4], 0.0)[0],
                    };
                    let (a, b) = (a as f64, b as f64);
                    assert!(
                        (a - b).abs() <= tol || (b <= a + tol && b >= cell.reach - tol),
                        "{} t={t}: interior distance {b} in the cell, {a} whole, at {p:?}",
                        file.display()
                    );
                }
                checked += 1;
                pruned += (cell.scene.code.len() < fs.scene.code.len()) as usize;
            }
        }
    }
    // The test must look at pruned tapes, not only at cells that kept everything.
    assert!(
        pruned * 4 > checked,
        "only {pruned} of {checked} points in pruned cells"
    );
    // And at cells that cut far objects to their bounds, and partial ones.
    assert!(
        cuts * 50 > checked,
        "only {cuts} of {checked} points where a cell cut"
    );
    assert!(
        partial_points * 10 > checked,
        "only {partial_points} of {checked} points in partial cells"
    );
    assert!(
        inner_points * 20 > checked,
        "only {inner_points} of {checked} points in cells with inner pieces"
    );
}

/// The exact pieces of cells (`ir::exact`): a ray meets a plane or a ball (a sphere of any
/// linear image of the point, or its complement) at the first `t` where the distance reaches
/// zero, and nowhere before it; when it meets none, the distance stays positive.
#[test]
fn exact_pieces_meet_rays_where_the_distance_reaches_zero() {
    let mut rng = Pcg64Mcg::seed_from_u64(21);
    let (mut met, mut missed) = (0, 0);
    for i in 0..16000 {
        let form = random_form(&mut rng, i % 9);
        let (p, d) = if i % 3 == 0 {
            // Rays aimed near the surface: grazing a rounded box's edges and corners.
            let aim = random_point(&mut rng, 1.5);
            let p = random_point(&mut rng, 4.0);
            let v: [f64; 4] = std::array::from_fn(|a| aim[a] - p[a]);
            let n = v.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-9);
            (p, v.map(|x| x / n))
        } else {
            (random_point(&mut rng, 4.0), random_unit(&mut rng))
        };
        let at = |t: f64| form.value(std::array::from_fn(|a| p[a] + t * d[a]));
        if at(0.0) <= 1e-6 {
            continue;
        }
        let m = form.meet(p, d, (50.0, 0));
        assert!(
            (m.value - at(0.0)).abs() <= 1e-12 * (1.0 + at(0.0).abs()),
            "{form:?}"
        );
        // Every form but a tiled ball is met in closed form: it knows where the ray meets it
        // or that it never does.
        assert!(m.clear == f64::INFINITY, "{form:?}: {m:?}");
        let until = m.first.unwrap_or(50.0);
        for k in 0..200 {
            let t = until * k as f64 / 200.0;
            assert!(
                at(t) > -1e-9,
                "{form:?} from {p:?} along {d:?}: {} at {t}, first {:?}",
                at(t),
                m.first
            );
        }
        if let Some(t) = m.first {
            let scale = 1.0 + t + p.iter().map(|x| x.abs()).sum::<f64>();
            assert!(
                at(t).abs() < 1e-9 * scale * 16.0,
                "{form:?}: {} at its first {t}",
                at(t)
            );
            met += 1;
        } else {
            // Missed: the distance stays positive all along (checked above to 50), and
            // beyond what the samples saw, nowhere near zero.
            let low = (0..2000)
                .map(|k| at(k as f64 * 0.025))
                .fold(f64::INFINITY, f64::min);
            assert!(low > -1e-9, "{form:?}: {low} along a ray said to miss");
            missed += 1;
        }
    }
    assert!(met > 1500 && missed > 3000, "{met} met, {missed} missed");
}

/// Up to four rays met together in the lanes of a vector (`Form::meet_lanes`, and the pieces
/// of a scene, `cells::meet_lanes`) meet every form as each ray alone does (`Form::meet`,
/// `cells::meet`), bit for bit, for one to four rays: no lane reads another's numbers, and the
/// balls' roots, taken without the branch that one ray alone takes past them, are the same.
#[test]
fn four_rays_in_lanes_meet_as_each_alone() {
    use hyperslice::ir::exact::{Form, Piece, Pieces, Rays};
    use hyperslice::vm::cells;
    let mut rng = Pcg64Mcg::seed_from_u64(44);
    let ray = |rng: &mut Pcg64Mcg| {
        let p = random_point(rng, 4.0);
        let d = if rng.random_bool(0.3) {
            // Aimed near the surfaces: grazing a rounded box's edges and corners.
            let aim = random_point(rng, 1.5);
            let v: [f64; 4] = std::array::from_fn(|a| aim[a] - p[a]);
            let n = v.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-9);
            v.map(|x| x / n)
        } else {
            random_unit(rng)
        };
        (p, d, (rng.random_range(0.5..50.0), 64))
    };
    let (mut met, mut total) = (0, 0);
    for i in 0..40000 {
        // Every third box or ball only moved (the identity's rows, met without products).
        let form = random_form(&mut rng, i % 9);
        let form = if i % 3 == 0 { unturned(form) } else { form };
        let rays: Vec<_> = (0..1 + i % 4).map(|_| ray(&mut rng)).collect();
        let lanes = form.meet_lanes(&Rays::new(&rays));
        for (l, &(p, d, reach)) in rays.iter().enumerate() {
            let one = form.meet(p, d, reach);
            let first = lanes.first[l];
            let four = (
                bits(lanes.value[l]),
                (!first.is_nan()).then_some(bits(first)),
            );
            let want = (bits(one.value), one.first.map(bits));
            assert_eq!(four, want, "{form:?}, lane {l} of {}: {one:?}", rays.len());
            assert_eq!((lanes.clear[l], lanes.cells[l]), (one.clear, one.cells));
            (met, total) = (met + one.first.is_some() as usize, total + 1);
        }
    }
    assert!(
        met > total / 5 && met < total * 4 / 5,
        "{met} of {total} met"
    );
    // Rays from where a box's value is NaN or infinite, or with no direction at all, as
    // boxes were met before they were met in lanes: from a NaN, the ray is taken to start on
    // the surface (it is not known to be outside), a `reach` that is no escape; from
    // infinity towards the box, it meets it at infinity.
    let unit = Form::Box {
        rows: IDENTITY.into(),
        b: [0.0; 4],
        half: [1.0; 4],
        r: 0.0,
        sign: 1.0,
    };
    let cases: [([f64; 4], [f64; 4], Option<f64>); 4] = [
        ([f64::NAN, 5.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], Some(0.0)),
        (
            [f64::INFINITY, 0.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0, 0.0],
            Some(f64::INFINITY),
        ),
        ([-3.0, 0.0, 0.0, 0.0], [0.0; 4], None),
        ([0.5, 0.0, 0.0, 0.0], [0.0; 4], Some(0.0)),
    ];
    for (p, d, want) in cases {
        let m = unit.meet(p, d, (f64::INFINITY, 0));
        assert_eq!(m.first, want, "from {p:?} along {d:?}: {m:?}");
        let lanes = unit.meet_lanes(&Rays::new(&[(p, d, (f64::INFINITY, 0)); 3]));
        assert!((0..3).all(|l| (!lanes.first[l].is_nan()).then_some(lanes.first[l]) == want));
    }
    // A scene's pieces: several forms, moved balls among them (met eight at a time).
    for i in 0..4000 {
        let moved = |rng: &mut Pcg64Mcg| hyperslice::ir::exact::Form::Ball {
            rows: std::array::from_fn(|a| std::array::from_fn(|b| (a == b) as u8 as f64)).into(),
            b: random_point(rng, 2.0),
            r: rng.random_range(0.1..1.0),
            sign: 1.0,
        };
        let list = (0..1 + i % 6)
            .map(|k| Piece {
                form: match [1, 3, 5, 9, 0, 10][(i + k) % 6] {
                    10 => moved(&mut rng),
                    kind => random_form(&mut rng, kind),
                },
                object: k as f64,
            })
            .collect::<Vec<_>>();
        let pieces = Pieces::from(list);
        let rays: Vec<_> = (0..1 + i % 4).map(|_| ray(&mut rng)).collect();
        let four = cells::meet_lanes(&pieces, &Rays::new(&rays));
        for (l, &(p, d, reach)) in rays.iter().enumerate() {
            let (p, d) = (glam::DVec4::from_array(p), glam::DVec4::from_array(d));
            let one = cells::meet(&pieces, p, d, reach);
            let key = |m: &cells::Met| {
                let ((a, b), (c, e)) = (m.near(), m.first());
                ([a, b, c, e, m.clear].map(bits), m.cells)
            };
            assert_eq!(key(&four[l]), key(&one), "{pieces:?}, lane {l}");
        }
    }
}

/// Boxes met from outside where the early test against the ball around them once missed
/// them (found in review): a box with a zero row, whose `A d` is shorter than a unit vector;
/// rays from 1e8 and 1e9 away, where `|u|^2 - (u.w)^2` cancels; and a direction along a face
/// too small to invert (subnormal), which made `0 * inf` of a root.
#[test]
fn boxes_are_met_from_far_and_along_short_directions() {
    use hyperslice::ir::exact::Form;
    let mut rows = [[0.0; 4]; 4];
    (0..4).for_each(|i| rows[i][i] = 1.0);
    let unit_box = |rows: [[f64; 4]; 4], r| Form::Box {
        rows: rows.into(),
        b: [0.0; 4],
        half: [1.0; 4],
        r,
        sign: 1.0,
    };
    let mut extruded = rows;
    extruded[3] = [0.0; 4];
    for r in [0.0, 0.1] {
        let (p, d) = ([-5.0, 0.0, 0.0, 0.0], [0.6, 0.0, 0.0, 0.8]);
        let first = unit_box(extruded, r).meet(p, d, (f64::INFINITY, 0)).first;
        let want = (4.0 - r) / 0.6;
        assert!(
            first.is_some_and(|t| (t - want).abs() < 1e-9),
            "r {r}: {first:?}, want {want}"
        );
    }
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    for far in [1e6, 1e8, 1e9] {
        for r in [0.0, 0.1] {
            for _ in 0..500 {
                let p = random_unit(&mut rng).map(|x| x * far);
                let aim = random_point(&mut rng, 0.9);
                let v: [f64; 4] = std::array::from_fn(|a| aim[a] - p[a]);
                let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let d = v.map(|x| x / n);
                let m = unit_box(rows, r).meet(p, d, (f64::INFINITY, 0));
                assert!(m.first.is_some(), "from {p:?} at {aim:?}: {m:?}");
            }
        }
    }
    for wx in [0.0, 1e-300, 1e-310] {
        let m = unit_box(rows, 0.0).meet([-1.0, -3.0, 0.0, 0.0], [wx, 1.0, 0.0, 0.0], (1e3, 0));
        assert!(
            m.first.is_some_and(|t| (t - 2.0).abs() < 1e-12),
            "w_x {wx:e}: {m:?}"
        );
    }
}

/// An exact form's gradient (the normals of a frame met as exact pieces) is the slope of its
/// value: central differences agree with it on every kind of form wherever the two one-sided
/// differences do (off edges, ridges and the centres of balls, where there is no slope).
#[test]
fn exact_forms_gradients_are_the_slopes_of_their_values() {
    let mut rng = Pcg64Mcg::seed_from_u64(33);
    let mut checked = 0;
    for i in 0..20000 {
        let form = random_form(&mut rng, i % 9);
        let p = random_point(&mut rng, 3.0);
        let g = form.gradient(p).expect("no tiled ball");
        let h = 1e-6;
        let at = |a: usize, t: f64| {
            let mut q = p;
            q[a] += t;
            form.value(q)
        };
        let v = form.value(p);
        let smooth = (0..4).all(|a| {
            let (fwd, back) = ((at(a, h) - v) / h, (v - at(a, -h)) / h);
            (fwd - back).abs() < 1e-4 * (1.0 + fwd.abs())
        });
        if !smooth {
            continue;
        }
        for (a, ga) in g.iter().enumerate() {
            let slope = (at(a, h) - at(a, -h)) / (2.0 * h);
            assert!(
                (ga - slope).abs() < 1e-5 * (1.0 + slope.abs()),
                "{form:?} at {p:?}: gradient {g:?}, slope {slope} along {a}"
            );
        }
        checked += 1;
    }
    assert!(checked > 15000, "{checked} points checked");
}

/// Four points' gradients at once (`Form::gradient` on `F4` lanes, as the normals of four hits
/// are taken) are each point's alone, bit for bit, on every kind of form: inside and outside
/// boxes, on their faces' planes and where faces tie (coordinates snapped to the box's own
/// numbers), at a ball's centre, and at points that are not finite.
#[test]
fn four_points_gradients_are_each_alone() {
    use hyperslice::math::lanes::{F4, gather, lane};
    let mut rng = Pcg64Mcg::seed_from_u64(34);
    let mut faces = 0;
    for i in 0..20000 {
        use hyperslice::ir::exact::Form;
        // Every other box only moved, so that points snapped to its centre and faces are.
        let form = random_form(&mut rng, i % 9);
        let form = if i % 2 == 0 { unturned(form) } else { form };
        let (centre, half) = match &form {
            Form::Box { b, half, .. } => (b.map(|x| -x), *half),
            _ => ([0.0; 4], [1.0; 4]),
        };
        let points: [[f64; 4]; 4] = std::array::from_fn(|_| {
            let mut p = random_point(&mut rng, 3.0);
            for a in 0..4 {
                p[a] = match rng.random_range(0..12) {
                    0 => 0.0,
                    1 => -0.0,
                    2 => centre[a],
                    3 => centre[a] + half[a],
                    4 => centre[a] - half[a],
                    5 if i % 50 == 0 => [f64::NAN, f64::INFINITY][rng.random_range(0..2)],
                    _ => p[a],
                };
            }
            p
        });
        let four = form.gradient::<F4>(gather(points)).expect("no tiled ball");
        for (l, &p) in points.iter().enumerate() {
            let one = form.gradient(p).expect("no tiled ball");
            assert_eq!(lane(four, l).map(bits), one.map(bits), "{form:?} at {p:?}");
            faces += (one.iter().filter(|&&x| x != 0.0).count() == 1) as usize;
        }
    }
    assert!(faces > 3000, "only {faces} gradients along an axis");
}

/// A NaN as one number: a NaN's bits are not kept by every operation.
fn bits(x: f64) -> u64 {
    if x.is_nan() {
        f64::NAN.to_bits()
    } else {
        x.to_bits()
    }
}

const IDENTITY: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// A box or ball only moved, not turned (the identity's rows, met without products); other
/// forms as they are.
fn unturned(form: hyperslice::ir::exact::Form) -> hyperslice::ir::exact::Form {
    use hyperslice::ir::exact::Form;
    match form {
        Form::Box {
            b, half, r, sign, ..
        } => Form::Box {
            rows: IDENTITY.into(),
            b,
            half,
            r,
            sign,
        },
        Form::Ball { b, r, sign, .. } => Form::Ball {
            rows: IDENTITY.into(),
            b,
            r,
            sign,
        },
        form => form,
    }
}

/// Random orthonormal rows (a rotation), by Gram-Schmidt.
fn random_rotation(rng: &mut Pcg64Mcg) -> [[f64; 4]; 4] {
    let mut rows = [[0.0; 4]; 4];
    for i in 0..4 {
        let mut v = random_unit(rng);
        for row in &rows[..i] {
            let k: f64 = (0..4).map(|a| v[a] * row[a]).sum();
            v = std::array::from_fn(|a| v[a] - k * row[a]);
        }
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        rows[i] = v.map(|x| x / n);
    }
    rows
}

/// One of the exact forms by `kind`: planes, balls (of any linear map, or their complement),
/// boxes sharp, shrunk and rounded (or their complement), convex polytopes of 4 to 24 planes
/// (or their complement), and shells of each (`|f| - k`).
fn random_form(rng: &mut Pcg64Mcg, kind: usize) -> hyperslice::ir::exact::Form {
    use hyperslice::ir::exact::Form;
    let sign = if rng.random_bool(0.3) { -1.0 } else { 1.0 };
    match kind {
        0 => Form::Plane {
            g: random_unit(rng),
            c: rng.random_range(-2.0..2.0),
        },
        1 | 2 => Form::Ball {
            rows: std::array::from_fn(|_| random_point(rng, 1.5)).into(),
            b: random_point(rng, 2.0),
            r: rng.random_range(0.1..2.0),
            sign,
        },
        3..=5 => {
            let mut half: [f64; 4] = std::array::from_fn(|_| rng.random_range(0.05..1.5));
            // Now and then one half-extent far beyond the others (a wall, a long beam).
            if rng.random_bool(0.2) {
                half[rng.random_range(0..4)] = 1e8;
            }
            let least = half.iter().cloned().fold(f64::INFINITY, f64::min);
            // Sharp, shrunk (by less than the box's least half-extent) or rounded.
            let r = match kind {
                3 => 0.0,
                4 => -rng.random_range(0.0..least),
                _ => rng.random_range(0.01..0.6),
            };
            Form::Box {
                rows: random_rotation(rng).into(),
                b: random_point(rng, 1.0),
                half,
                r,
                sign,
            }
        }
        8 => Form::Hull {
            planes: (0..rng.random_range(4..=24))
                .map(|_| (random_unit(rng), rng.random_range(-1.5..-0.2)))
                .collect(),
            sign,
        },
        _ => {
            let inner = [0, 1, 3, 4, 5, 8][rng.random_range(0..6)];
            let f = random_form(rng, inner);
            let f = match f {
                Form::Ball { b, r, .. } => Form::Ball {
                    rows: random_rotation(rng).into(),
                    b,
                    r,
                    sign: 1.0,
                },
                f => f,
            };
            Form::Abs {
                f: Box::new(f),
                // A negative `k`: `|f| + c`, which nothing meets.
                k: if kind == 6 {
                    0.0
                } else {
                    rng.random_range(-0.1..0.3)
                },
            }
        }
    }
}

/// A ball tiled over a lattice (D4 or a grid with limits; moved in its cell, turned, moved,
/// rounded, larger than its cell) is a piece that rays meet exactly (`ir::exact::Tiled`): its
/// value is the reference distance, and a ray meets it where the reference distance first
/// reaches zero (or, past a cell's face, is below it: a ball larger than its cell is cut
/// there), and nowhere before. Where it meets none, it is clear as far as it says, and that
/// is at least as far as it was asked on stretches shorter than its cells' crossing limit.
#[test]
fn tiled_balls_meet_rays_where_the_distance_reaches_zero() {
    use hyperslice::ir::exact::{Form, pieces};
    let mut rng = Pcg64Mcg::seed_from_u64(33);
    let (mut met, mut missed) = (0, 0);
    for (shape, cut) in [
        ("hypersphere(0.6) |> tile(d4(scale: 1))", false),
        (
            "hypersphere(0.3) |> translate([0.1, -0.2, 0.05, 0]) |> tile(d4(scale: 2)) \
             |> rotate(xz, 30deg) |> translate([3, 1, -2, 0.5])",
            false,
        ),
        ("hypersphere(0.35) |> round(0.1) |> tile(d4(0.5))", false),
        ("hypersphere(0.9) |> tile(d4(1))", true),
        (
            "hypersphere(0.4) |> tile(grid(spacing: [1, 1.5, 2, 1], limit: [2, 3, 1, 0])) \
             |> rotate(yw, 20deg)",
            false,
        ),
        (
            "hypersphere(0.7) |> tile(grid(spacing: 1, limit: [3, 3, 3, 3]))",
            true,
        ),
        // Sparse: rays cross gaps between the copies' reach, and some keep a coordinate; one
        // turned inside its cell, so that its reach along each axis is not the same.
        ("hypersphere(0.15) |> tile(d4(1))", false),
        (
            "hypersphere(0.12) |> translate([0.1, 0, 0, 0.05]) |> rotate(xw, 30deg) \
             |> tile(grid(spacing: [1, 2, 1, 1.5], limit: [3, 2, 3, 2]))",
            false,
        ),
        (
            "hypersphere(0.2) |> translate([0, 0.1, 0, 0.2]) |> tile(grid(spacing: [1, 2, 1, 1.5], limit: [2, 1, 3, 2])) \
             |> rotate(xy, 15deg) |> translate([0.5, 0, 0, 0])",
            false,
        ),
    ] {
        let scene = compile_text(&format!("object s {{ shape = {shape} }}"));
        let program = hyperslice::compile::Compiled::new(&scene).program(Some(0.0));
        let g = &program.ir.graph;
        let found = pieces(g, program.ir.distance, program.ir.nearest);
        let form = match found.as_deref() {
            Some([piece]) if matches!(piece.form, Form::Lattice(_)) => piece.form.clone(),
            other => panic!("{shape}: {other:?}"),
        };
        let raw = ir::lower(&scene);
        let mut eval = Reference::new(&raw.graph, &[raw.distance]);
        let mut field = |p: [f64; 4]| {
            eval.run(&vars(p, [0.0; 4], 0.0));
            eval.value(raw.distance)
        };
        for _ in 0..1500 {
            let p = random_point(&mut rng, 5.0);
            let (a, b) = (form.value(p), field(p));
            assert!(
                (a - b).abs() <= 1e-9,
                "{shape} at {p:?}: {a}, reference {b}"
            );
        }
        for i in 0..1500 {
            let (p, mut d) = (random_point(&mut rng, 5.0), random_unit(&mut rng));
            // A third of the rays keep their w (a slice's camera rays do), and a third change
            // it slowly (a crossing then starts far along the ray).
            if i % 3 != 2 {
                let w = if i % 3 == 0 {
                    0.0
                } else {
                    0.01 * d[3].signum()
                };
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / (1.0 - w * w).sqrt();
                d = [d[0] / n, d[1] / n, d[2] / n, w];
            }
            let at = |t: f64| -> [f64; 4] { std::array::from_fn(|a| p[a] + t * d[a]) };
            if field(p) <= 1e-6 {
                continue;
            }
            let limit = if i % 2 == 0 { 0.8 } else { 40.0 };
            let m = form.meet(p, d, (limit, hyperslice::ir::exact::CELLS));
            let (value, first, clear) = (m.value, m.first, m.clear);
            assert!(
                (value - field(p)).abs() <= 1e-9,
                "{shape} at {p:?}: {value}"
            );
            if first.is_none() && limit < 1.0 {
                assert!(clear >= limit, "{shape}: clear to {clear} of {limit}");
            }
            let end = first.unwrap_or(clear.min(60.0));
            for k in 0..400 {
                let t = end * k as f64 / 400.0;
                let f = field(at(t));
                assert!(
                    f > -1e-9,
                    "{shape} from {p:?} along {d:?}: {f} at {t}, first {first:?}"
                );
            }
            let Some(t) = first else {
                missed += 1;
                continue;
            };
            let f = field(at(t));
            let inside = field(at(t + 1e-7));
            assert!(
                f.abs() < 1e-9 || (cut && inside < 1e-6),
                "{shape} from {p:?} along {d:?}: {f} at its first {t} ({inside} just past)"
            );
            met += 1;
        }
    }
    assert!(met > 1000 && missed > 300, "{met} met, {missed} missed");
    // What is not a tiled ball's distance stays on the tapes: a tiled ball cut out of a box
    // (its negation), a tiled onion, and a tiled ball beside a custom field, where a partial
    // cell's pieces are the floor's alone (a crossing may stop short of the cell's side).
    use hyperslice::ir::exact::partition;
    let tiled =
        |p: &[hyperslice::ir::exact::Piece]| p.iter().any(|p| matches!(p.form, Form::Lattice(_)));
    for shape in [
        "subtract(hyperbox(3), hypersphere(0.4) |> tile(d4(1)))",
        "hypersphere(0.3) |> onion(0.05) |> tile(d4(1))",
    ] {
        let scene = compile_text(&format!("object s {{ shape = {shape} }}"));
        let program = hyperslice::compile::Compiled::new(&scene).program(Some(0.0));
        let found = pieces(&program.ir.graph, program.ir.distance, program.ir.nearest);
        assert!(!found.as_deref().is_some_and(tiled), "{shape}: {found:?}");
    }
    let scene = compile_text(
        "object a { shape = hypersphere(0.4) |> tile(d4(1)) }\n\
         object b { shape = sdf |p| length(p) - 0.3 + 0.1 * sin(p.x * 1rad) }\n\
         object c { shape = halfspace([0, 1, 0, 0], offset: 2) }",
    );
    let program = hyperslice::compile::Compiled::new(&scene).program(Some(0.0));
    let (parts, rest) = partition(&program.ir.graph, program.ir.distance, program.ir.nearest)
        .expect("the floor apart from the rest");
    assert!(!tiled(&parts) && rest.len() == 2, "{parts:?} {rest:?}");
}

/// Where the objects' pieces are more than a cell meets one by one (`MAX_PIECES`), a partial
/// cell keeps those of the objects with fewest pieces exact and leaves the others to the
/// tape: a floor and a lamp beside nine objects of seven rounded boxes each and a custom
/// field (which once made the whole cell marched on its tape: its pieces were too many to be
/// exact at all).
#[test]
fn partial_cells_keep_the_objects_of_fewest_pieces_exact() {
    use hyperslice::ir::exact::{Form, MAX_PIECES, partition};
    let (objects, each) = (9, 7);
    assert!(objects * each <= MAX_PIECES && objects * each + 2 > MAX_PIECES);
    let boxes: String = (0..objects)
        .map(|o| {
            let members: Vec<String> = (0..each)
                .map(|i| {
                    format!(
                        "hyperbox(0.3) |> round(0.1) |> translate([{}, 0.4, {o}, 0])",
                        i as f64 - 3.0
                    )
                })
                .collect();
            format!(
                "object boxes{o} {{ shape = union({}) }}\n",
                members.join(", ")
            )
        })
        .collect();
    let blob =
        "object blob { shape = sdf |p| length(p - [0, 2, 3, 0]) - 0.5 + 0.1 * sin(p.x * 1rad) }";
    let scene = compile_text(&format!(
        "{boxes}object floor {{ shape = halfspace([0, 1, 0, 0], offset: 0) }}\n\
         object lamp {{ shape = hypersphere(0.5) |> translate([0, 4, 0, 0]) }}\n{blob}"
    ));
    let program = hyperslice::compile::Compiled::new(&scene).program(Some(0.0));
    let (parts, rest) = partition(&program.ir.graph, program.ir.distance, program.ir.nearest)
        .expect("the floor and the lamp apart from the rest");
    // The floor and the lamp, then as many of the box objects as there is room for (ties in
    // the objects' order), listed in the objects' order.
    let exact: Vec<f64> = parts.iter().map(|p| p.object).collect();
    let mut expected: Vec<f64> = (0..objects - 1)
        .flat_map(|o| std::iter::repeat_n(o as f64, each))
        .collect();
    expected.extend([objects as f64, objects as f64 + 1.0]);
    assert_eq!(exact, expected);
    assert!(matches!(parts[parts.len() - 2].form, Form::Plane { .. }));
    assert!(matches!(parts[parts.len() - 1].form, Form::Ball { .. }));
    let rest: Vec<usize> = rest.iter().map(|(o, _)| *o).collect();
    assert_eq!(rest, [objects - 1, objects + 2]);
    // With room for them, the boxes are exact too.
    let scene = compile_text(&format!("{boxes}{blob}"));
    let program = hyperslice::compile::Compiled::new(&scene).program(Some(0.0));
    let (parts, rest) = partition(&program.ir.graph, program.ir.distance, program.ir.nearest)
        .expect("the boxes apart from the field");
    assert!(
        parts.len() == objects * each
            && parts
                .iter()
                .all(|p| matches!(p.form, Form::Box { r, .. } if r > 0.0))
    );
    assert_eq!(rest.len(), 1);
}

/// A box pruned to a region where at most one of its faces can have the point outside it
/// becomes the largest of its candidate faces' planes (`ir::prune`), on both sides of the
/// surface; elsewhere it stays a box. At random points of random regions around turned,
/// rounded and hollowed boxes, the pruned graph computes what the whole one does (in `f64`),
/// and a sixth of the regions take the faces' form, some of them straddling the surface.
#[test]
fn pruned_boxes_agree_with_the_whole_box() {
    use hyperslice::ir::Node;
    use hyperslice::ir::prune::prune;
    let mut rng = Pcg64Mcg::seed_from_u64(17);
    let (mut faces, mut straddling, mut regions) = (0, 0, 0);
    for i in 0..300 {
        let half: Vec<String> = (0..4)
            .map(|_| format!("{:.3}", rng.random_range(0.2..1.5)))
            .collect();
        let planes = ["xy", "xz", "xw", "yz", "yw", "zw"];
        let mut shape = format!("hyperbox([{}])", half.join(", "));
        for _ in 0..(i % 3) {
            let plane = planes[rng.random_range(0..6)];
            shape += &format!(
                " |> rotate({plane}, {:.1}deg)",
                rng.random_range(-90.0..90.0)
            );
        }
        if i % 4 == 1 {
            shape += &format!(" |> round({:.2})", rng.random_range(0.05..0.4));
        }
        if i % 5 < 2 {
            shape += &format!(" |> onion({:.2})", rng.random_range(0.02..0.2));
        }
        let raw = ir::lower(&compile_text(&format!("object s {{ shape = {shape} }}")));
        let root = raw.objects[0].distance;
        let mut whole = Reference::new(&raw.graph, &[root]);
        for _ in 0..20 {
            let centre = random_point(&mut rng, 1.6);
            let edge = 10f64.powf(rng.random_range(-2.0..0.0));
            let region = [I::new(-edge / 2.0, edge / 2.0); 4];
            let cell = prune(&raw.graph, &[root], region, centre, f64::INFINITY);
            // What pruning builds, its roots need all of (`Pruned::compact`): pruning it
            // again marks every node live without looking.
            assert!(cell.compact && cell.graph.live(&cell.roots).iter().all(|&l| l));
            let boxes = (0..cell.graph.len())
                .filter(|&k| matches!(cell.graph.get(ir::Id(k as u32)), Node::BoxDist(..)))
                .count();
            let mut part = Reference::new(&cell.graph, &cell.roots);
            let mut signs = [false; 2];
            for _ in 0..40 {
                let local = random_point(&mut rng, edge / 2.0);
                whole.run(&vars(
                    std::array::from_fn(|a| centre[a] + local[a]),
                    [0.0; 4],
                    0.0,
                ));
                part.run(&vars(local, [0.0; 4], 0.0));
                let (a, b) = (whole.value(root), part.value(cell.roots[0]));
                assert!(
                    (a - b).abs() <= 1e-9 * (1.0 + a.abs()),
                    "{shape} in the cell of edge {edge} at {centre:?}: {b} pruned, {a} whole"
                );
                signs[(a > 0.0) as usize] = true;
            }
            regions += 1;
            if boxes == 0 {
                faces += 1;
                straddling += (signs[0] && signs[1]) as usize;
            }
        }
    }
    eprintln!("{faces} of {regions} regions as faces, {straddling} straddling the surface");
    assert!(faces * 10 > regions && straddling * 200 > regions);
}

/// Far from the origin, on surfaces of radius 1e5, a cell's `f32` tapes of the plain forms
/// lose the distance to the rounding of the large constants; the forms `ir::precise` writes
/// keep it to a small share of the epsilon, checked against the `f64` reference at random
/// points of a cell on each surface. A tiled box, whose operand (the offset in its tile) lies
/// past the box's offset, checks the sign of the folded face.
#[test]
fn precise_forms_keep_surfaces_of_radius_1e5_to_the_epsilon() {
    use hyperslice::ir::precise::precise;
    use hyperslice::ir::prune::prune;
    let far = "|> translate([300000, 0, 0, 200000])";
    let at_far = [3e5, 0.0, 0.0, 2e5];
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    for (shape, origin, plain_loses) in [
        (
            format!(
                "hypersphere(100000) |> translate([0, -100000, 0, 0]) |> rotate(xy, 30deg) {far}"
            ),
            at_far,
            true,
        ),
        (
            format!(
                "hyperbox([100000, 100000, 100000, 100000]) |> translate([3, -100000, 7, 1]) |> rotate(xz, 20deg) |> rotate(yw, 10deg) {far}"
            ),
            at_far,
            true,
        ),
        (
            format!("hypersphere(100000) |> onion(0.5) |> translate([0, -100000, 0, 0]) {far}"),
            at_far,
            true,
        ),
        (
            "hyperbox(50) |> translate([300, 0, 0, 0]) |> tile(grid(1000))".to_string(),
            [352.0, 48.0, 0.0, 0.0],
            false,
        ),
    ] {
        let raw = ir::lower(&compile_text(&format!("object s {{ shape = {shape} }}")));
        let root = raw.objects[0].distance;
        let (edge, epsilon) = (64.0, 1e-4);
        let region = [I::new(-edge / 2.0, edge / 2.0); 4];
        let cell = prune(&raw.graph, &[root], region, origin, f64::INFINITY);
        let plain = Tape::compile("plain", &cell.graph, &cell.roots);
        let (g, roots) =
            precise(&cell.graph, &cell.roots, region, epsilon).expect("large constants rewritten");
        let exact = Tape::compile("precise", &g, &roots);
        let mut reference = Reference::new(&raw.graph, &[root]);
        let mut one = Regs::<f32, 1>::new(&plain);
        let (mut worst_plain, mut worst): (f64, f64) = (0.0, 0.0);
        for _ in 0..2000 {
            let local = random_point(&mut rng, edge / 2.0);
            reference.run(&vars(
                std::array::from_fn(|a| origin[a] + local[a]),
                [0.0; 4],
                0.0,
            ));
            let want = reference.value(root);
            let at = to32(local);
            let a = vm::eval_point(&plain, &mut one, at, [0.0; 4], 0.0)[0] as f64;
            let b = vm::eval_point(&exact, &mut one, at, [0.0; 4], 0.0)[0] as f64;
            // Points rounded to f32 in the cell: their own rounding is the floor.
            let own = (0..4).map(|k| (at[k] as f64 - local[k]).abs()).sum::<f64>();
            worst_plain = worst_plain.max((a - want).abs() - own);
            worst = worst.max((b - want).abs() - own);
        }
        eprintln!("{shape}: plain tape off by {worst_plain:e}, precise by {worst:e}");
        if plain_loses {
            assert!(
                worst < epsilon / 8.0,
                "{shape}: precise off by {worst}\n{exact}"
            );
            assert!(
                worst_plain > epsilon,
                "{shape}: plain only off by {worst_plain}"
            );
        } else {
            // Here the tile's own rounding sets the floor, for both.
            assert!(
                worst <= 1.5 * worst_plain + 1e-6,
                "{shape}: precise off by {worst}, plain by {worst_plain}\n{exact}"
            );
        }
    }
}

/// Cells meet a length of the point exactly only where it is a distance: of a turned point or
/// a projection (orthonormal rows), not of a stretched one, whose value is no distance bound.
#[test]
fn only_distances_become_exact_spheres() {
    use hyperslice::ir::exact::{Form, pieces};
    use hyperslice::ir::{Graph, K, Node};
    let k = K::new;
    for (rows, exact) in [
        (
            [
                [0.6, 0.8, 0.0, 0.0],
                [-0.8, 0.6, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            true,
        ),
        (
            [
                [2.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            false,
        ),
        (
            [
                [0.6, 0.8, 0.0, 0.0],
                [0.6, 0.8, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            false,
        ),
    ] {
        let mut g = Graph::new();
        let vars = Var::POINT.map(|v| g.intern(Node::Var(v)));
        let zero = g.intern(Node::Const(k(0.0)));
        let mut ops = [zero; 4];
        for (op, row) in ops.iter_mut().zip(rows) {
            *op = g.intern(Node::Affine(
                vars,
                [k(row[0]), k(row[1]), k(row[2]), k(row[3]), k(0.5)],
            ));
        }
        let d = g.intern(Node::Length(ops, [k(0.0), k(0.0), k(0.0), k(0.0), k(1.0)]));
        let id = g.intern(Node::Const(k(0.0)));
        let got = pieces(&g, d, id);
        assert_eq!(got.is_some(), exact, "rows {rows:?}: {got:?}");
        if let Some(p) = got {
            assert!(matches!(p[0].form, Form::Ball { r: 1.0, .. }), "{p:?}");
        }
    }
}

/// The default marcher keeps a frame's cells only where its probe shows they pay: not on a D4
/// tiling of boxes (a few instructions that nothing prunes, so cells only add bookkeeping),
/// but on the D4 packing of spheres (met exactly, cell by cell of the lattice), on a union of
/// 1024 spheres (cells cut each step to the few spheres nearby); on a blend of two spheres
/// 1e6 from the origin, whose cells resolve the epsilon in `f32` where the whole tape's hits
/// settle in `f64`; and with the camera inside glass, whose rays the probe marches on the
/// interior tape as the render does; not around small objects in a shell of radius 1e6,
/// whose cells split around every ray (`UNSHARED`: through them the frame took 16 times as
/// long as plain). The probe stays small whatever the image's shape.
/// A scene that is a few exact pieces (a turned slab, glass and a sphere thousands of
/// epsilons across seen from 3e4 away, a sphere alone) is not probed: every ray meets the
/// pieces once (`Escape::pieces`), on no cells. (Through the cells, the slab was met exactly
/// as a shell of a plane, and the glass in one cell; before rays inside objects met pieces,
/// the glass's cells split to resolve the epsilon in `f32`, a ray built new ones at nearly
/// every step, and building them was the whole render: 24.6 s through the cells, 0.07 s
/// plain, 96 x 72, 4 spp.)
#[test]
fn frames_march_through_cells_only_where_they_pay() {
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::Build;
    use hyperslice::render::march::MarcherKind;
    // Two spheres blended: no piece a ray meets exactly.
    let blob = |at: &str| {
        format!(
            "union(hypersphere(1) |> translate([{at}]), hypersphere(0.5) |> translate([{at}]) \
             |> translate([0, 0.8, 0, 0]), smooth: 0.2)"
        )
    };
    let far = format!(
        "render {{ size = 64 x 48 }}\n\
         camera {{ from = [1e6, 0, -5, 0]  to = [1e6, 0, 0, 0] }}\n\
         object ball {{ shape = {} material = diffuse(rgb(0.5)) }}",
        blob("1e6, 0, 0, 0")
    );
    let inside = format!(
        "render {{ size = 64 x 48 }}\n\
         camera {{ from = [0, 0, -5, 0] }}\n\
         object ball {{ shape = {} material = diffuse(rgb(0.5)) }}\n\
         object bath {{ shape = hypersphere(20) material = glass(ior: 1.3) }}",
        blob("0, 0, 0, 0")
    );
    let tall = format!(
        "render {{ size = 16 x 16384 }}\n\
         camera {{ from = [0, 0, -5, 0] }}\n\
         object ball {{ shape = {} material = diffuse(rgb(0.5)) }}",
        blob("0, 0, 0, 0")
    );
    let boxes = "render { size = 64 x 48 }\n\
                 camera { from = [0.5, 0.5, -2.5, 0] }\n\
                 object boxes { shape = hyperbox(0.3) |> tile(d4(1)) \
                 material = diffuse(rgb(0.5)) }";
    let split = "render { size = 96 x 72  spp = 4  bounces = 2 }\n\
                 camera { from = [-1.6e4, -2.1e4, -4.6e3, 1.3e4]  to = [0, 0, 0, 0] }\n\
                 object water { shape = halfspace(normal: [0.165, 0.443, -0.617, 0.630], \
                 offset: -9.97e3) material = glass(ior: 1.5) }\n\
                 object ball { shape = hypersphere(8.9e3) |> translate([7.47e3, 4.77e3, \
                 -4.73e3, 1.65e3]) material = diffuse(rgb(0.5)) }";
    // Small objects inside a shell of radius 1e6: its cells split around every ray.
    let shell = "render { size = 80 x 60  spp = 4  bounces = 3 }\n\
                 camera { from = [0, 0.5, -4, 0.1] }\n\
                 object dome { shape = onion(hypersphere(1), 0.001) |> scale(1000000) \
                 material = diffuse(rgb(0.8)) }\n\
                 object a { shape = spherinder(0.5, 0.5) |> rotate(xz, 30deg) \
                 material = diffuse(rgb(0.5)) }\n\
                 object b { shape = union(hypersphere(0.4) |> translate([1, 0, 0, 0]), \
                 hypersphere(0.4) |> translate([1.5, 0.3, 0, 0]), smooth: 0.3) \
                 material = diffuse(rgb(0.5)) }\n\
                 object c { shape = duocylinder(0.3, 0.2) |> translate([-1.2, 0, 0.5, 0]) \
                 material = glass(ior: 1.5) }\n\
                 object l { shape = hypersphere(0.3) |> translate([0, 3, 0, 0]) \
                 material = light(rgb(20)) }\n\
                 object g { shape = halfspace(offset: -1) material = diffuse(rgb(0.6)) }";
    let alone = "render { size = 64 x 48 }\n\
                 camera { from = [0, 0, -5, 0] }\n\
                 object ball { shape = hypersphere(1) material = diffuse(rgb(0.5)) }";
    // (scene, how it marches: cells kept and relaxed steps, or none for exact pieces)
    let cases = [
        (
            Compilation::from_path(Path::new("examples/d4_packing.4ds")),
            Some((true, true)),
        ),
        (
            Compilation::from_source("boxes.4ds", boxes),
            Some((false, true)),
        ),
        (
            Compilation::from_path_with(
                Path::new("benches/scenes/spheres.4ds"),
                &["n=32".to_string()],
            ),
            Some((true, true)),
        ),
        (
            Compilation::from_source("far.4ds", &far),
            Some((true, true)),
        ),
        (
            Compilation::from_source("inside.4ds", &inside),
            Some((true, true)),
        ),
        (
            Compilation::from_source("tall.4ds", &tall),
            Some((false, true)),
        ),
        (Compilation::from_source("split.4ds", split), None),
        (
            Compilation::from_source("shell.4ds", shell),
            Some((false, false)),
        ),
        (
            Compilation::from_path(Path::new("benches/scenes/turned_slab.4ds")),
            None,
        ),
        (Compilation::from_source("alone.4ds", alone), None),
    ];
    for (c, marching) in cases {
        assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
        let scene = c.scene.expect("a scene");
        let frames = Frames::new(&scene);
        let fs = frames.at(0.0, Build::marcher(MarcherKind::Auto));
        assert_eq!(
            fs.escape.meets_every_ray(),
            marching.is_none(),
            "{:?}",
            fs.probe
        );
        let Some((cells, relax)) = marching else {
            assert!(fs.probe.is_none() && fs.cells.is_none() && fs.unlit.is_empty());
            continue;
        };
        let probe = fs.probe.expect("the default marcher probes");
        assert_eq!(fs.cells.is_some(), cells, "{probe:?}");
        assert_eq!(fs.relax, relax, "{probe:?}");
        let rays = probe.cells.map_or(probe.whole.rays, |c| c.rays);
        assert!(rays <= 3 * 24 * 24, "{probe:?}");
    }
}

/// A union of 1,024 spheres keeps its cells at every sample count: at 1 spp the probe's
/// model, which charged building a cell by the nodes of its parent's graph that pruning read,
/// put the render's cost of building them above twice the whole tape's march, and the frame
/// took the whole tape, three times slower (0.47 s against 0.15 s at 160 x 120, one thread).
#[test]
fn a_dense_union_keeps_its_cells_at_one_sample_per_pixel() {
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::Build;
    use hyperslice::render::march::MarcherKind;
    let c = Compilation::from_path_with(
        Path::new("benches/scenes/spheres.4ds"),
        &["n=32".to_string()],
    );
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
    let mut scene = c.scene.expect("a scene");
    for spp in [1, 2, 4] {
        (scene.render.width, scene.render.height, scene.render.spp) = (160, 120, spp);
        let fs = Frames::new(&scene).at(0.0, Build::marcher(MarcherKind::Auto));
        let probe = fs.probe.expect("the default marcher probes");
        assert!(fs.cells.is_some(), "{spp} spp: {probe:?}");
    }
}

/// The probe gives cells up as soon as building them costs more than its budget, not only at
/// the end of a quarter of its camera rays: in this generated scene at scale 1e4 (generated
/// 266) the first quarter's 48 camera rays built 65,707 graph nodes (counting the parents'
/// nodes that pruning read) against a budget of about 11,000, most of the frame's time; its
/// first 16 rays build cells worth 14,609 (`Cells::built`).
#[test]
fn the_probe_gives_cells_up_within_its_budget() {
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::Build;
    use hyperslice::render::march::MarcherKind;
    let source = "render { size = 96 x 72  spp = 4  bounces = 2 }\n\
                  camera { from = [1.490992255e4, 1.641820388e4, -1.831020599e4, \
                  -8.536577042e3]  to = [0, 0, 0, 0]  fov = 70deg }\n\
                  sky = rgb(1)\n\
                  object o0 { shape = (hypersphere(3e3) |> tile(grid(spacing: 9.592202e3, \
                  limit: [2, 2, 2, 2]))) |> translate([-1.726947104e3, -8.333340272e3, \
                  1.024320654e3, 5.769351799e3]) material = diffuse(rgb(0.5)) }\n\
                  object o1 { shape = hyperbox([3.975205e3, 6.406291e3, 3.363490e3, \
                  7.854096e3]) |> translate([-6.318630272e3, 6.922429733e3, 3.695344902e3, \
                  8.560302427e3]) material = glass(ior: 1.5) }";
    let c = Compilation::from_source("far_tiles.4ds", source);
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
    let scene = c.scene.expect("a scene");
    let fs = Frames::new(&scene).at(0.0, Build::marcher(MarcherKind::Auto));
    let probe = fs.probe.expect("the default marcher probes");
    assert!(fs.cells.is_none(), "{probe:?}");
    let abandoned = probe
        .abandoned
        .expect("the cells were marched, then given up");
    // 192 camera rays, a quarter of them 48: given up after the first 16.
    assert!(abandoned.rays < 48, "{probe:?}");
    assert!(abandoned.built < 30_000.0, "{probe:?}");
}

/// `hsv` of a field gives each hit point its own colour: the material tape's albedo at a point
/// is the constant `hsv` of that point's hue, in the bytecode and in the plain IR alike.
#[test]
fn hsv_of_a_field_colours_each_point() {
    let scene = compile_text(
        "sky = rgb(1)\nobject o {\n  shape = hypersphere(1)\n  \
         material = |p, n| diffuse(albedo: hsv(360deg * fract(p.w), 0.6, clamp(0.5 + p.x, 0, 1)))\n}\n",
    );
    let raw = ir::lower(&scene);
    let prog = hyperslice::compile::program(&raw, None);
    let o = &raw.objects[0];
    let mut reference = Reference::new(&raw.graph, &o.material.roots());
    let mut one = Regs::<f32, 1>::new(&prog.objects[0].material);
    let mut seen = Vec::new();
    for (w, x) in [
        (0.0f64, 0.4f64),
        (1.0 / 3.0, 0.4),
        (0.55, 0.1),
        (0.9, -0.2),
        (-0.25, 0.3),
        (2.7, 0.0),
    ] {
        let p = [x, 0.0, 0.0, w];
        let n = [1.0, 0.0, 0.0, 0.0];
        let want = hyperslice::math::color::hsv(
            (360.0 * (w - w.floor())).to_radians(),
            0.6,
            (0.5 + x).clamp(0.0, 1.0),
        );
        reference.run(&vars(p, n, 0.0));
        // The tape's outputs: the selector, then the albedo's three channels.
        let got = vm::eval_point(&prog.objects[0].material, &mut one, to32(p), to32(n), 0.0);
        let roots = o.material.roots();
        for c in 0..3 {
            let ir = reference.value(roots[1 + c]);
            assert!((ir - want[c]).abs() < 1e-9, "ir at {p:?}: {ir} vs {want:?}");
            assert!(
                (got[1 + c] as f64 - want[c]).abs() < 1e-5,
                "vm at {p:?}: {:?} vs {want:?}",
                &got[1..4]
            );
        }
        seen.push(want);
    }
    assert_ne!(seen[0], seen[1], "red at w = 0, green at w = 1/3");
    assert!((seen[0][0] - 0.9).abs() < 1e-12 && (seen[0][1] - 0.36).abs() < 1e-12);
}

/// A cell's lower bound of the distance holds at every point of it where the distance is
/// defined, also in fields that leave a function's domain (a logarithm, an arcsine, an
/// arccosine past it): bounds there are the whole line, not NaN, which a `min` would drop.
/// With NaN bounds, `min(log(y + 0.5), |p| - 1)` got the lower bound -1 over cells where the
/// slab's distance reaches -3.3.
#[test]
fn cell_bounds_hold_where_fields_leave_their_domain() {
    use glam::DVec4;
    use hyperslice::compile::Frames;
    use hyperslice::render::frame::Build;
    use hyperslice::render::march::MarcherKind;
    let fields = [
        "sdf |p| min(log(p.y + 0.5), length(p) - 1)",
        "sdf |p| min(asin(p.y) / 1rad - 0.3, length(p - [2, 0, 0, 0]) - 0.5)",
        "sdf |p| max(acos(p.x * 0.5) / 1rad - 1, length(p) - 2)",
        "sdf |p| min(log(p.x * p.y), p.z + 1)",
        "sdf |p| max(length(p) - 2, sqrt(p.y) + 0.1)",
    ];
    let mut rng = Pcg64Mcg::seed_from_u64(23);
    let (mut checked, mut undefined) = (0, 0);
    for field in fields {
        for beside in [
            "",
            "object ball { shape = hypersphere(0.5) |> translate([3, 1, 0, 0])\n material = diffuse(0.5) }\n",
        ] {
            let src = format!(
                "camera {{ from = [0, 0, -6, 0]\n to = [0, 0, 0, 0] }}\n\
                 object o {{ shape = {field}\n material = diffuse(0.5) }}\n{beside}"
            );
            let scene = compile_text(&src);
            let fs = Frames::new(&scene).at(0.0, Build::marcher(MarcherKind::Cells));
            let mut one = Regs::<f32, 1>::new(&fs.scene);
            let cells = fs.cells.as_ref().expect("cells");
            for _ in 0..3000 {
                let p = DVec4::from_array(random_point(&mut rng, 4.0));
                let whole = vm::eval_point(&fs.scene, &mut one, to32(p.to_array()), [0.0; 4], 0.0);
                let d = whole[0] as f64;
                if !d.is_finite() {
                    undefined += 1;
                    continue;
                }
                let cell = cells.find(p);
                let tol = 2e-5 * (1.0 + d.abs() + p.abs().max_element());
                assert!(
                    cell.lower[0] <= d + tol,
                    "{src}: lower bound {} over the cell at {:?} (edge {}), distance {d} at {p:?}",
                    cell.lower[0],
                    cell.lo,
                    cell.size
                );
                checked += 1;
            }
        }
    }
    // The fields must be undefined somewhere, and checked mostly where they are not.
    assert!(
        undefined > 1000 && checked > 10_000,
        "{undefined} {checked}"
    );
}

/// A random custom field of depth up to `depth` that goes NaN in places (square roots,
/// logarithms and arcsines past their domains, `0 / 0`), read through the kernel's operations
/// that drop a NaN (`min`, `max`, comparisons, `sign`, selections): its expression in `p`.
fn nan_prone_field(rng: &mut Pcg64Mcg, depth: u32) -> String {
    if depth == 0 {
        return match rng.random_range(0..6) {
            0 => "p.x".into(),
            1 => "p.y".into(),
            2 => "p.z".into(),
            3 => "p.w".into(),
            4 => "0".into(),
            _ => format!("{:.2}", rng.random_range(-2.0..2.0)),
        };
    }
    let op = rng.random_range(0..17);
    let mut e = || nan_prone_field(rng, depth - 1);
    let (a, b) = (e(), e());
    match op {
        0 => format!("sqrt({a})"),
        1 => format!("log({a})"),
        2 => format!("(asin({a}) / 1rad)"),
        3 => format!("abs({a})"),
        4 => format!("sign({a})"),
        5 => format!("(-{a})"),
        6 => format!("floor({a})"),
        7 => format!("({a} + {b})"),
        8 => format!("({a} - {b})"),
        9 => format!("({a} * {b})"),
        10 => format!("({a} / {b})"),
        11 | 12 => format!("min({a}, {b})"),
        13 | 14 => format!("max({a}, {b})"),
        15 => format!("(if {a} < {b} {{ {} }} else {{ {} }})", e(), e()),
        _ => format!(
            "(if {a} != {b} || !({} >= 0) {{ {} }} else {{ {} }})",
            e(),
            e(),
            e()
        ),
    }
}

/// Whether some node of `g` that `live` marks took an infinite value in `reference`'s last
/// run (`x / 0`): bounds follow values past a function's domain, not infinities that a later
/// `0 * x` or `x - x` makes NaN (`docs/ir-and-vm.md`). (The running min starts at infinity.)
fn infinite_somewhere(g: &ir::Graph, live: &[bool], reference: &Reference) -> bool {
    use ir::Node;
    (0..g.len())
        .filter(|&i| live[i])
        .any(|i| match g.get(ir::Id(i as u32)) {
            Node::Const(_) | Node::MinId(..) | Node::Proj(..) => false,
            _ => reference.value(ir::Id(i as u32)).is_infinite(),
        })
}

/// Whether some `min` or `max` of `g` had a NaN operand and a number in `reference`'s last
/// run: it is either, by the operands' order, which the graph does not keep (`I::dropping`).
fn order_decides(g: &ir::Graph, live: &[bool], reference: &Reference) -> bool {
    use ir::{Bin, Node};
    let one_nan = |a: ir::Id, b: ir::Id| reference.value(a).is_nan() != reference.value(b).is_nan();
    (0..g.len())
        .filter(|&i| live[i])
        .any(|i| match g.get(ir::Id(i as u32)) {
            Node::Bin(Bin::Min | Bin::Max, a, b) => one_nan(a, b),
            _ => false,
        })
}

/// Bounds know where a node may be NaN (`I::nan`), and hold every value it takes where it is
/// not: on random fields that go NaN past a function's domain and then meet `min`, `max`,
/// comparisons and selections, which drop a NaN (the kernel's `max(a, b)` is `a` where `b`
/// is NaN). Over random boxes and stretches of rays, at every node; and a graph pruned to a
/// box (`ir::prune`) is the same function there, NaN for NaN. Before bounds kept the flag,
/// `max(-1 - z^2, max(sqrt(x), y - 0.5))` read as at least `y - 0.5` past `x = 0`, where it is
/// `-1 - z^2`.
#[test]
fn bounds_follow_nan_through_the_operations_that_drop_it() {
    use hyperslice::ir::prune::prune;
    let mut rng = Pcg64Mcg::seed_from_u64(17);
    let (mut fields, mut nan_values, mut dropped, mut infinite) = (0, 0, 0, 0);
    let (mut pruned_points, mut nan_points) = (0, 0);
    let mut along = Along::default();
    for _ in 0..400 {
        let depth = rng.random_range(2..=4);
        let expr = nan_prone_field(&mut rng, depth);
        // A third blended with another field (`smooth`), where a NaN is never dropped.
        let expr = match rng.random_range(0..6) {
            0 => format!(
                "union(sdf |p| {expr}, sdf |p| {}, smooth: 0.3)",
                nan_prone_field(&mut rng, 2)
            ),
            1 => format!(
                "intersect(sdf |p| {expr}, sdf |p| {}, smooth: 0.3)",
                nan_prone_field(&mut rng, 2)
            ),
            _ => format!("sdf |p| {expr}"),
        };
        let src = format!("object o {{ shape = {expr}\n material = diffuse(0.5) }}");
        // (A constant past a domain, `asin(-1.92)`, is an error of the scene's.)
        let c = Compilation::from_source("t.4ds", &src);
        let errors = c.has_errors();
        let Some(scene) = c.scene.filter(|_| !errors) else {
            continue;
        };
        fields += 1;
        let raw = ir::lower(&scene);
        let (g, root) = (&raw.graph, raw.objects[0].distance);
        let live = g.live(&[root]);
        let scalar: Vec<ir::Id> = (0..g.len() as u32)
            .map(ir::Id)
            .filter(|&id| live[id.0 as usize] && g.get(id).arity() == 1)
            .collect();
        let mut reference = Reference::new(g, &[root]);
        let mut check = |bounds: &Intervals, reference: &Reference, at: String| {
            if infinite_somewhere(g, &live, reference) {
                infinite += 1;
                return;
            }
            for &id in &scalar {
                let (b, x) = (bounds.get(id), reference.value(id));
                if x.is_nan() {
                    nan_values += 1;
                    assert!(b.nan, "{expr}: node {id:?} NaN at {at}, bounds {b:?}");
                } else {
                    let slack = 1e-9 * (1.0 + x.abs());
                    let within = |lo: f64, hi: f64| lo <= x && x <= hi;
                    assert!(
                        within(b.lo, b.hi) || within(b.lo - slack, b.hi + slack),
                        "{expr}: node {id:?} {x} outside {b:?} at {at}"
                    );
                }
            }
            let some_nan = scalar.iter().any(|&id| reference.value(id).is_nan());
            dropped += (some_nan && !reference.value(root).is_nan()) as u32;
        };
        for _ in 0..8 {
            let c = random_point(&mut rng, 2.0);
            let r = rng.random_range(0.0..1.5);
            let region = [I::new(-r, r); 4];
            let boxed = |v: Var| match v.index() {
                a @ 0..4 => I::new(c[a] - r, c[a] + r),
                4..8 => I::new(-1.0, 1.0),
                _ => I::ALL,
            };
            let bounds = Intervals::of(g, &boxed, None);
            let cell = prune(g, &[root], region, c, f64::INFINITY);
            let mut cut = Reference::new(&cell.graph, &cell.roots);
            for _ in 0..16 {
                let local: [f64; 4] = std::array::from_fn(|_| rng.random_range(-r..=r));
                let p: [f64; 4] = std::array::from_fn(|a| c[a] + local[a]);
                reference.run(&vars(p, [0.0; 4], 0.5));
                check(
                    &bounds,
                    &reference,
                    format!("{p:?} in the box of {c:?} and {r}"),
                );
                // Nothing to compare where the order of a `min`'s operands decides, or an
                // infinity (a pruned graph's `-x` for `|x|`, or its local coordinates, may give
                // the other zero under `x / 0`).
                if order_decides(g, &live, &reference) || infinite_somewhere(g, &live, &reference) {
                    continue;
                }
                cut.run(&vars(local, [0.0; 4], 0.5));
                let (want, got) = (reference.value(root), cut.value(cell.roots[0]));
                // (The pruned graph runs in coordinates local to the box: its own roundings.)
                let same = want == got || (want - got).abs() <= 1e-9 * (1.0 + want.abs());
                assert!(
                    same || (want.is_nan() && got.is_nan()),
                    "{expr}: pruned to the box of {c:?} and {r}: {got} against {want} at {p:?}"
                );
                pruned_points += 1;
                nan_points += want.is_nan() as u32;
            }
            let (o, d) = (random_point(&mut rng, 2.0), random_unit(&mut rng));
            let len = [0.0, 0.1, 1.0, 4.0][rng.random_range(0..4)];
            let bounds = Intervals::along(&mut along, g, o, d, len);
            for (s, at) in stretch(o, d, len) {
                reference.run(&at);
                check(
                    bounds,
                    &reference,
                    format!("s = {s} of {len} from {o:?} along {d:?}"),
                );
            }
        }
    }
    assert!(nan_values > 10_000, "{nan_values} NaN values");
    assert!(dropped > 1_000, "{dropped} points where a NaN was dropped");
    assert!(fields > 200, "{fields} fields");
    assert!(
        pruned_points > 10_000 && nan_points > 1_000,
        "{pruned_points}, {nan_points}"
    );
}
