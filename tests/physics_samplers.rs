//! Numerical checks of the 4D light-transport building blocks (`render::sampling`, `bsdf`,
//! `phase`), after the physics notes' "Tests the best renderers run":
//! - item 3: GGX identities by quadrature (NDF normalisation, Smith projected area), the weak
//!   white furnace, and the single-scatter albedo table;
//! - item 4: chi-square goodness of fit of every sampler against its pdf;
//! - item 5: sample/eval/pdf consistency, reciprocity, albedo <= 1, and the dielectric's Fresnel,
//!   total internal reflection and eta^3 bookkeeping.
//!
//! Every random test uses a fixed seed. Tolerances are chosen so that the 3D formula a 4D port is
//! likely to keep by mistake (`rho / pi`, `1 / (4 o.h)`, `u = xi`, `eta^2`) fails them.

mod common;

use common::*;
use glam::{DVec3, DVec4};
use hyperslice::render::bsdf::{Bsdf, Dielectric, Ggx, Lambert, Mirror};
use hyperslice::render::phase::{HenyeyGreenstein, Isotropic, PhaseFunction};
use hyperslice::render::sampling::{
    Frame, cosine_hemisphere_pdf, fresnel_dielectric, uniform_s2, uniform_s3,
};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Numerics shared by the tests.

/// A uniformly random direction of the upper hemisphere (`w >= 0`) of a local frame.
fn upper_direction(rng: &mut Pcg64Mcg) -> DVec4 {
    let d = uniform_s3(uniforms(rng));
    DVec4::new(d.x, d.y, d.z, d.w.abs())
}

/// The direction at angle `theta` from e4, tilted towards e1.
fn tilted(theta: f64) -> DVec4 {
    DVec4::new(theta.sin(), 0.0, 0.0, theta.cos())
}

fn assert_close(what: &str, got: f64, want: f64, tol: f64) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got:.9}, want {want:.9} (tolerance {tol:e}, off by {:e})",
        (got - want).abs()
    );
}

// ---------------------------------------------------------------------------------------------
// The chi-square harness, shared by every sampler.

/// Samples per chi-square test.
const CHI2_SAMPLES: usize = 1_000_000;
/// The number of chi-square comparisons in this file, for the Sidak correction: Lambert 1,
/// GGX visible normals 3, isotropic phase 1, Henyey-Greenstein 3.
const CHI2_TESTS: i32 = 8;
/// Family-wise significance level.
const SIGNIFICANCE: f64 = 0.01;

/// Pearson's statistic after pooling every cell whose expected count is below 5 into one cell
/// (merged with the next smallest cell if the pool itself stays below 5). Returns
/// `(statistic, degrees of freedom, the three worst cells)`, or an error if samples landed where
/// the pdf is exactly zero.
fn pooled_chi2(observed: &[f64], expected: &[f64]) -> Result<(f64, usize, String), String> {
    let mut cells: Vec<(usize, f64, f64)> = Vec::new();
    for (k, (&e, &o)) in expected.iter().zip(observed).enumerate() {
        if e <= 0.0 && o > 0.0 {
            return Err(format!("{o} samples in cell {k}, where the pdf is zero"));
        }
        cells.push((k, e, o));
    }
    cells.sort_by(|a, b| a.1.total_cmp(&b.1));
    let split = cells.partition_point(|c| c.1 < 5.0);
    let mut kept = cells.split_off(split);
    let mut pool = (usize::MAX, 0.0, 0.0);
    for (_, e, o) in cells {
        pool.1 += e;
        pool.2 += o;
    }
    if pool.1 > 0.0 {
        if pool.1 < 5.0 && !kept.is_empty() {
            let (_, e, o) = kept.remove(0);
            pool.1 += e;
            pool.2 += o;
        }
        kept.push(pool);
    }
    let mut terms: Vec<(f64, usize, f64, f64)> = kept
        .iter()
        .map(|&(k, e, o)| ((o - e) * (o - e) / e, k, o, e))
        .collect();
    let stat = terms.iter().map(|t| t.0).sum();
    terms.sort_by(|a, b| b.0.total_cmp(&a.0));
    let worst = terms
        .iter()
        .take(3)
        .map(|&(_, k, o, e)| {
            let cell = if k == usize::MAX {
                "pool".to_string()
            } else {
                k.to_string()
            };
            format!("cell {cell}: observed {o}, expected {e:.1}")
        })
        .collect::<Vec<_>>()
        .join("; ");
    Ok((stat, kept.len() - 1, worst))
}

