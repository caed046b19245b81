//! The marchers against a reference, on scenes nobody wrote: a seeded generator builds valid
//! random scenes from the language's parts (hyperspheres, boxes, halfspaces, slabs of two
//! halfspaces, union / intersect / subtract with and without `smooth`, onion, round, rotations
//! in all six planes, translations, grid tilings, custom `sdf` fields, glass), at scales from
//! 1e-3 to 1e4 and far from the origin, with cameras outside and inside objects. Camera,
//! bounce, shadow and interior rays are marched by each marcher and checked against an `f64`
//! sphere trace of the unoptimised IR (plain steps, a far cut-off instead of the escape
//! proof, a huge step cap):
//!
//! - a hit lies on a surface (the reference distance there is within the tolerance, or
//!   below it for a ray that starts in a solid), on the object it names, and not past the
//!   first root the reference finds (tracing to a thousandth of the epsilon);
//! - a miss is a ray the reference finds no root on (grazes closer than the epsilon without
//!   a root may go either way);
//! - rays out of steps are counted: at most 1 in 100,000 segments for the cells' marcher.
//!
//! The same scenes set moving with the frame variable `t` (`generate_moving`) are checked at
//! a later frame, against the reference at that `t`.
//!
//! `cargo test --release --test marcher_differential` runs a few hundred scenes;
//! `cargo test --release -- --ignored soak` runs 10,000 and prints each failure as a scene.

use glam::DVec4;
use hyperslice::Compilation;
use hyperslice::compile::Frames;
use hyperslice::generate::{Generated, generate, generate_moving};
use hyperslice::ir::eval::{Reference, vars};
use hyperslice::ir::{Id, SceneIr};
use hyperslice::render::frame::{Build, FrameScene};
use hyperslice::render::march::{Hit, Limits, Marcher, MarcherKind, Ray};
use hyperslice::vm::cells::{epsilon_at, hit_epsilon};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::fmt::Write;

/// The reference distances of a scene at time `t`: its unoptimised IR walked in `f64`.
struct Truth<'g> {
    ir: &'g SceneIr,
    eval: Reference<'g>,
    t: f64,
}

impl Truth<'_> {
    fn at(&mut self, root: Id, p: DVec4) -> f64 {
        self.eval.run(&vars(p.to_array(), [0.0; 4], self.t));
        self.eval.value(root)
    }

    /// The first `t` at which the ray is within `tol` of a surface (on `root`'s distance),
    /// `None` when it is not before `tmax` or `far`; `Err` when the step cap runs out.
    fn first(&mut self, root: Id, r: &Ray, tol: f64, far: f64) -> Result<Option<f64>, ()> {
        self.first_from(root, r, 0.0, tol, far)
    }

    /// `first`, from `t` on.
    fn first_from(
        &mut self,
        root: Id,
        r: &Ray,
        mut t: f64,
        tol: f64,
        far: f64,
    ) -> Result<Option<f64>, ()> {
        for _ in 0..200_000 {
            let d = self.at(root, r.o + r.d * t);
            if d.is_nan() {
                return Err(());
            }
            let d = if r.interior { d.abs() } else { d };
            if d < tol {
                return Ok((t < r.tmax).then_some(t));
            }
            t += d;
            if t >= r.tmax || t > far {
                return Ok(None);
            }
        }
        Err(())
    }

    /// Where the ray, at a root of the distance at `from`, is clear of the surface by `tol`
    /// again without having gone more than `tol` inside it (stepping on the distance's
    /// size, at least `tol / 8`): past a surface it only grazes. None where it enters it.
    fn graze(&mut self, root: Id, r: &Ray, from: f64, tol: f64) -> Option<f64> {
        let mut t = from;
        for _ in 0..100_000 {
            let d = self.at(root, r.o + r.d * t);
            if d < -tol || d.is_nan() {
                return None;
            }
            if d > tol || t >= r.tmax {
                return Some(t);
            }
            t += d.abs().max(tol / 8.0);
        }
        None
    }

    /// Whether the ray goes more than `tol` inside a solid between `from` and `to` (stepping
    /// on the distance's size, at least `tol / 8`). A ray that grazes a plane at a slope of
    /// 1e-4 is within a thousandth of the epsilon of it for a hundredth of a unit before its
    /// root: a hit at the root is past where the reference first came that close, yet never
    /// inside.
    fn enters(&mut self, root: Id, r: &Ray, from: f64, to: f64, tol: f64) -> bool {
        let mut t = from;
        for _ in 0..100_000 {
            if t >= to {
                return false;
            }
            let d = self.at(root, r.o + r.d * t);
            if d < -tol || d.is_nan() {
                return true;
            }
            t += d.abs().max(tol / 8.0);
        }
        true
    }

    /// The outward normal at `p` of the nearest object, by central differences.
    fn normal(&mut self, p: DVec4, h: f64) -> DVec4 {
        let root = self.ir.distance;
        let g = DVec4::from_array(std::array::from_fn(|a| {
            let e = DVec4::AXES[a] * h;
            self.at(root, p + e) - self.at(root, p - e)
        }));
        g.normalize_or_zero()
    }
}

