//! Helpers shared by the test files: quadrature and the chi-square distribution for sampler
//! tests, rendering a scene from source with the checks every render must pass, and running the
//! command line on a small scene.
#![allow(dead_code)] // each test file uses a different subset

use glam::DVec3;
use hyperslice::Compilation;
use hyperslice::Rendered;
use hyperslice::render::driver::{Monitor, Options};
use hyperslice::scene::Denoise;
use rand::Rng;
use rand_pcg::Pcg64Mcg;
use std::f64::consts::PI;
use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

/// Composite 5-point Gauss-Legendre quadrature on `[a, b]` with `panels` equal panels: exact
/// for polynomials of degree 9 per panel, and it never evaluates the end points, where the
/// integrands here sit on a pole of the coordinates or on the horizon (a microfacet normal
/// exactly tangent to the surface cannot be recomputed from `wi + wo` to any relative precision).
pub fn gauss(a: f64, b: f64, panels: usize, mut f: impl FnMut(f64) -> f64) -> f64 {
    const X: [f64; 5] = [
        -0.906_179_845_938_664,
        -0.538_469_310_105_683_1,
        0.0,
        0.538_469_310_105_683_1,
        0.906_179_845_938_664,
    ];
    const W: [f64; 5] = [
        0.236_926_885_056_189_1,
        0.478_628_670_499_366_5,
        0.568_888_888_888_888_9,
        0.478_628_670_499_366_5,
        0.236_926_885_056_189_1,
    ];
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for k in 0..panels {
        let mid = a + (k as f64 + 0.5) * h;
        sum += X
            .iter()
            .zip(W)
            .map(|(x, w)| w * f(mid + 0.5 * h * x))
            .sum::<f64>();
    }
    0.5 * h * sum
}

/// `ln Gamma(x)` for `x > 0`: Lanczos' approximation (g = 7, 9 coefficients), relative error
/// about 1e-15, with the reflection formula below 1/2.
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    for (k, c) in C.iter().enumerate().skip(1) {
        a += c / (x + k as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Upper regularised incomplete gamma `Q(a, x) = Gamma(a, x) / Gamma(a)`: the series for
/// `P = 1 - Q` when `x < a + 1`, else the continued fraction for `Q` by modified Lentz
/// (Numerical Recipes, 6.2). Each converges fast in its region, for the hundreds of degrees of
/// freedom the histograms have too.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..100_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        1.0 - sum * log_prefactor.exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        h * log_prefactor.exp()
    }
}

/// Survival function of the chi-square distribution: `P(X >= stat) = Q(dof / 2, stat / 2)`.
pub fn chi2_sf(stat: f64, dof: usize) -> f64 {
    gamma_q(0.5 * dof as f64, 0.5 * stat)
}

pub fn uniforms(rng: &mut Pcg64Mcg) -> DVec3 {
    DVec3::new(rng.random(), rng.random(), rng.random())
}

/// Time any one of these renders may take (release build, a loaded 2-core machine).
pub const TIME_BOUND: Duration = Duration::from_secs(30);

/// Render `src`. The physics tests judge the estimator, so the scene is not denoised unless
/// it says `denoise` itself (the language's default is `atrous`; the filters have their own
/// tests in `tests/denoise.rs`).
pub fn render_with(src: &str, options: Options) -> Rendered {
    let c = Compilation::from_source("test.4ds", src);
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
    let mut scene = c.scene.expect("a scene");
    if !src.contains("denoise") {
        scene.render.denoise = Denoise::None;
    }
    let r = hyperslice::render(&scene, &options, Monitor::SILENT).expect("rendered");
    assert!(r.elapsed < TIME_BOUND, "took {:?}", r.elapsed);
    for film in &r.frames {
        for c in &film.color {
            assert!(c.is_finite() && c.min_element() >= 0.0, "pixel {c}");
        }
    }
    assert_eq!(r.stats.dropped, 0, "no sample came out NaN or infinite");
    r
}

pub fn render(src: &str) -> Rendered {
    render_with(src, Options::default())
}

/// Mean over all pixels of every frame, and its standard error (pixels are independent).
pub fn mean_and_error(r: &Rendered) -> (DVec3, DVec3) {
    let films = &r.frames;
    let n: usize = films.iter().map(|f| f.color.len()).sum();
    let mean = films.iter().flat_map(|f| &f.color).sum::<DVec3>() / n as f64;
    let var = films
        .iter()
        .flat_map(|f| &f.std_error)
        .map(|e| *e * *e)
        .sum::<DVec3>();
    (mean, var.map(f64::sqrt) / n as f64)
}

pub fn assert_mean(what: &str, r: &Rendered, want: DVec3) {
    let (mean, se) = mean_and_error(r);
    for c in 0..3 {
        let tol = 4.0 * se[c] + 1e-9 * want[c].abs().max(1.0);
        assert!(
            (mean[c] - want[c]).abs() <= tol,
            "{what}: channel {c} mean {} expected {} (4 sigma = {tol})",
            mean[c],
            want[c]
        );
    }
}

/// The least-squares slope of `y` against `x` (the fit `bench --costs` uses).
pub fn slope(points: &[(f64, f64)]) -> f64 {
    hyperslice::sweep::costs::slope(points).expect("two distinct x")
}

/// Two independent renders of the same scene agree: every channel's means within 4 standard
/// errors of their difference. Returns both renders' standard errors.
pub fn assert_means_agree(what: &str, a: &Rendered, b: &Rendered) -> (DVec3, DVec3) {
    let ((m1, s1), (m2, s2)) = (mean_and_error(a), mean_and_error(b));
    eprintln!("{what}: {m1} +- {s1} against {m2} +- {s2}");
    for c in 0..3 {
        let tol = 4.0 * (s1[c] * s1[c] + s2[c] * s2[c]).sqrt();
        assert!(
            (m1[c] - m2[c]).abs() <= tol,
            "{what}: channel {c}: {} against {} (4 sigma = {tol})",
            m1[c],
            m2[c]
        );
    }
    (s1, s2)
}

/// A lit ball under a sky: light sampling matters, and it renders in moments.
pub const LIT_BALL: &str = "render { size = 320 x 240  frames = 3  spp = 64 }
sky = rgb(0.6, 0.7, 0.9)
object ball { shape = hypersphere(1) material = diffuse(albedo: rgb(0.8, 0.3, 0.2)) }
object lamp { shape = hypersphere(0.5) |> translate([1, 2, 0, 0]) material = light(intensity: 5) }
";

/// A temporary directory holding [`LIT_BALL`] as `scene.4ds`.
pub fn scene_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("scene.4ds"), LIT_BALL).expect("scene written");
    dir
}

/// Run the `hyperslice` binary in `dir` with `args`.
pub fn hyperslice(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hyperslice"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("ran hyperslice")
}