/// Draws `CHI2_SAMPLES` samples, bins each with `draw` (`None`: outside every cell, including
/// zero-weight samples) and tests the histogram against the cell probabilities `probabilities`;
/// the probability of "outside" is what they leave over. Passes at the Sidak-corrected level.
fn assert_fits(
    name: &str,
    seed: u64,
    probabilities: &[f64],
    mut draw: impl FnMut(DVec3) -> Option<usize>,
) {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut observed = vec![0.0; probabilities.len() + 1];
    for _ in 0..CHI2_SAMPLES {
        let cell = draw(uniforms(&mut rng)).unwrap_or(probabilities.len());
        observed[cell] += 1.0;
    }
    let n = CHI2_SAMPLES as f64;
    let mut expected: Vec<f64> = probabilities.iter().map(|p| p * n).collect();
    let inside: f64 = expected.iter().sum();
    expected.push((n - inside).max(0.0));
    let (stat, dof, worst) =
        pooled_chi2(&observed, &expected).unwrap_or_else(|e| panic!("{name}: {e}"));
    let p_value = chi2_sf(stat, dof);
    let threshold = 1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / CHI2_TESTS as f64);
    eprintln!("{name}: chi-square {stat:.1}, {dof} degrees of freedom, p = {p_value:.3}");
    assert!(
        p_value > threshold,
        "{name}: chi-square {stat:.1} with {dof} degrees of freedom, p = {p_value:.3e} < {threshold:.3e}; \
         worst: {worst}"
    );
}

/// Cells on S^3 in a local frame: theta = acos(w) in `n_theta` bins over `[0, theta_max]`, and
/// phi = atan2(y, x) in `n_phi` bins over `[-pi, pi]`. Phi mixes e1, the plane of incidence of
/// the tested lobes, with e2, so a lobe rotated or skewed within the tangent space shows up.
struct SphereGrid {
    theta_max: f64,
    n_theta: usize,
    n_phi: usize,
}

impl SphereGrid {
    fn cell(&self, o: DVec4) -> Option<usize> {
        let theta = o.w.clamp(-1.0, 1.0).acos();
        if theta >= self.theta_max {
            return None;
        }
        let i = ((theta / self.theta_max * self.n_theta as f64) as usize).min(self.n_theta - 1);
        let phi = o.y.atan2(o.x);
        let j = (((phi + PI) / (2.0 * PI) * self.n_phi as f64) as usize).min(self.n_phi - 1);
        Some(i * self.n_phi + j)
    }

    /// Each cell's probability, integrating `pdf` with nested Gauss-Legendre rules in hyperspherical
    /// coordinates `o = (sin t sin s cos p, sin t sin s sin p, sin t cos s, cos t)`, whose measure
    /// is `sin^2 t sin s dt ds dp` (s over `[0, pi]` integrated out within each cell).
    fn probabilities(&self, pdf: impl Fn(DVec4) -> f64) -> Vec<f64> {
        let dt = self.theta_max / self.n_theta as f64;
        let dp = 2.0 * PI / self.n_phi as f64;
        let mut out = Vec::with_capacity(self.n_theta * self.n_phi);
        for i in 0..self.n_theta {
            for j in 0..self.n_phi {
                let t0 = i as f64 * dt;
                let p0 = -PI + j as f64 * dp;
                out.push(gauss(t0, t0 + dt, 1, |t| {
                    let (st, ct) = t.sin_cos();
                    st * st
                        * gauss(p0, p0 + dp, 1, |p| {
                            let (sp, cp) = p.sin_cos();
                            gauss(0.0, PI, 10, |s| {
                                let (ss, cs) = s.sin_cos();
                                let o = DVec4::new(st * ss * cp, st * ss * sp, st * cs, ct);
                                pdf(o) * ss
                            })
                        })
                }));
            }
        }
        out
    }
}

/// Chi-square test of a direction sampler (in the grid's local frame) against its pdf.
fn assert_direction_sampler(
    name: &str,
    seed: u64,
    grid: &SphereGrid,
    pdf: impl Fn(DVec4) -> f64,
    mut sample: impl FnMut(DVec3) -> Option<DVec4>,
) {
    let probabilities = grid.probabilities(pdf);
    assert_fits(name, seed, &probabilities, |u| {
        sample(u).and_then(|o| grid.cell(o))
    });
}

// ---------------------------------------------------------------------------------------------
// The harness itself.

#[test]
fn chi2_survival_function_matches_closed_forms() {
    // For even dof k: P(X >= x) = exp(-x/2) sum_{j < k/2} (x/2)^j / j!, summed in log space.
    for k in [2usize, 4, 10, 200, 1000] {
        for x in [0.3 * k as f64, k as f64, 1.5 * k as f64, 3.0 * k as f64] {
            let half = 0.5 * x;
            let exact: f64 = (0..k / 2)
                .map(|j| (j as f64 * half.ln() - half - ln_gamma(j as f64 + 1.0)).exp())
                .sum();
            let got = chi2_sf(x, k);
            assert!(
                (got - exact).abs() <= 1e-10 * exact.max(1e-300) + 1e-14,
                "chi2_sf({x}, {k}) = {got:e}, want {exact:e}"
            );
        }
    }
    assert_close("ln_gamma(0.5)", ln_gamma(0.5), 0.5 * PI.ln(), 1e-14);
}