/// What went wrong with one ray, for the report.
#[derive(Debug)]
struct Fault {
    /// Which rays: camera, bounce, shadow or interior.
    kind: &'static str,
    ray: Ray,
    fast: Hit,
    why: String,
}

#[derive(Default, Debug)]
struct Tally {
    segments: u64,
    out_of_steps: u64,
    /// The kinds of the rays out of steps.
    stuck: Vec<&'static str>,
    faults: Vec<Fault>,
    /// Scenes that are a few exact pieces, which every ray meets once (`Escape::pieces`; not
    /// through the cells, which `--marcher cells` keeps).
    exact: u64,
}

/// Which rays `r` is among: camera, bounce, shadow (to a point, so finite) or interior.
fn kind(r: &Ray, camera: DVec4) -> &'static str {
    match (r.interior, r.tmax.is_finite(), r.o == camera) {
        (true, ..) => "interior",
        (_, true, _) => "shadow",
        (_, _, true) => "camera",
        _ => "bounce",
    }
}

/// March `rays` through the frame with `kind`, and check every result against the truth.
fn check(
    marcher: MarcherKind,
    fs: &FrameScene,
    truth: &mut Truth,
    rays: &[Ray],
    limits: Limits,
    scale: f64,
    tally: &mut Tally,
) -> Vec<Hit> {
    let mut hits = vec![];
    Marcher::default().march(fs.field(), rays, limits, &mut hits);
    let whole = matches!(marcher, MarcherKind::Whole | MarcherKind::Plain);
    let eps = limits.epsilon;
    for (r, &h) in rays.iter().zip(&hits) {
        tally.segments += 1;
        let root = match (r.interior, truth.ir.interior) {
            (true, Some((d, _))) => d,
            _ => truth.ir.distance,
        };
        let far = 50.0 * (scale + (r.o - fs.camera.position).length()) + 1e3 * scale;
        let mut fault = |why: String| {
            tally.faults.push(Fault {
                kind: kind(r, fs.camera.position),
                ray: *r,
                fast: h,
                why,
            })
        };
        // The first root, approached from before it: a trace to a thousandth of the epsilon.
        let first = truth.first(root, r, eps * 1e-3, far);
        match h {
            Hit::OutOfSteps => {
                tally.out_of_steps += 1;
                tally.stuck.push(kind(r, fs.camera.position));
            }
            Hit::Surface { t, object } => {
                let p = r.o + r.d * t;
                // The cells resolve the epsilon; far from every cell's origin `f32` needs more.
                // The whole tape's hits settle in `f64` where `f32` cannot resolve it.
                let tol = match whole {
                    true => 4.0 * eps,
                    false => 4.0 * epsilon_at(p - fs.camera.position, eps).max(epsilon_at(p, eps)),
                };
                // A ray that starts inside a solid meets it where it starts.
                let here = truth.at(root, p);
                let d = if r.interior { here.abs() } else { here };
                let own = truth.at(truth.ir.objects[object].distance, p);
                let own = if r.interior { own.abs() } else { own };
                if d > tol {
                    fault(format!(
                        "hit at t = {t:.6e}, but the distance there is {d:.3e}"
                    ));
                } else if own > tol {
                    fault(format!("hit names object {object}, {own:.3e} away"));
                } else if let Ok(Some(first)) = first
                    && t > first + 2.0 * tol
                    // (A quarter of the hit's tolerance: one epsilon on the whole tape, so
                    // only a solid thinner than two epsilons can be crossed unseen.)
                    && (r.interior || truth.enters(root, r, first, t, tol / 4.0))
                {
                    fault(format!("hit at t = {t:.6e}, past a surface at {first:.6e}"));
                } else if whole
                    && !r.interior
                    && d > 2.0 * eps
                    && first.is_ok_and(|f| f.is_none_or(|f| t < f - 2.0 * tol))
                {
                    // The whole tape's hits settle within the epsilon in `f64`: one well
                    // short of the surface is a ray that stopped early (a path that hit
                    // the surface it was leaving, four epsilons off it).
                    fault(format!(
                        "hit at t = {t:.6e}, {d:.3e} short of a surface at {first:?}"
                    ));
                }
            }
            Hit::Beyond => {
                // Exact pieces meet the true surface, which the reference's trace stops within
                // a thousandth of the epsilon of: a ray may pass a surface it only grazes
                // (never inside it by more than that), but none it enters, nor any behind.
                // Inside objects the distance is unsigned, so a graze cannot be told from a
                // crossing, except at the ray's start: a surface there is one the ray leaves
                // (it starts four epsilons past the last one it crossed; a shell thinner than
                // that puts it on the next), which it may meet at 0 or pass.
                let mut next = first;
                while let Ok(Some(t)) = next {
                    let tol = eps * 1e-3;
                    let leaves = !r.interior || t == 0.0;
                    match truth.graze(root, r, t, tol).filter(|_| leaves) {
                        Some(past) => next = truth.first_from(root, r, past, tol, far),
                        None => {
                            fault(format!("missed a surface at t = {t:.6e}"));
                            break;
                        }
                    }
                }
            }
        }
    }
    hits
}

