//! Random valid scenes built from the language's own parts, for differential tests of the
//! marchers and for the marcher corpus (`hyperslice bench --marcher-corpus`): hyperspheres,
//! boxes, halfspaces, slabs of two halfspaces, union / intersect / subtract with and without
//! `smooth`, onion, round, rotations in all six planes, translations, grid tilings, custom
//! `sdf` fields and glass, at scales from 1e-3 to 1e4 and sometimes far from the origin, with
//! cameras outside and inside objects; and the same scenes set moving with the frame variable
//! `t` (`generate_moving`). A seed always gives the same scene.

use glam::DVec4;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::fmt::Write;

const PLANES: [&str; 6] = ["xy", "xz", "xw", "yz", "yw", "zw"];

/// A random scene: its source, and the scale its shapes are built at.
pub struct Generated {
    pub source: String,
    pub scale: f64,
}

fn num(rng: &mut Pcg64Mcg, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

fn vec4(rng: &mut Pcg64Mcg, r: f64) -> String {
    let v: Vec<String> = (0..4).map(|_| format!("{:.6e}", num(rng, -r, r))).collect();
    format!("[{}]", v.join(", "))
}

fn unit(rng: &mut Pcg64Mcg) -> DVec4 {
    loop {
        let v = DVec4::from_array(std::array::from_fn(|_| num(rng, -1.0, 1.0)));
        if v.length() > 0.1 && v.length() <= 1.0 {
            return v.normalize();
        }
    }
}

fn literal(v: DVec4) -> String {
    format!("[{:.9e}, {:.9e}, {:.9e}, {:.9e}]", v.x, v.y, v.z, v.w)
}

/// A shape of size about `s`, nested at most `depth` levels of CSG.
fn shape(rng: &mut Pcg64Mcg, s: f64, depth: u32) -> String {
    let base = match rng.random_range(0..if depth > 0 { 9 } else { 6 }) {
        0 => format!("hypersphere({:.6e})", s * num(rng, 0.3, 1.0)),
        1 => format!("hyperbox({})", {
            let v: Vec<String> = (0..4)
                .map(|_| format!("{:.6e}", s * num(rng, 0.2, 0.9)))
                .collect();
            format!("[{}]", v.join(", "))
        }),
        2 => format!(
            "halfspace(normal: {}, offset: {:.6e})",
            literal(unit(rng)),
            s * num(rng, -1.0, 1.0)
        ),
        3 => {
            let n = unit(rng);
            let (a, b) = (s * num(rng, 0.1, 1.0), s * num(rng, 0.1, 1.0));
            let (neg, n) = (literal(-n), literal(n));
            format!(
                "intersect(halfspace(normal: {n}, offset: {a:.6e}), halfspace(normal: {neg}, offset: {b:.6e}))"
            )
        }
        4 => format!(
            "(sdf |p| length(p - {}) - {:.6e})",
            vec4(rng, s * 0.5),
            s * num(rng, 0.3, 0.8)
        ),
        5 => format!(
            "hypersphere({:.6e}) |> tile(grid(spacing: {:.6e}, limit: [2, 2, 2, 2]))",
            s * 0.3,
            s * num(rng, 0.8, 1.5)
        ),
        k => {
            let op = ["union", "intersect", "subtract"][k as usize - 6];
            let (a, b) = (shape(rng, s, depth - 1), shape(rng, s, depth - 1));
            let smooth = if rng.random_bool(0.4) {
                format!(", smooth: {:.6e}", s * num(rng, 0.05, 0.3))
            } else {
                String::new()
            };
            format!("{op}({a}, {b}{smooth})")
        }
    };
    let mut out = base;
    for _ in 0..rng.random_range(0..3) {
        out = match rng.random_range(0..4) {
            0 => format!(
                "({out}) |> rotate({}, {:.3}deg)",
                PLANES[rng.random_range(0..6)],
                num(rng, -90.0, 90.0)
            ),
            1 => format!("({out}) |> translate({})", vec4(rng, s)),
            2 => format!("onion({out}, {:.6e})", s * num(rng, 0.02, 0.2)),
            _ => format!("round({out}, {:.6e})", s * num(rng, 0.01, 0.2)),
        };
    }
    out
}

/// The scene of `seed`: an 8 x 8 image, 1 spp, 2 bounces, a white sky, 1 to 3 objects.
pub fn generate(seed: u64) -> Generated {
    generated(seed, None)
}

/// `generate(seed)`'s scene over 5 frames, each object turning, moving or rounding with the
/// frame variable `t`: still at `t = 0` (the motions are drawn from a stream of their own, so
/// the rest of the scene is `generate`'s). Its camera moves too, as every animated scene's
/// does, from `from` to `to`: to the objects' centre, often inside one, on the last frame.
pub fn generate_moving(seed: u64) -> Generated {
    generated(seed, Some(Pcg64Mcg::seed_from_u64(seed ^ 0x6d6f_7669_6e67)))
}

/// A motion with `t` of a shape of size about `s`, 0 at `t = 0`.
fn motion(rng: &mut Pcg64Mcg, s: f64) -> String {
    match rng.random_range(0..3) {
        0 => format!(
            "rotate({}, {:.3}deg * t)",
            PLANES[rng.random_range(0..6)],
            num(rng, -90.0, 90.0)
        ),
        1 => format!("translate({} * t)", vec4(rng, s)),
        _ => format!("round({:.6e} * t)", s * num(rng, 0.01, 0.2)),
    }
}

/// `generate`, with objects set moving by draws from `moving`.
fn generated(seed: u64, mut moving: Option<Pcg64Mcg>) -> Generated {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let scale = [1e-3, 1.0, 1.0, 1.0, 30.0, 1e4][rng.random_range(0..6)];
    let far = if rng.random_bool(0.2) {
        scale * 1e3
    } else {
        0.0
    };
    let centre = DVec4::from_array(std::array::from_fn(|_| num(&mut rng, -far, far)));
    let c = literal;
    let dir = DVec4::from_array(std::array::from_fn(|_| num(&mut rng, -1.0, 1.0))).normalize();
    // Outside the objects mostly, sometimes among them.
    let from = centre + dir * scale * [6.0, 3.0, 0.5][rng.random_range(0..3)];
    let mut src = String::new();
    let frames = if moving.is_some() { "  frames = 5" } else { "" };
    writeln!(
        src,
        "render {{ size = 8 x 8  spp = 1  bounces = 2{frames} }}"
    )
    .unwrap();
    writeln!(
        src,
        "camera {{ from = {}  to = {}  fov = 70deg }}",
        c(from),
        c(centre)
    )
    .unwrap();
    writeln!(src, "sky = rgb(1)").unwrap();
    for i in 0..rng.random_range(1..4) {
        let material = if rng.random_bool(0.2) {
            "glass(ior: 1.5)"
        } else {
            "diffuse(rgb(0.5))"
        };
        let mut s = shape(&mut rng, scale, 2);
        if let Some(moving) = &mut moving {
            s = format!("({s}) |> {}", motion(moving, scale));
        }
        writeln!(
            src,
            "object o{i} {{ shape = ({s}) |> translate({}) material = {material} }}",
            c(centre + DVec4::from_array(std::array::from_fn(|_| num(&mut rng, -scale, scale))))
        )
        .unwrap();
    }
    Generated { source: src, scale }
}