// ---------------------------------------------------------------------------------------------
// Frames and the small helpers.

#[test]
fn frame_is_orthonormal_and_maps_e4_to_the_normal() {
    let mut rng = Pcg64Mcg::seed_from_u64(1);
    let mut normals = vec![
        DVec4::X,
        -DVec4::X,
        DVec4::Y,
        DVec4::Z,
        DVec4::W,
        -DVec4::W,
        DVec4::new(1e-9, -2e-9, 0.0, 1.0).normalize(),
        DVec4::new(1e-9, 0.0, 3e-9, -1.0).normalize(),
        DVec4::new(1.0, 0.0, 0.0, 1e-12).normalize(),
    ];
    normals.extend((0..1000).map(|_| uniform_s3(uniforms(&mut rng))));
    let axes = [DVec4::X, DVec4::Y, DVec4::Z, DVec4::W];
    for n in normals {
        let frame = Frame::new(n);
        assert!((frame.to_world(DVec4::W) - n).length() < 1e-15, "e4 -> {n}");
        let images = axes.map(|a| frame.to_world(a));
        for (i, a) in images.iter().enumerate() {
            for (j, b) in images.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (a.dot(*b) - want).abs() < 1e-14,
                    "frame of {n}: e{}.e{} = {}",
                    i + 1,
                    j + 1,
                    a.dot(*b)
                );
            }
        }
        let x = uniform_s3(uniforms(&mut rng));
        assert!((frame.to_local(frame.to_world(x)) - x).length() < 1e-15);
        assert!((frame.to_local(n) - DVec4::W).length() < 1e-15);
    }
}

#[test]
fn fresnel_at_normal_incidence() {
    for n in [1.0f64, 1.33, 1.5, 2.42] {
        let want = ((n - 1.0) / (n + 1.0)).powi(2);
        assert_close(
            "outside -> inside",
            fresnel_dielectric(1.0, 1.0, n),
            want,
            1e-15,
        );
        assert_close(
            "inside -> outside",
            fresnel_dielectric(1.0, n, 1.0),
            want,
            1e-15,
        );
    }
    // Grazing incidence reflects everything; past the critical angle too.
    assert_eq!(fresnel_dielectric(0.0, 1.0, 1.5), 1.0);
    // Oblique incidence against high-precision values of (R_s + R_p) / 2 (Schlick would give
    // 0.0421 for the first).
    let cases = [
        (PI / 4.0, 1.0, 1.5, 0.050_239_911_012_235_94),
        (PI / 6.0, 1.5, 1.0, 0.055_190_167_295_375_92),
        (1.2, 1.0, 1.33, 0.118_768_666_119_145_5),
    ];
    for (theta, eta_i, eta_t, want) in cases {
        assert_close(
            "oblique Fresnel",
            fresnel_dielectric(theta.cos(), eta_i, eta_t),
            want,
            1e-14,
        );
    }
    assert_eq!(fresnel_dielectric(0.5, 1.5, 1.0), 1.0);
}

// ---------------------------------------------------------------------------------------------
// Item 3: GGX identities by quadrature, furnaces.

#[test]
fn ggx_ndf_projected_integral_is_one() {
    // D depends on theta only; the S^3 measure is 4 pi sin^2(theta) d(theta).
    for alpha in [0.02, 0.1, 0.3, 0.6, 1.0] {
        let ggx = Ggx {
            alpha,
            color: DVec3::ONE,
        };
        let integral = gauss(0.0, PI / 2.0, 2000, |t| {
            let (s, c) = t.sin_cos();
            ggx.ndf(tilted(t)) * c * 4.0 * PI * s * s
        });
        assert_close(
            &format!("integral of D cos, alpha {alpha}"),
            integral,
            1.0,
            1e-6,
        );
    }
}

/// `integral of max(0, v.m) D(m) d(omega_m)` for `v = tilted(theta_v)`. With `m` at angle t from
/// the normal and angle b (polar, on the S^2 of tangential directions) from v's tangential part,
/// `v.m = A + B cos b` with `A = cos theta_v cos t`, `B = sin theta_v sin t`; the b integral is
/// closed-form: `4 pi A` when `A >= B`, else `pi (A + B)^2 / B`. The t integral is split where
/// the two meet, `t = pi/2 - theta_v`, so that the quadrature sees smooth pieces.
fn ggx_projected_area(ggx: &Ggx, theta_v: f64) -> f64 {
    let (sv, cv) = theta_v.sin_cos();
    let integrand = |t: f64| {
        let (st, ct) = t.sin_cos();
        let (a, b) = (cv * ct, sv * st);
        let inner = if a >= b {
            4.0 * PI * a
        } else {
            PI * (a + b) * (a + b) / b
        };
        ggx.ndf(tilted(t)) * st * st * inner
    };
    let kink = PI / 2.0 - theta_v;
    gauss(0.0, kink, 2000, integrand) + gauss(kink, PI / 2.0, 2000, integrand)
}