/// Camera rays of the frame at time `t`, then from their hits bounce rays (out of the
/// surface), shadow rays (to a point near the camera) and, into enterable objects, interior
/// rays.
fn run_scene(g: &Generated, t: f64, kind: MarcherKind, tally: &mut Tally) {
    let c = Compilation::from_source("generated.4ds", &g.source);
    assert!(
        !c.has_errors(),
        "{}\n{}",
        g.source,
        c.render_diagnostics(false)
    );
    let scene = c.scene.expect("a scene");
    let frames = Frames::new(&scene);
    let fs = frames.at(t, Build::marcher(kind));
    tally.exact += fs.field().pieces(false).is_some() as u64;
    let ir = hyperslice::ir::lower(&scene);
    let mut roots = vec![ir.distance];
    roots.extend(ir.interior.map(|i| i.0));
    roots.extend(ir.objects.iter().map(|o| o.distance));
    let mut truth = Truth {
        eval: Reference::new(&ir.graph, &roots),
        ir: &ir,
        t,
    };
    let limits = frames.shot.limits;
    let (w, h) = (8, 8);
    let camera = &fs.camera;
    let rays: Vec<Ray> = (0..w * h)
        .map(|i| Ray {
            o: camera.position,
            d: camera.direction((i % w) as f64 + 0.5, (i / w) as f64 + 0.5, w, h),
            tmax: f64::INFINITY,
            interior: false,
        })
        .collect();
    let hits = check(kind, &fs, &mut truth, &rays, limits, g.scale, tally);
    let mut rng = Pcg64Mcg::seed_from_u64(hits.len() as u64);
    let (mut bounce, mut inside) = (vec![], vec![]);
    for (r, hit) in rays.iter().zip(&hits) {
        let Hit::Surface { t, .. } = *hit else {
            continue;
        };
        let p = r.o + r.d * t;
        // Off the surface as the integrator leaves it (the cube's outside, far from every
        // cell's origin, has a coarser epsilon than a cell near the camera).
        let cell = fs.cells.as_ref().map(|cells| cells.find(p));
        let eps = hit_epsilon(cell, p, limits.epsilon, false);
        let n = truth.normal(p, eps);
        if n == DVec4::ZERO {
            continue;
        }
        let mut d = DVec4::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0)));
        d = d.normalize_or(n);
        let d = if d.dot(n) < 0.0 { -d } else { d };
        let o = p + n * 4.0 * eps;
        bounce.push(Ray {
            o,
            d,
            tmax: f64::INFINITY,
            interior: false,
        });
        let to = camera.position + DVec4::splat(0.1 * g.scale) - o;
        bounce.push(Ray {
            o,
            d: to.normalize(),
            tmax: to.length(),
            interior: false,
        });
        if truth.ir.interior.is_some() {
            inside.push(Ray {
                o: p - n * 4.0 * eps,
                d: -d,
                tmax: f64::INFINITY,
                interior: true,
            });
        }
    }
    check(kind, &fs, &mut truth, &bounce, limits, g.scale, tally);
    check(kind, &fs, &mut truth, &inside, limits, g.scale, tally);
}

/// Run `n` scenes from `seed` with `kind`, or where `moving`, those scenes set moving at one of
/// their later frames (`t` a quarter to 1, by the seed); report each failing scene with its
/// first faults.
fn soak(seed: u64, n: u64, kind: MarcherKind, moving: bool) -> (Tally, Vec<(u64, String)>) {
    let mut total = Tally::default();
    let mut failures = vec![];
    for s in seed..seed + n {
        let (mut g, t) = match moving {
            true => (generate_moving(s), (s % 4 + 1) as f64 / 4.0),
            false => (generate(s), 0.0),
        };
        // A scene being shrunk by hand, from a file, in place of the generated one.
        if let Ok(path) = std::env::var("SOAK_SCENE") {
            g.source = std::fs::read_to_string(path).expect("SOAK_SCENE names a scene file");
        }
        let mut tally = Tally::default();
        run_scene(&g, t, kind, &mut tally);
        if !tally.faults.is_empty() {
            let mut report = format!(
                "scene {s} at t = {t} ({} of {} rays wrong):\n{}",
                tally.faults.len(),
                tally.segments,
                g.source
            );
            for f in tally.faults.iter().take(3) {
                writeln!(
                    report,
                    "  {} {:?} -> {:?}: {}",
                    f.kind, f.ray, f.fast, f.why
                )
                .unwrap();
            }
            failures.push((s, report));
        }
        if tally.out_of_steps > 0 && std::env::var("SOAK_STUCK").is_ok() {
            eprintln!("stuck {s} {:?}:\n{}", tally.stuck, g.source);
        }
        total.segments += tally.segments;
        total.out_of_steps += tally.out_of_steps;
        total.stuck.extend(tally.stuck);
        total.faults.extend(tally.faults);
        total.exact += tally.exact;
    }
    (total, failures)
}

/// Scenes among the first 300 on which the cells' marcher is still wrong (open faults of
/// the marcher issue; each also fails alone with `SOAK_FROM=N SOAK_COUNT=1`): none now. CI
/// fails on any other scene, and once one of these is fixed it must leave this list.
const KNOWN: [u64; 0] = [];

/// Segments out of steps that CI tolerates on the first 300 scenes, per 100,000: the soak's
/// goal (measured: 0 of 38,460 since crawling rays leap; 91 before).
const CI_OUT_OF_STEPS: u64 = 1;

fn assert_sound(kind: MarcherKind, from: u64, n: u64, moving: bool) {
    let (tally, failures, known) = tally(kind, from, n, moving);
    let wrong = failures.len() + known.len();
    assert!(wrong == 0, "{wrong} scenes disagree");
    assert!(
        tally.out_of_steps * 100_000 <= tally.segments,
        "{} of {} segments out of steps",
        tally.out_of_steps,
        tally.segments
    );
}

/// Run and print the scenes' tally and their failures (the scenes known to fail apart).
fn tally(kind: MarcherKind, from: u64, n: u64, moving: bool) -> (Tally, Vec<String>, Vec<u64>) {
    let (tally, mut failures) = soak(from, n, kind, moving);
    let known: Vec<u64> = (failures.iter())
        .map(|(s, _)| *s)
        .filter(|s| KNOWN.contains(s))
        .collect();
    failures.retain(|(s, _)| !KNOWN.contains(s));
    eprintln!(
        "{}: {n} {}scenes ({} of exact pieces), {} segments, {} out of steps, {} faults in {} \
         scenes",
        kind.name(),
        if moving { "moving " } else { "" },
        tally.exact,
        tally.segments,
        tally.out_of_steps,
        tally.faults.len(),
        failures.len()
    );
    eprintln!("known to fail: {known:?}");
    let show = std::env::var("SOAK_SHOW").ok().and_then(|v| v.parse().ok());
    for (_, f) in failures.iter().take(show.unwrap_or(5)) {
        eprintln!("{f}");
    }
    let failures = failures.into_iter().map(|(_, f)| f).collect();
    (tally, failures, known)
}