#[test]
fn ggx_smith_projected_area_identity() {
    // integral (v.m)+ D(m) d(omega_m) = cos(theta_v) (1 + Lambda(v)).
    for alpha in [0.05, 0.3, 0.6, 1.0] {
        let ggx = Ggx {
            alpha,
            color: DVec3::ONE,
        };
        for theta_v in [0.0, 0.4, 0.9, 1.3, 1.55] {
            let v = tilted(theta_v);
            let want = v.w * (1.0 + ggx.lambda(v));
            let got = ggx_projected_area(&ggx, theta_v);
            assert_close(
                &format!("Smith identity, alpha {alpha}, theta_v {theta_v}"),
                got,
                want,
                1e-6,
            );
        }
    }
}

#[test]
fn ggx_weak_white_furnace_is_one() {
    // integral over all of S^3 of G1(o) D(h) / (8 (i.h) |i.n| (o.n)) |i.n| d(omega_i) = 1.
    // Quadrature over the half vector h = (sin t (c e1 + sqrt(1 - c^2) e2), cos t), i.e. over t
    // and c = cos b as in `ggx_projected_area` (the S^2 measure is dc; the integrand is smooth in
    // c), with i = 2 (o.h) h - o and this test's own Jacobian d(omega_i) = 8 (o.h)^2 d(omega_h):
    // the library's `unshadowed` must carry the matching 4D factor 8 (i.h). The c range starts
    // where o.h = 0, the t range is split where that cut reaches c = -1.
    for alpha in [0.3, 0.6, 1.0] {
        let ggx = Ggx {
            alpha,
            color: DVec3::ONE,
        };
        for theta_o in [0.0, 0.7, 1.3] {
            let o = tilted(theta_o);
            let (so, co) = theta_o.sin_cos();
            let over_t = |t: f64| {
                let (st, ct) = t.sin_cos();
                let (a, b) = (co * ct, so * st);
                let c_min = if a >= b { -1.0 } else { -a / b };
                let over_c = gauss(c_min, 1.0, 4, |c| {
                    let h = DVec4::new(st * c, st * (1.0 - c * c).max(0.0).sqrt(), 0.0, ct);
                    let oh = o.dot(h);
                    if oh <= 0.0 {
                        return 0.0;
                    }
                    let i = 2.0 * oh * h - o;
                    ggx.unshadowed(o, i) * i.w.abs() * 8.0 * oh * oh
                });
                2.0 * PI * st * st * over_c
            };
            let kink = PI / 2.0 - theta_o;
            let total =
                ggx.g1(o) * (gauss(0.0, kink, 200, over_t) + gauss(kink, PI / 2.0, 200, over_t));
            assert_close(
                &format!("weak furnace, alpha {alpha}, theta_o {theta_o}"),
                total,
                1.0,
                1e-6,
            );
        }
    }
}

/// Reference single-scatter albedos (F = 1) from the physics notes: (alpha, theta_i, albedo).
const ALBEDO_TABLE: [(f64, f64, f64); 3] =
    [(0.3, 0.0, 0.824), (0.6, 0.8, 0.496), (1.0, 1.3, 0.467)];

#[test]
fn ggx_single_scatter_albedo_by_quadrature() {
    // E(o) = integral of f(o, i) cos(theta_i) over the upper hemisphere, through `eval`.
    for (alpha, theta_o, want) in ALBEDO_TABLE {
        let ggx = Ggx {
            alpha,
            color: DVec3::ONE,
        };
        let o = tilted(theta_o);
        let albedo = gauss(0.0, PI / 2.0, 100, |t| {
            let (st, ct) = t.sin_cos();
            2.0 * PI
                * st
                * st
                * ct
                * gauss(-1.0, 1.0, 40, |c| {
                    let i = DVec4::new(st * c, st * (1.0 - c * c).max(0.0).sqrt(), 0.0, ct);
                    ggx.eval(o, i).x
                })
        });
        eprintln!("albedo by quadrature, alpha {alpha}, theta {theta_o}: {albedo:.5}");
        assert_close(
            &format!("albedo by quadrature, alpha {alpha}, theta {theta_o}"),
            albedo,
            want,
            0.002,
        );
    }
}