#[test]
fn generated_scenes_agree_with_the_reference() {
    let (tally, failures, _) = tally(MarcherKind::Cells, 1, 300, false);
    assert!(
        failures.is_empty(),
        "{} new scenes disagree",
        failures.len()
    );
    assert!(
        tally.out_of_steps * 100_000 <= CI_OUT_OF_STEPS * tally.segments,
        "{} of {} segments out of steps",
        tally.out_of_steps,
        tally.segments
    );
}

#[test]
fn the_whole_tape_marchers_agree_with_the_reference() {
    for kind in [MarcherKind::Plain, MarcherKind::Whole] {
        let (tally, failures, known) = tally(kind, 1, 300, false);
        let wrong = failures.len() + known.len();
        assert!(wrong == 0, "{}: {wrong} scenes disagree", kind.name());
        // The whole tape meets the scenes of a few exact pieces at once; plain never does.
        assert_eq!(
            tally.exact > 0,
            kind == MarcherKind::Whole,
            "{}",
            tally.exact
        );
    }
}

/// The scenes set moving with `t` (each object turned, moved or rounded by it, the camera
/// moving to their centre) agree with the reference at a later frame, for the cells' marcher
/// and the whole tape's: the frames are compiled for their `t`, and nothing else marches an
/// animated scene's later frames.
#[test]
fn moving_scenes_agree_with_the_reference() {
    for kind in [MarcherKind::Cells, MarcherKind::Whole] {
        let (tally, failures, _) = tally(kind, 1, 150, true);
        assert!(
            failures.is_empty(),
            "{}: {} scenes disagree",
            kind.name(),
            failures.len()
        );
        assert!(tally.segments > 15_000, "{} segments", tally.segments);
        assert!(
            tally.out_of_steps * 100_000 <= CI_OUT_OF_STEPS * tally.segments,
            "{}: {} of {} segments out of steps",
            kind.name(),
            tally.out_of_steps,
            tally.segments
        );
    }
}

/// Failures of the soak, shrunk to a few lines each (`tests/in/marcher/`, each saying what
/// went wrong; `// scale = X` sets the scale the harness checks at, 1 unless given): each
/// marchers agree with the reference on every one, with no ray out of steps.
#[test]
fn shrunk_scenes_agree_with_the_reference() {
    let mut files: Vec<_> = (std::fs::read_dir("tests/in/marcher").unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "4ds"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for file in files {
        let source = std::fs::read_to_string(&file).unwrap();
        let scale = (source.lines())
            .find_map(|l| l.strip_prefix("// scale = "))
            .map_or(1.0, |x| x.trim().parse().expect("a scale"));
        let g = Generated { source, scale };
        for kind in [MarcherKind::Cells, MarcherKind::Whole, MarcherKind::Plain] {
            let mut tally = Tally::default();
            run_scene(&g, 0.0, kind, &mut tally);
            assert!(
                tally.faults.is_empty() && tally.out_of_steps == 0,
                "{} ({}): {} of {} rays wrong, {} out of steps; first {:?}",
                file.display(),
                kind.name(),
                tally.faults.len(),
                tally.segments,
                tally.out_of_steps,
                tally.faults.first()
            );
        }
    }
}

/// `SOAK_FROM`, `SOAK_COUNT` and `SOAK_MARCHER` (cells, whole, plain or auto) choose the scenes and the
/// marcher: `SOAK_FROM=92 SOAK_COUNT=1` reruns one scene; `SOAK_MOVING=1` sets them moving
/// (`generate_moving`, at a later frame). `SOAK_SHOW=N` prints the first N
/// failing scenes, `SOAK_STUCK=1` every scene with rays out of steps (and their kinds), and
/// `SOAK_SCENE=FILE` marches that scene instead of the generated one (with its scale), to
/// shrink a failure by hand.
#[test]
#[ignore = "10,000 scenes: cargo test --release -- --ignored soak"]
fn soak_generated_scenes() {
    let var = |name: &str, default: u64| {
        std::env::var(name)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    let kind = match std::env::var("SOAK_MARCHER").as_deref() {
        Ok("plain") => MarcherKind::Plain,
        Ok("whole") => MarcherKind::Whole,
        Ok("auto") => MarcherKind::Auto,
        _ => MarcherKind::Cells,
    };
    let moving = var("SOAK_MOVING", 0) == 1;
    assert_sound(kind, var("SOAK_FROM", 1), var("SOAK_COUNT", 10_000), moving);
}