#[test]
fn ggx_single_scatter_albedo_by_sampling() {
    // The same albedos as the mean sample weight (zero-weight samples included).
    let n = 1_000_000;
    for (k, (alpha, theta_o, want)) in ALBEDO_TABLE.into_iter().enumerate() {
        let ggx = Ggx {
            alpha,
            color: DVec3::ONE,
        };
        let o = tilted(theta_o);
        let mut rng = Pcg64Mcg::seed_from_u64(100 + k as u64);
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let w = ggx
                .sample(o, uniforms(&mut rng))
                .map_or(0.0, |s| s.weight.x);
            sum += w;
            sum2 += w * w;
        }
        let mean = sum / n as f64;
        let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!(sigma < 5e-4, "too noisy to compare: sigma {sigma}");
        eprintln!("albedo by sampling, alpha {alpha}, theta {theta_o}: {mean:.5} +- {sigma:.5}");
        assert_close(
            &format!("albedo by sampling, alpha {alpha}, theta {theta_o}"),
            mean,
            want,
            0.002,
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Item 4: chi-square goodness of fit.

/// The hemisphere grid used for reflection lobes.
const HEMISPHERE: SphereGrid = SphereGrid {
    theta_max: PI / 2.0,
    n_theta: 40,
    n_phi: 32,
};

#[test]
fn chi2_lambert_cosine_hemisphere() {
    let lambert = Lambert { albedo: DVec3::ONE };
    let wi = tilted(0.6);
    assert_direction_sampler(
        "Lambert (Malley cosine hemisphere)",
        11,
        &HEMISPHERE,
        |o| cosine_hemisphere_pdf(o.w),
        |u| lambert.sample(wi, u).map(|s| s.wo),
    );
}

#[test]
fn chi2_ggx_visible_normals() {
    for (k, (alpha, theta_i)) in [(0.15, 0.4), (0.5, 1.1), (1.0, 1.45)]
        .into_iter()
        .enumerate()
    {
        let ggx = Ggx {
            alpha,
            color: DVec3::ONE,
        };
        let wi = tilted(theta_i);
        assert_direction_sampler(
            &format!("GGX visible normals, alpha {alpha}, theta_i {theta_i}"),
            20 + k as u64,
            &HEMISPHERE,
            |o| ggx.pdf(wi, o),
            |u| ggx.sample(wi, u).map(|s| s.wo),
        );
    }
}

#[test]
fn chi2_isotropic_phase_on_the_disk() {
    // A uniform point of S^3 projected to two orthonormal coordinates (o.n, o.t) is uniform on
    // the unit disk, so cells equal in r^2 and in angle are equally likely.
    let wi = DVec4::new(0.3, -0.5, 0.2, 0.8).normalize();
    let n = -wi;
    let t = Frame::new(n).to_world(DVec4::X);
    let (n_r, n_a) = (32, 32);
    let probabilities = vec![1.0 / (n_r * n_a) as f64; n_r * n_a];
    assert_fits("isotropic phase", 30, &probabilities, |u| {
        let o = Isotropic.sample(wi, u).wo;
        let (x, y) = (o.dot(n), o.dot(t));
        let r2 = x * x + y * y;
        let i = ((r2 * n_r as f64) as usize).min(n_r - 1);
        let j = (((y.atan2(x) + PI) / (2.0 * PI) * n_a as f64) as usize).min(n_a - 1);
        Some(i * n_a + j)
    });
}

#[test]
fn chi2_henyey_greenstein() {
    // Binned in the frame of the forward direction -wi, over the whole sphere.
    let grid = SphereGrid {
        theta_max: PI,
        n_theta: 64,
        n_phi: 16,
    };
    let wi = DVec4::new(-0.2, 0.7, 0.1, -0.4).normalize();
    let frame = Frame::new(-wi);
    for (k, g) in [-0.7, 0.3, 0.9].into_iter().enumerate() {
        let hg = HenyeyGreenstein::new(g);
        assert_direction_sampler(
            &format!("Henyey-Greenstein g {g}"),
            40 + k as u64,
            &grid,
            |o| hg.pdf(wi, frame.to_world(o)),
            |u| Some(frame.to_local(hg.sample(wi, u).wo)),
        );
    }
}

#[test]
fn henyey_greenstein_theta_distribution() {
    // |g| = 1 would be a delta: clamped. Tiny |g| is the isotropic lobe.
    assert_eq!(HenyeyGreenstein::new(1.5).g(), HenyeyGreenstein::G_MAX);
    assert_eq!(HenyeyGreenstein::new(-1.0).g(), -HenyeyGreenstein::G_MAX);
    let nearly_isotropic = HenyeyGreenstein::new(0.5 * HenyeyGreenstein::ISOTROPIC_BELOW);
    assert_eq!(nearly_isotropic.eval_cos(1.0), 1.0 / (2.0 * PI * PI));
    for g in [-0.95, -0.7, -1e-3, 1e-3, 0.3, 0.9, 0.99] {
        let hg = HenyeyGreenstein::new(g);
        // The closed-form CDF is the integral of the theta density, reaching 1 at pi.
        for theta in [0.05, 0.5, 1.5, 2.5, PI] {
            let integral = gauss(0.0, theta, 2000, |t| hg.theta_pdf(t));
            assert_close(
                &format!("CDF(g {g}, theta {theta})"),
                hg.theta_cdf(theta),
                integral,
                1e-9,
            );
        }
        // The mean cosine is exactly g.
        let mean_cos = gauss(0.0, PI, 2000, |t| hg.theta_pdf(t) * t.cos());
        assert_close(&format!("mean cosine, g {g}"), mean_cos, g, 1e-8);
        // The Newton-bisection inversion hits the CDF.
        for xi in [0.0, 1e-9, 0.01, 0.3, 0.5, 0.77, 0.999, 1.0 - 1e-12] {
            let theta = hg.sample_theta(xi);
            assert!((0.0..=PI).contains(&theta));
            assert_close(
                &format!("CDF(inverse(xi {xi})), g {g}"),
                hg.theta_cdf(theta),
                xi,
                1e-10,
            );
        }
        // Sampled directions carry pdf == eval.
        let mut rng = Pcg64Mcg::seed_from_u64(50);
        let wi = upper_direction(&mut rng);
        for _ in 0..100 {
            let s = hg.sample(wi, uniforms(&mut rng));
            assert_close("sampled direction is unit", s.wo.length(), 1.0, 1e-12);
            assert_close("sample pdf == eval", s.pdf, hg.eval(wi, s.wo), 1e-9 * s.pdf);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Item 5: consistency, reciprocity, energy.

fn continuous_bsdfs() -> Vec<(String, Box<dyn Bsdf>)> {
    let metal = DVec3::new(0.95, 0.64, 0.54);
    let mut out: Vec<(String, Box<dyn Bsdf>)> = vec![(
        "Lambert".into(),
        Box::new(Lambert {
            albedo: DVec3::new(0.8, 0.5, 0.2),
        }),
    )];
    for alpha in [Ggx::ALPHA_MIN, 0.02, 0.3, 1.0] {
        out.push((
            format!("GGX alpha {alpha}"),
            Box::new(Ggx {
                alpha,
                color: metal,
            }),
        ));
    }
    out
}

#[test]
fn bsdf_sample_weight_equals_eval_cos_over_pdf() {
    let mut rng = Pcg64Mcg::seed_from_u64(60);
    for (name, bsdf) in continuous_bsdfs() {
        let mut drawn = 0;
        for k in 0..20_000 {
            // Every tenth incident direction is grazing.
            let mut wi = upper_direction(&mut rng);
            if k % 10 == 0 {
                wi = DVec4::new(wi.x, wi.y, wi.z, 1e-4).normalize();
            }
            let Some(s) = bsdf.sample(wi, uniforms(&mut rng)) else {
                continue;
            };
            drawn += 1;
            assert!(!s.delta, "{name}: delta sample");
            assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{name}: pdf {}", s.pdf);
            let pdf = bsdf.pdf(wi, s.wo);
            assert!(
                (pdf - s.pdf).abs() <= 1e-9 * pdf,
                "{name}: sample pdf {} vs pdf() {pdf}",
                s.pdf
            );
            let expected = bsdf.eval(wi, s.wo) * s.wo.w.abs() / s.pdf;
            let err = (s.weight - expected).abs().max_element();
            assert!(
                err <= 1e-4 * s.weight.max_element().max(expected.max_element()) + 1e-300,
                "{name}: weight {} vs eval cos / pdf {expected} (wi {wi}, wo {})",
                s.weight,
                s.wo
            );
        }
        assert!(drawn > 10_000, "{name}: only {drawn} samples drawn");
    }
}

#[test]
fn bsdf_reciprocity() {
    let mut rng = Pcg64Mcg::seed_from_u64(61);
    for (name, bsdf) in continuous_bsdfs() {
        for _ in 0..10_000 {
            let (a, b) = (upper_direction(&mut rng), upper_direction(&mut rng));
            let (ab, ba) = (bsdf.eval(a, b), bsdf.eval(b, a));
            assert!(
                ab.is_finite() && ab.min_element() >= 0.0,
                "{name}: f = {ab}"
            );
            assert!(
                (ab - ba).abs().max_element() <= 1e-12 * ab.max_element(),
                "{name}: f(a,b) {ab} != f(b,a) {ba}"
            );
        }
    }
}

#[test]
fn bsdf_albedo_at_most_one() {
    // White versions of every BSDF, 64 incident directions from normal to grazing.
    let bsdfs: Vec<(String, Box<dyn Bsdf>)> = vec![
        ("Lambert".into(), Box::new(Lambert { albedo: DVec3::ONE })),
        ("Mirror".into(), Box::new(Mirror { tint: DVec3::ONE })),
        (
            "GGX roughness 0".into(),
            Box::new(Ggx::from_roughness(0.0, DVec3::ONE)),
        ),
        (
            "GGX alpha 0.05".into(),
            Box::new(Ggx {
                alpha: 0.05,
                color: DVec3::ONE,
            }),
        ),
        (
            "GGX alpha 0.3".into(),
            Box::new(Ggx {
                alpha: 0.3,
                color: DVec3::ONE,
            }),
        ),
        (
            "GGX roughness 1".into(),
            Box::new(Ggx::from_roughness(1.0, DVec3::ONE)),
        ),
    ];
    let n = 10_000;
    let mut rng = Pcg64Mcg::seed_from_u64(62);
    for (name, bsdf) in bsdfs {
        for k in 0..64 {
            let theta = (k as f64 + 0.5) / 64.0 * PI / 2.0;
            let (st, ct) = theta.sin_cos();
            let wi = (st * DVec3::from_array(uniform_s2(rng.random(), rng.random()))).extend(ct);
            let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
            for _ in 0..n {
                let w = bsdf
                    .sample(wi, uniforms(&mut rng))
                    .map_or(DVec3::ZERO, |s| s.weight);
                sum += w;
                sum2 += w * w;
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean).max(DVec3::ZERO) / n as f64).powf(0.5);
            let bound = DVec3::ONE + 4.0 * sigma + 1e-12;
            assert!(
                mean.cmple(bound).all(),
                "{name}, theta {theta:.3}: albedo {mean} > 1 + 4 sigma ({sigma})"
            );
        }
    }
}

#[test]
fn lambert_weight_is_exactly_the_albedo() {
    let albedo = DVec3::new(0.8, 0.5, 0.2);
    let lambert = Lambert { albedo };
    let mut rng = Pcg64Mcg::seed_from_u64(63);
    for _ in 0..10_000 {
        let wi = upper_direction(&mut rng);
        if let Some(s) = lambert.sample(wi, uniforms(&mut rng)) {
            assert_eq!(s.weight, albedo);
        }
    }
    // f = 3 rho / (4 pi), not rho / pi.
    assert_close(
        "Lambert f",
        lambert.eval(DVec4::W, DVec4::W).x,
        3.0 * 0.8 / (4.0 * PI),
        1e-15,
    );
}

#[test]
fn ggx_roughness_extremes_stay_finite() {
    let color = DVec3::new(0.9, 0.7, 0.3);
    let mut rng = Pcg64Mcg::seed_from_u64(64);
    let mut directions = vec![DVec4::W, tilted(PI / 2.0 - 1e-9), tilted(1e-12)];
    directions.extend((0..2000).map(|_| upper_direction(&mut rng)));
    // Roughness 0 (and a zero alpha written directly) is a perfect mirror.
    for mirror in [Ggx::from_roughness(0.0, color), Ggx { alpha: 0.0, color }] {
        assert!(mirror.is_mirror());
        for &wi in &directions {
            let s = mirror
                .sample(wi, uniforms(&mut rng))
                .expect("a mirror always reflects");
            assert!(s.delta && s.weight.is_finite() && s.wo.is_finite());
            assert!((s.wo - DVec4::new(-wi.x, -wi.y, -wi.z, wi.w)).length() < 1e-15);
            assert_eq!(s.weight, mirror.fresnel(wi.w));
            assert_eq!(mirror.eval(wi, s.wo), DVec3::ZERO);
            assert_eq!(mirror.pdf(wi, s.wo), 0.0);
        }
    }
    // Small non-zero roughness is clamped to a continuous lobe; roughness 1 is alpha 1.
    assert_eq!(Ggx::from_roughness(1e-3, color).alpha, Ggx::ALPHA_MIN);
    assert_eq!(Ggx::from_roughness(0.5, color).alpha, 0.25);
    let rough = Ggx::from_roughness(1.0, color);
    assert_eq!(rough.alpha, 1.0);
    for &wi in &directions {
        for &wo in &directions[..50] {
            assert!(rough.eval(wi, wo).is_finite() && rough.pdf(wi, wo).is_finite());
        }
        if let Some(s) = rough.sample(wi, uniforms(&mut rng)) {
            assert!(s.weight.is_finite() && s.pdf.is_finite() && s.wo.is_finite());
            assert!(s.weight.max_element() <= 1.0 + 1e-12);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The dielectric.

/// `(index on wi's side, index on the other side)` for glass of index `ior` (normal to outside).
fn sides(wi: DVec4, ior: f64) -> (f64, f64) {
    if wi.w >= 0.0 { (1.0, ior) } else { (ior, 1.0) }
}

#[test]
fn dielectric_branch_probabilities_sum_to_one() {
    let glass = Dielectric { ior: 1.5 };
    let mut rng = Pcg64Mcg::seed_from_u64(70);
    for k in 0..200 {
        let mut wi = upper_direction(&mut rng);
        if k % 2 == 1 {
            wi.w = -wi.w;
        }
        let (eta_i, eta_t) = sides(wi, glass.ior);
        let fresnel = fresnel_dielectric(wi.w.abs(), eta_i, eta_t);
        let reflect = glass.sample(wi, DVec3::ZERO).unwrap();
        let transmit = glass.sample(wi, DVec3::splat(1.0 - 1e-12)).unwrap();
        assert_close("P(reflect)", reflect.pdf, fresnel, 1e-15);
        if fresnel < 1.0 {
            assert!(
                transmit.wo.w * wi.w < 0.0,
                "transmission stays on wi's side"
            );
            assert_close(
                "P(reflect) + P(transmit)",
                reflect.pdf + transmit.pdf,
                1.0,
                1e-15,
            );
        }
        // The branch is chosen with probability F: count over a stratified u.
        let m = 10_000;
        let reflected = (0..m)
            .filter(|j| {
                glass
                    .sample(wi, DVec3::new((*j as f64 + 0.5) / m as f64, 0.5, 0.5))
                    .unwrap()
                    .wo
                    .w
                    * wi.w
                    > 0.0
            })
            .count();
        assert_close(
            "reflected fraction",
            reflected as f64 / m as f64,
            fresnel,
            1.0 / m as f64,
        );
    }
}

#[test]
fn dielectric_total_internal_reflection_inside() {
    let glass = Dielectric { ior: 1.5 };
    let critical = (1.0 / glass.ior).asin();
    let mut rng = Pcg64Mcg::seed_from_u64(71);
    for theta in [critical + 1e-6, 1.0, 1.3, PI / 2.0 - 1e-6] {
        // Inside the glass: wi below the surface.
        let wi = Frame::new(-DVec4::W).to_world(tilted(theta));
        assert!(wi.w < 0.0);
        for _ in 0..100 {
            let s = glass.sample(wi, uniforms(&mut rng)).unwrap();
            assert_eq!((s.pdf, s.weight), (1.0, DVec3::ONE), "theta {theta}");
            assert!((s.wo - DVec4::new(-wi.x, -wi.y, -wi.z, wi.w)).length() < 1e-15);
        }
    }
    // Just inside the critical angle light still escapes.
    let wi = Frame::new(-DVec4::W).to_world(tilted(critical - 1e-3));
    assert!(glass.sample(wi, DVec3::splat(0.999)).unwrap().wo.w > 0.0);
}

#[test]
fn dielectric_refraction_obeys_snell_and_eta_cubed() {
    // Furnace bookkeeping: with radiance 1 outside, radiance inside lossless glass is ior^3
    // (L / eta^3 is invariant in 4D). A path arriving from either side must see exactly its own
    // side's radiance in expectation: sum over branches P * weight * L(wo's side) = L(wi's side).
    let mut rng = Pcg64Mcg::seed_from_u64(72);
    for ior in [1.33, 1.5, 2.42] {
        let glass = Dielectric { ior };
        let radiance = |w: f64| if w > 0.0 { 1.0 } else { ior.powi(3) };
        for k in 0..500 {
            let mut wi = upper_direction(&mut rng);
            if k % 2 == 1 {
                wi.w = -wi.w;
            }
            let (eta_i, eta_t) = sides(wi, ior);
            let r = glass.sample(wi, DVec3::ZERO).unwrap();
            let t = glass.sample(wi, DVec3::splat(1.0 - 1e-12)).unwrap();
            let mut expected = r.pdf * r.weight.x * radiance(r.wo.w);
            if t.wo.w * wi.w < 0.0 {
                expected += t.pdf * t.weight.x * radiance(t.wo.w);
                // Snell's law in 4D: eta_i sin(theta_i) = eta_t sin(theta_t), the tangential
                // part turns around (both directions point away from the surface), unit length.
                let (ti, tt) = (wi.truncate(), t.wo.truncate());
                assert_close("|wo|", t.wo.length(), 1.0, 1e-12);
                assert_close("Snell", eta_i * ti.length(), eta_t * tt.length(), 1e-12);
                assert!(
                    (ti.normalize() + tt.normalize()).length() < 1e-9,
                    "tangential direction"
                );
            }
            assert_close(
                &format!("furnace, ior {ior}"),
                expected,
                radiance(wi.w),
                1e-12 * radiance(wi.w),
            );
        }
    }
}
