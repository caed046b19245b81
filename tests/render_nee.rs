//! Next-event estimation towards spherical lights (`render::lights` and the integrator's light
//! sampling with multiple importance sampling).
//!
//! - the ball's solid-angle sampler against its pdf (chi-square, as in
//!   `tests/physics_samplers.rs`), and the pdf's normalisation over the cone;
//! - which objects count as spherical lights, and where they are at any `t`;
//! - renders with light sampling on against the closed forms of `docs/physics.md` ("Light
//!   sampling (next-event estimation)") and against renders with it off (BSDF sampling only), in
//!   scenes where the shadow rays meet fog, glass and rough metal: the two estimators must agree
//!   within 4 standard errors of their difference;
//! - the variance reduction, and determinism across thread counts.
//!
//! Every seed is fixed, so a run that passes passes every time.

mod common;

use common::*;
use glam::{DVec3, DVec4};
use hyperslice::Compilation;
use hyperslice::Rendered;
use hyperslice::compile::Frames;
use hyperslice::render::driver::Options;
use hyperslice::render::frame::Build;
use hyperslice::render::lights::{Side, ball_pdf, sample_ball};
use hyperslice::render::march::MarcherKind;
use hyperslice::render::sampling::uniform_s3;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use std::f64::consts::PI;

fn pooled_chi2(observed: &[f64], expected: &[f64]) -> (f64, usize) {
    let mut cells: Vec<(f64, f64)> = vec![];
    for (k, (&e, &o)) in expected.iter().zip(observed).enumerate() {
        assert!(
            e > 0.0 || o == 0.0,
            "{o} samples in cell {k}, where the pdf is 0"
        );
        cells.push((e, o));
    }
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    let split = cells.partition_point(|c| c.0 < 5.0);
    let mut kept = cells.split_off(split);
    let pool = cells.iter().fold((0.0, 0.0), |p, c| (p.0 + c.0, p.1 + c.1));
    if pool.0 > 0.0 {
        let mut pool = pool;
        if pool.0 < 5.0 && !kept.is_empty() {
            let c = kept.remove(0);
            pool = (pool.0 + c.0, pool.1 + c.1);
        }
        kept.push(pool);
    }
    let stat = kept.iter().map(|(e, o)| (o - e) * (o - e) / e).sum();
    (stat, kept.len() - 1)
}

// ---------------------------------------------------------------------------------------------
// The ball sampler.

/// Chi-square comparisons in this file, for the Sidak correction.
const CHI2_TESTS: i32 = 3;
const SIGNIFICANCE: f64 = 0.01;
const CHI2_SAMPLES: usize = 1_000_000;

/// An orthonormal basis `(e1, e2, e3)` of the 3-space orthogonal to the unit `axis`.
fn complement(axis: DVec4) -> [DVec4; 3] {
    let mut basis: Vec<DVec4> = vec![];
    for e in [DVec4::X, DVec4::Y, DVec4::Z, DVec4::W] {
        let mut v = e - axis * axis.dot(e);
        for b in &basis {
            v -= *b * b.dot(v);
        }
        if v.length() > 0.3 {
            basis.push(v.normalize());
        }
        if basis.len() == 3 {
            break;
        }
    }
    [basis[0], basis[1], basis[2]]
}

/// `1 - cos theta` without cancellation near 0.
fn one_minus_cos(theta: f64) -> f64 {
    2.0 * (theta / 2.0).sin().powi(2)
}

/// The density `sample_ball` draws with (`render::lights`): `v = 1 - cos theta` with density
/// `~ sqrt(v)` on `[0, 1 - cos a]`, so `P(theta' < theta) = (v / (1 - cos a))^(3/2)`, and the
/// solid-angle pdf `3 / (8 pi (1 - cos a)^(3/2) sqrt(1 + cos theta))`.
fn cone_cdf(a: f64, theta: f64) -> f64 {
    (one_minus_cos(theta) / one_minus_cos(a)).powf(1.5)
}

fn cone_pdf(a: f64, theta: f64) -> f64 {
    3.0 / (8.0 * PI * one_minus_cos(a).powf(1.5) * (1.0 + theta.cos()).sqrt())
}

/// Cells: theta in `N_THETA` bins of `[0, a]` (expected mass from `cone_cdf`), and the
/// direction of the tangential part on S^2: its `e3` coordinate in `N_Z` bins of `[-1, 1]`
/// (uniform, by Archimedes) times its azimuth in `N_PHI` bins. The cone sampler must make
/// theta and the S^2 direction independent, so the cells' probabilities are products. Each
/// sample's pdf must be the formula's, and `ball_pdf`'s for the same direction (the MIS
/// weight of a BSDF sample that meets the light reads it).
#[test]
fn chi2_ball_solid_angle_sampler() {
    const N_THETA: usize = 24;
    const N_Z: usize = 4;
    const N_PHI: usize = 6;
    let threshold = 1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / CHI2_TESTS as f64);
    let x = DVec4::new(0.3, -0.2, 0.1, 0.5);
    // Narrow, medium and nearly hemispherical cones, along a skewed axis.
    for (k, (dist, radius)) in [(40.0, 0.5), (2.0, 1.0), (1.02, 1.0)]
        .into_iter()
        .enumerate()
    {
        let axis = DVec4::new(0.4, 0.7, -0.2, 0.55).normalize();
        let center = x + axis * dist;
        let a = (radius / dist).asin();
        let tangent = complement(axis);
        let edges: Vec<f64> = (0..=N_THETA)
            .map(|i| cone_cdf(a, a * i as f64 / N_THETA as f64))
            .collect();
        let cells = N_THETA * N_Z * N_PHI;
        let mut expected = vec![0.0; cells];
        for i in 0..N_THETA {
            for j in 0..N_Z * N_PHI {
                expected[i * N_Z * N_PHI + j] =
                    (edges[i + 1] - edges[i]) / (N_Z * N_PHI) as f64 * CHI2_SAMPLES as f64;
            }
        }
        expected.push(0.0); // outside the cone
        let mut observed = vec![0.0; cells + 1];
        let mut rng = Pcg64Mcg::seed_from_u64(17 + k as u64);
        for _ in 0..CHI2_SAMPLES {
            let (wo, pdf, d) = sample_ball(x, center, radius, uniforms(&mut rng)).unwrap();
            assert!((wo.length() - 1.0).abs() < 1e-14, "{}", wo.length());
            assert!((d - dist).abs() < 1e-9);
            let c = wo.dot(axis);
            let t = wo - axis * c;
            let theta = t.length().atan2(c);
            let want = cone_pdf(a, theta);
            assert!((pdf - want).abs() <= 1e-9 * want, "{pdf} against {want}");
            let again = ball_pdf(x, center, radius, wo);
            assert!((pdf - again).abs() <= 1e-12 * pdf, "{pdf} against {again}");
            if theta > a * (1.0 + 1e-9) {
                observed[cells] += 1.0;
                continue;
            }
            let ti = ((theta / a * N_THETA as f64) as usize).min(N_THETA - 1);
            let s2 = DVec3::new(t.dot(tangent[0]), t.dot(tangent[1]), t.dot(tangent[2]));
            let s2 = s2 / s2.length();
            let zi = (((s2.z + 1.0) / 2.0 * N_Z as f64) as usize).min(N_Z - 1);
            let phi = s2.y.atan2(s2.x);
            let pi = (((phi + PI) / (2.0 * PI) * N_PHI as f64) as usize).min(N_PHI - 1);
            observed[ti * N_Z * N_PHI + zi * N_PHI + pi] += 1.0;
        }
        let (stat, dof) = pooled_chi2(&observed, &expected);
        let p = chi2_sf(stat, dof);
        eprintln!(
            "ball d={dist} R={radius} (a = {a:.4}): chi-square {stat:.1}, {dof} dof, p = {p:.3}"
        );
        assert!(
            p > threshold,
            "ball d={dist} R={radius}: p = {p:.3e} < {threshold:.3e}"
        );
    }
}

/// The pdf integrates to 1 over the cone (quadrature at cone sizes from 1e-3 rad to nearly a
/// half-space, and Monte Carlo over all of S^3 counting only directions that meet the ball:
/// the cone is exactly the directions that do); tiny cones, whose `1 - cos a` would cancel,
/// keep their pdf; no sample from inside the ball.
#[test]
fn ball_pdf_integrates_to_one_over_the_cone() {
    let x = DVec4::new(0.1, -0.4, 0.2, 0.3);
    let axis = DVec4::new(0.5, -0.1, 0.3, 0.8).normalize();
    let across = complement(axis)[0];
    for a in [1e-3f64, 0.05, 0.3, 1.0, 1.5, PI / 2.0 - 1e-6] {
        let (dist, radius) = (2.0, 2.0 * a.sin());
        let center = x + axis * dist;
        // The S^2 of directions at angle theta has area 4 pi sin^2 theta.
        let pdf = |t: f64| {
            let wo = axis * t.cos() + across * t.sin();
            ball_pdf(x, center, radius, wo)
        };
        let total = gauss(0.0, a, 64, |t| 4.0 * PI * t.sin().powi(2) * pdf(t));
        assert!((total - 1.0).abs() < 1e-10, "a = {a}: {total}");
    }
    // Tiny cones: near the axis the pdf is `3 / (4 pi a^3)` (with `1 - cos a ~ a^2 / 2`).
    for a in [1e-30, 1e-12, 1e-8] {
        let (dist, radius) = (3.0, 3.0 * a);
        let got = ball_pdf(x, x + axis * dist, radius, axis);
        let want = 3.0 / (4.0 * PI * a * a * a);
        assert!((got / want - 1.0).abs() < 1e-9, "a = {a}: {got} vs {want}");
    }
    // Monte Carlo on S^3: the pdf over exactly the directions that meet the ball integrates to
    // 1, so the cone is the set of directions that hit the ball.
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    for (center, radius) in [
        (DVec4::new(1.0, 1.5, 0.0, -0.5), 1.0),
        (DVec4::splat(1.0), 0.4),
    ] {
        let n = 400_000;
        let (mut sum, mut sq) = (0.0, 0.0);
        for _ in 0..n {
            let w = uniform_s3(uniforms(&mut rng));
            let to = center - x;
            let along = to.dot(w);
            let miss2 = to.length_squared() - along * along;
            let hits = along > 0.0 && miss2 < radius * radius;
            let v = if hits {
                ball_pdf(x, center, radius, w) * 2.0 * PI * PI
            } else {
                0.0
            };
            sum += v;
            sq += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - 1.0).abs() < 4.0 * se, "integral {mean} +- {se}");
    }
    // Inside the ball: no sample, pdf 0.
    assert!(sample_ball(DVec4::ZERO, DVec4::X * 0.5, 1.0, DVec3::splat(0.5)).is_none());
    assert_eq!(ball_pdf(DVec4::ZERO, DVec4::X * 0.5, 1.0, DVec4::X), 0.0);
}

/// Samples stay in the cone and finite at every cone size and every `u`, up to `u` just below
/// 1 (whose `u^(2/3)` the cube root may round past 1): the rim at most, never beyond, and the
/// angle where `u` puts it. Along the `w` axis the local frame is exact, so the angle is
/// measured to its own precision even in a cone of 1e-50 rad.
#[test]
fn ball_samples_stay_in_the_cone() {
    // Below about 1e-54 rad `(1 - cos a)^3` underflows: no sample, and BSDF samples take it all.
    let (x, axis) = (DVec4::ZERO, DVec4::W);
    assert!(sample_ball(x, axis * 1.5, 1.5e-60, DVec3::splat(0.5)).is_none());
    assert_eq!(ball_pdf(x, axis * 1.5, 1.5e-60, axis), 0.0);
    for a in [1e-50f64, 1e-9, 1e-4, 0.09, 0.7, 1.5, PI / 2.0 - 1e-4] {
        let (dist, radius) = (1.5, 1.5 * a.sin());
        let center = x + axis * dist;
        for ux in [0.0, 1e-12, 0.25, 0.5, 0.999999, 1.0 - f64::EPSILON / 2.0] {
            let (wo, pdf, _) = sample_ball(x, center, radius, DVec3::new(ux, 0.3, 0.8)).unwrap();
            assert!(pdf.is_finite() && pdf > 0.0, "a {a} u {ux}: pdf {pdf}");
            let theta = wo.truncate().length().atan2(wo.w);
            assert!(theta <= a * (1.0 + 1e-9), "a {a} u {ux}: theta {theta}");
            // The cdf inverts: the sampled angle is where `u` puts it.
            let back = cone_cdf(a, theta);
            assert!((back - ux).abs() < 1e-9, "a {a} u {ux}: cdf {back}");
        }
    }
    // A direction that rounds past the rim, or points away, takes the rim's pdf: never an
    // infinite or NaN weight.
    let (center, rim) = (axis * 2.0, cone_pdf(PI / 6.0, PI / 6.0));
    for wo in [
        -axis,
        DVec4::X,
        DVec4::new(1e-9, 0.0, 0.0, -1.0).normalize(),
    ] {
        let pdf = ball_pdf(x, center, 1.0, wo);
        assert!(
            (pdf - rim).abs() <= 1e-12 * rim,
            "{wo}: {pdf} against {rim}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Which objects are lights.

fn scene_of(src: &str) -> hyperslice::scene::Scene {
    let c = Compilation::from_source("test.4ds", src);
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
    c.scene.expect("a scene")
}

#[test]
fn spherical_lights_are_recognised_and_placed_per_frame() {
    let scene = scene_of(
        "render { size = 4 x 4 frames = 3 }
         object floor { shape = halfspace(offset: -1) material = diffuse() }
         object lamp { shape = hypersphere(0.4 + 0.2 * t) |> round(0.1) |> translate([1, 0, 0, 0])
             |> rotate(xy, 90deg) |> rotate(zw, 30deg * t) |> scale(2) |> translate([0, 0, t, 1])
             material = light(color: rgb(1, 0.5, 0.25), intensity: 4 + 2 * t) }
         object plain { shape = hypersphere(0.3) |> translate([3, 0, 0, 0]) material = light() }
         object cube { shape = hyperbox(0.3) material = light() }
         object patterned { shape = hypersphere(0.2) |> translate([0, 3, 0, 0])
             material = |p, n| light(intensity: 2 + p.x) }
         object shell { shape = hypersphere(0.5) |> onion(0.1) material = light() }
         object dark { shape = hypersphere(0.2) |> translate([-3, 0, 0, 0]) material = light(intensity: 0) }",
    );
    let frames = Frames::new(&scene);
    for t in [0.0, 0.5, 1.0] {
        let fs = frames.at(t, Build::marcher(MarcherKind::Cells));
        let lights = fs.lights.lights();
        let objects: Vec<u32> = lights.iter().map(|l| l.object).collect();
        assert_eq!(objects, vec![1, 2], "t = {t}");
        let lamp = &lights[0];
        let radius = 2.0 * (0.4 + 0.2 * t + 0.1);
        assert!((lamp.radius - radius).abs() < 1e-12, "{}", lamp.radius);
        // (1, 0, 0, 0) turned by 90deg in xy is (0, 1, 0, 0); the zw turn leaves it; scaled by 2.
        let want = DVec4::new(0.0, 2.0, t, 1.0);
        assert!((lamp.center - want).length() < 1e-12, "{}", lamp.center);
        let want_radiance = DVec3::new(1.0, 0.5, 0.25) * (4.0 + 2.0 * t);
        assert!((lamp.radiance - want_radiance).length() < 1e-5);
        // The distance tape agrees: -R at the centre, 0 on the surface in every direction.
        for (l, &object) in lights.iter().zip(&objects) {
            let tape = &fs.objects[object as usize].distance;
            let mut regs = hyperslice::vm::Regs::<f32, 1>::new(tape);
            let mut at = |p: DVec4| {
                hyperslice::vm::eval_point(
                    tape,
                    &mut regs,
                    p.as_vec4().to_array(),
                    [0.0; 4],
                    t as f32,
                )[0] as f64
            };
            assert!((at(l.center) + l.radius).abs() < 1e-5);
            for dir in [DVec4::X, DVec4::Y, DVec4::Z, DVec4::W, DVec4::splat(-0.5)] {
                assert!(at(l.center + dir * l.radius).abs() < 1e-5, "{dir}");
            }
        }
        // Selection by power: radiance (mean of the channels) times R^3.
        let power = |i: usize| lights[i].radiance.element_sum() / 3.0 * lights[i].radius.powi(3);
        let p0 = power(0) / (power(0) + power(1));
        assert!((fs.lights.probability(0) - p0).abs() < 1e-12);
        assert_eq!(fs.lights.of_object(1), Some(0));
        assert_eq!(fs.lights.of_object(3), None);
    }
}

// ---------------------------------------------------------------------------------------------
// Renders.

fn with_nee(light_sampling: bool) -> Options {
    Options {
        light_sampling,
        ..Options::default()
    }
}

/// Renders `src` with light sampling on and off, with different seeds (independent estimates),
/// and checks that the means agree within 4 standard errors of their difference. Returns the
/// two standard errors (of the green channel).
fn assert_on_off_agree(what: &str, src: &str) -> (f64, f64) {
    let on = render_with(src, with_nee(true));
    let off = render_with(&src.replace("seed = 1", "seed = 2"), with_nee(false));
    assert!(on.stats.shadow_rays > 0, "{what}: no shadow rays");
    assert_eq!(off.stats.shadow_rays, 0);
    let (s1, s2) = assert_means_agree(&format!("{what}, light sampling on / off"), &on, &off);
    let m1 = mean_and_error(&on).0;
    assert!(m1.min_element() > 0.0, "{what}: a channel is black: {m1}");
    (s1.y, s2.y)
}

/// The floor point under a spherical light, `L = rho L_e (R / d)^3`, seen through a very narrow
/// field of view (the answer changes by `-2 s^2 / d^2` at a distance `s` from that point; here
/// `s < 0.003`) with a small marching epsilon (paths leave the floor `4 epsilon` above it).
fn emitter_scene(d: f64, spp: u32) -> String {
    format!(
        "render {{ size = 2 x 2  spp = {spp}  bounces = 1  epsilon = 1e-6 }}
         camera {{ from = [0, 1, -4, 0] look = rotate(yz, 14.036243deg) fov = 0.02deg }}
         object floor {{ shape = halfspace(normal: [0, 1, 0, 0], offset: 0) material = diffuse(albedo: rgb(0.8)) }}
         object lamp {{ shape = hypersphere(1) |> translate([0, {d}, 0, 0]) material = light(intensity: 10) }}"
    )
}

#[test]
fn spherical_emitter_with_and_without_light_sampling() {
    let want = DVec3::splat(0.8 * 10.0 * (1.0f64 / 2.0).powi(3));
    let spp = 20000;
    let on = render_with(&emitter_scene(2.0, spp), with_nee(true));
    let off = render_with(&emitter_scene(2.0, spp), with_nee(false));
    assert_mean("d = 2, light sampling", &on, want);
    assert_mean("d = 2, BSDF sampling", &off, want);
    let (se_on, se_off) = (mean_and_error(&on).1.x, mean_and_error(&off).1.x);
    let ratio = se_off / se_on;
    eprintln!(
        "standard error at {spp} spp: {se_off:.3e} without, {se_on:.3e} with light sampling: \
         {ratio:.1}x smaller, variance {:.0}x smaller",
        ratio * ratio
    );
    assert!(ratio >= 5.0, "only {ratio}x");
}

#[test]
fn spherical_emitter_falls_as_inverse_cube_with_light_sampling() {
    let near = render_with(&emitter_scene(2.0, 2000), with_nee(true));
    let want = 0.8 * 10.0 * (1.0f64 / 2.0).powi(3);
    assert_mean("d = 2", &near, DVec3::splat(want));
    let far = render_with(&emitter_scene(4.0, 2000), with_nee(true));
    assert_mean("d = 4", &far, DVec3::splat(want / 8.0));
    let ((a, sa), (b, sb)) = (mean_and_error(&near), mean_and_error(&far));
    let ratio = a.x / b.x;
    let sigma = ratio * ((sa.x / a.x).powi(2) + (sb.x / b.x).powi(2)).sqrt();
    eprintln!("ratio {ratio} +- {sigma}");
    assert!(
        (ratio - 8.0).abs() < 4.0 * sigma,
        "ratio {ratio} +- {sigma}"
    );
    assert!(
        sigma < 0.01,
        "light sampling should pin the ratio down: {sigma}"
    );
}

#[test]
fn large_close_light_where_both_strategies_count() {
    // R = 1 at d = 1.2: the cone's half-angle is 56 degrees, and the light pdf (0.30) and the
    // cosine pdf (up to 0.24) are alike, so both MIS weights are far from 0 and 1.
    let r = render_with(&emitter_scene(1.2, 4000), with_nee(true));
    assert_mean("d = 1.2", &r, DVec3::splat(8.0 / 1.2f64.powi(3)));
}

#[test]
fn animated_light_is_followed_frame_by_frame() {
    // The light rises from d = 2 to d = 3 over two frames.
    let src = emitter_scene(2.0, 2000)
        .replace("bounces = 1", "bounces = 1  frames = 2")
        .replace("translate([0, 2, 0, 0])", "translate([0, 2 + t, 0, 0])");
    let r = render_with(&src, with_nee(true));
    for (f, d) in [(0, 2.0f64), (1, 3.0)] {
        let one = Rendered {
            frames: vec![r.frames[f].clone()],
            stats: r.stats,
            denoise_time: r.denoise_time,
            elapsed: r.elapsed,
        };
        assert_mean(&format!("frame {f}"), &one, DVec3::splat(8.0 / d.powi(3)));
    }
}

#[test]
fn light_in_fog_agrees_with_bsdf_sampling() {
    // A global scattering medium: light samples at floor and medium vertices, attenuated along
    // their shadow rays; the lamp, just above the field of view, also shines on a rough metal
    // ball.
    let src = "render { size = 4 x 3  spp = 20000  bounces = 5  seed = 1 }
               camera { from = [0, 0.6, -4, 0] fov = 50deg }
               medium = fog(extinction: 0.25, albedo: rgb(0.9, 0.8, 0.7), anisotropy: 0.4)
               object floor { shape = halfspace(offset: -1) material = diffuse(albedo: rgb(0.7)) }
               object ball { shape = hypersphere(0.5) |> translate([-0.8, -0.5, 0.5, 0]) material = shiny(roughness: 0.5, color: rgb(0.9)) }
               object lamp { shape = hypersphere(0.25) |> translate([0.6, 2.5, 0.5, 0.1]) material = light(intensity: 40) }";
    let (on, off) = assert_on_off_agree("global fog", src);
    assert!(
        off > 2.0 * on,
        "light sampling should help here: {on} vs {off}"
    );
}

#[test]
fn light_inside_a_fog_object_agrees_with_bsdf_sampling() {
    // The lamp sits in a ball of fog: vertices inside it sample the lamp along interior
    // shadow rays; from outside, the fog's boundary stops shadow rays (BSDF sampling's part).
    // No lamp is in the field of view (whose top edge rises 0.35 per unit of depth), so the
    // standard errors measure the lighting, not which pixels see a lamp.
    let src = "render { size = 4 x 3  spp = 20000  bounces = 5  seed = 1 }
               camera { from = [0, 0.6, -4, 0] fov = 50deg }
               object floor { shape = halfspace(offset: -1) material = diffuse(albedo: rgb(0.7)) }
               object haze { shape = hypersphere(1.5) |> translate([0.3, 1.8, 0.5, 0]) material = fog(extinction: 0.8, albedo: rgb(0.9), anisotropy: -0.3) }
               object lamp { shape = hypersphere(0.2) |> translate([0.3, 2.6, 0.5, 0]) material = light(intensity: 40) }
               object free { shape = hypersphere(0.2) |> translate([-1.5, 2.9, 0, 0]) material = light(color: rgb(0.4, 0.6, 1), intensity: 30) }";
    assert_on_off_agree("fog object", src);
}

#[test]
fn light_behind_glass_agrees_with_bsdf_sampling() {
    // One lamp inside a glass ball (reached through the glass by BSDF sampling only) and one
    // above a glass pane; a third, free lamp is sampled directly. All are above the field of
    // view; the floor and a rough metal ball catch their light.
    let src = "render { size = 4 x 3  spp = 20000  bounces = 6  seed = 1 }
               camera { from = [0, 0.6, -4, 0] fov = 50deg }
               object floor { shape = halfspace(offset: -1) material = diffuse(albedo: rgb(0.8)) }
               object metal { shape = hypersphere(0.6) |> translate([0.8, -0.4, 0.8, 0]) material = shiny(roughness: 0.4, color: rgb(0.9, 0.7, 0.5)) }
               object globe { shape = hypersphere(0.7) |> translate([-1, 3.2, 0.5, 0]) material = glass(ior: 1.5) }
               object inner { shape = hypersphere(0.3) |> translate([-1, 3.2, 0.5, 0]) material = light(intensity: 60) }
               object pane { shape = hyperbox([1.5, 0.05, 1.5, 1.5]) |> translate([1.2, 2.7, 0.5, 0]) material = glass(ior: 1.4, extinction: 0.3) }
               object above { shape = hypersphere(0.3) |> translate([1.2, 3.3, 0.5, 0]) material = light(intensity: 60) }
               object free { shape = hypersphere(0.15) |> translate([0, 2.8, 1, 0]) material = light(intensity: 100) }";
    assert_on_off_agree("glass", src);
}

#[test]
fn without_spherical_lights_light_sampling_changes_nothing() {
    // A box-shaped light and a patterned sphere are not sampled: the renders are the same bits.
    let src = "render { size = 6 x 5  spp = 8 }
               object floor { shape = halfspace(offset: -1) material = diffuse() }
               object lamp { shape = hyperbox(0.3) |> translate([0, 1, 0, 0]) material = light(intensity: 10) }
               object glow { shape = hypersphere(0.3) |> translate([1, 1, 0, 0]) material = |p, n| light(intensity: 1 + p.y) }";
    let on = render_with(src, with_nee(true));
    let off = render_with(src, with_nee(false));
    assert_eq!(on.frames, off.frames);
    assert_eq!(on.stats.shadow_rays, 0);
}

#[test]
fn light_sampling_is_bit_identical_whatever_the_thread_count() {
    let src = "render { size = 40 x 36  spp = 4  frames = 2 }
               camera { from = [0, 0.5, -4, 0] to = [0, 0.5, -4, 0.5] }
               sky = rgb(0.2)
               medium = fog(extinction: 0.05, albedo: 0.9)
               object ball { shape = hypersphere(1) material = glass(ior: 1.5, extinction: 0.3) }
               object metal { shape = hypersphere(0.5) |> translate([-1.5, -0.5, 0, 0]) material = shiny(roughness: 0.3) }
               object floor { shape = halfspace(offset: -1) material = diffuse() }
               object lamp { shape = hypersphere(0.5) |> translate([1, 2 - t, 0, 0]) material = light(intensity: 20) }
               object small { shape = hypersphere(0.1) |> translate([-1, 1, 0.5, 0]) material = light(intensity: 80) }";
    let threads = |n| {
        render_with(
            src,
            Options {
                threads: Some(n),
                ..Options::default()
            },
        )
    };
    let (one, two) = (threads(1), threads(2));
    assert!(one.stats.shadow_rays > 0);
    assert_eq!(one.frames, two.frames);
    assert_eq!(one.stats, two.stats);
}

#[test]
fn shadow_rays_marching_without_their_light_still_meet_what_is_in_the_way() {
    // Where a frame marches its whole tape, a shadow ray marches the scene without its light
    // (`FrameScene::unlit`) up to the light's ball, and sees the light if it gets there. A
    // shelf under the lamp (which is above the field of view) shades the floor under it,
    // and must stay in the way: without it the floor there would get 0.8 * 10 * (0.5 / 2)^3,
    // which is more than the rest of the picture's light. A second lamp above the first is
    // partly hidden by it (the first must stay in the second's unlit tape), and thin fog
    // attenuates every shadow ray up to where it enters a ball. The shelf is two slabs
    // blended together, which no ray meets exactly; made of one box, the whole scene is a
    // few exact pieces, which every ray meets once (`Escape::pieces`): shadow rays then see
    // the light where it is the first thing they meet, and there are no unlit tapes.
    let src = "render { size = 4 x 3  spp = 10000  bounces = 3  seed = 1 }
               camera { from = [0, -0.5, -3, 0] look = rotate(yz, 8deg) fov = 50deg }
               medium = fog(extinction: 0.2, albedo: rgb(0.5))
               object floor { shape = halfspace(offset: -1) material = diffuse(albedo: rgb(0.8)) }
               object shelf { shape = SHELF material = diffuse(albedo: rgb(0.5)) }
               object lamp { shape = hypersphere(0.5) |> translate([0, 1, 0.5, 0]) material = light(intensity: 10) }
               object high { shape = hypersphere(0.3) |> translate([0, 2.2, 0.5, 0]) material = light(intensity: 60) }";
    let blended = "union(hyperbox([0.6, 0.025, 0.6, 0.6]) |> translate([0, -0.025, 0.5, 0]), \
                   hyperbox([0.6, 0.025, 0.6, 0.6]) |> translate([0, 0.025, 0.5, 0]), smooth: 0.01)";
    let one_box = "hyperbox([0.6, 0.05, 0.6, 0.6]) |> translate([0, 0, 0.5, 0])";
    for (shelf, unlit) in [(blended, 2), (one_box, 0)] {
        let src = src.replace("SHELF", shelf);
        let frames = Frames::new(&scene_of(&src));
        for (marcher, tapes) in [
            (MarcherKind::Whole, unlit),
            (MarcherKind::Cells, 0),
            (MarcherKind::Plain, 0),
        ] {
            let fs = frames.at(0.0, Build::marcher(marcher));
            assert_eq!(fs.unlit.len(), tapes, "{marcher:?}, {shelf}");
            let exact = fs.escape.pieces(false).is_some();
            assert_eq!(
                exact,
                unlit == 0 && marcher != MarcherKind::Plain,
                "{marcher:?}"
            );
        }
        // Each light's unlit tape leaves that light out and keeps the other.
        let fs = frames.at(0.0, Build::marcher(MarcherKind::Whole));
        let lights = fs.lights.lights();
        for (k, tape) in fs.unlit.iter().enumerate() {
            for (j, l) in lights.iter().enumerate() {
                let mut regs = hyperslice::vm::Regs::<f32, 1>::new(tape);
                let at = l.center.as_vec4().to_array();
                let d = hyperslice::vm::eval_point(tape, &mut regs, at, [0.0; 4], 0.0)[0] as f64;
                match j == k {
                    true => assert!(d > l.radius, "light {k}'s own centre on its tape: {d}"),
                    false => assert!((d + l.radius).abs() < 1e-5, "light {j} on light {k}'s: {d}"),
                }
            }
        }
        let on = render_with(
            &src,
            Options {
                marcher: MarcherKind::Whole,
                ..with_nee(true)
            },
        );
        let off = render_with(
            &src.replace("seed = 1", "seed = 2"),
            Options {
                marcher: MarcherKind::Plain,
                ..with_nee(false)
            },
        );
        assert!(on.stats.shadow_rays > 0);
        assert_means_agree("shadow rays, light sampling on / off", &on, &off);
    }
}

#[test]
fn shadow_rays_of_exact_frames_stop_where_they_enter_their_light() {
    // Where a frame is a few exact pieces, a shadow ray meets the pieces but its light's own
    // ball (`ShadowCull`) only as far as it enters the ball, and sees the light if it meets
    // nothing before. A lamp sunk halfway into the floor lights a ceiling: the ceiling's rays
    // that went on past their entry would meet the floor inside the ball and leave it dark.
    let src = "render { size = 4 x 3  spp = 4000  bounces = 2  seed = 1 }
               camera { from = [0, 0.5, -2, 0] look = rotate(yz, -40deg) fov = 60deg }
               object floor { shape = halfspace(offset: 0) material = diffuse(albedo: rgb(0.5)) }
               object ceiling { shape = halfspace(normal: [0, -1, 0, 0], offset: -1.5)
                                material = diffuse(albedo: rgb(0.8)) }
               object lamp { shape = hypersphere(0.6) material = light(intensity: 5) }";
    let frames = Frames::new(&scene_of(src));
    let fs = frames.at(0.0, Build::marcher(MarcherKind::Auto));
    assert!(
        fs.escape.pieces(false).is_some(),
        "not a frame of exact pieces"
    );
    assert_eq!(fs.shadow_culls.len(), 1);
    // The ceiling's free region holds the lamp, the floor's does not: the floor stays.
    assert_eq!(fs.shadow_culls[0].pieces.len(), 1);
    let on = render_with(src, with_nee(true));
    let off = render_with(
        &src.replace("seed = 1", "seed = 2"),
        Options {
            marcher: MarcherKind::Plain,
            ..with_nee(false)
        },
    );
    assert!(on.stats.shadow_rays > 10_000, "{}", on.stats.shadow_rays);
    assert_means_agree("a sunk lamp, light sampling on / off", &on, &off);
}

#[test]
fn lights_lie_outside_or_inside_only_objects_they_clear() {
    // Light sampling marches no shadow ray from inside an object whose surface the light lies
    // wholly outside, nor from outside one it lies wholly inside (`Lights::side`): the ray
    // would meet that surface first. A lamp inside the haze, one across its surface and one
    // outside it; an air pocket, which stops no shadow ray, and each light's own object are
    // neither.
    let src = "render { size = 4 x 3  spp = 1 }
               object haze { shape = hypersphere(1.5) |> translate([0.3, 1.8, 0.5, 0]) material = fog(extinction: 0.8, albedo: rgb(0.9)) }
               object inner { shape = hypersphere(0.2) |> translate([0.3, 2.6, 0.5, 0]) material = light(intensity: 40) }
               object edge { shape = hypersphere(0.2) |> translate([0.3, 3.25, 0.5, 0]) material = light(intensity: 40) }
               object free { shape = hypersphere(0.2) |> translate([-1.5, 2.9, 0, 0]) material = light(intensity: 40) }
               object pocket { shape = hypersphere(0.5) |> translate([-1.5, 2.9, 0, 0]) material = air }";
    let fs = Frames::new(&scene_of(src)).at(0.0, Build::marcher(MarcherKind::Auto));
    let sides = |light: usize| [0, 1, 2, 3, 4].map(|o| fs.lights.side(light, o));
    assert_eq!(fs.lights.lights().len(), 3);
    // Objects: haze, inner, edge, free, pocket.
    let (o, i, a) = (Side::Outside, Side::Inside, Side::Across);
    assert_eq!(sides(0), [i, a, o, o, a], "inner");
    assert_eq!(sides(1), [a, o, a, o, a], "edge");
    assert_eq!(sides(2), [o, o, o, a, a], "free");
    assert_eq!(fs.lights.enclosing(0), [0]);
    assert!(fs.lights.enclosing(1).is_empty() && fs.lights.enclosing(2).is_empty());
    // That the shadow rays skipped would have been occluded is what
    // `light_inside_a_fog_object_agrees_with_bsdf_sampling` (from inside an object the light
    // is outside of) and `light_behind_glass_agrees_with_bsdf_sampling` (from outside an
    // object the light is inside) check: with every light outside, or inside, every other
    // object, they fail.
}

/// Light directions are unit vectors to within 1e-14 without being normalised: from every
/// side of the ball (both branches of the Householder frame, axes at +-e4 among them), for
/// cones from nearly a hemisphere down to 1e-12 rad.
#[test]
fn light_directions_are_unit_vectors() {
    use rand::Rng;
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let fixed = [DVec4::W, -DVec4::W, DVec4::X, -DVec4::Y];
    for k in 0..20_000 {
        let axis = match fixed.get(k) {
            Some(a) => *a,
            None => {
                DVec4::from_array(std::array::from_fn(|_| rng.random_range(-1.0..1.0))).normalize()
            }
        };
        let x = DVec4::from_array(std::array::from_fn(|_| rng.random_range(-3.0..3.0)));
        let dist = 10f64.powf(rng.random_range(-1.0..3.0));
        let radius = dist * 10f64.powf(rng.random_range(-12.0..-0.0001));
        let Some((wo, _, _)) = sample_ball(x, x + axis * dist, radius, uniforms(&mut rng)) else {
            panic!("no sample from {x} of a ball at {dist} of radius {radius}");
        };
        let off = (wo.length() - 1.0).abs();
        assert!(
            off < 1e-14,
            "length off by {off} along {axis}, radius {radius}"
        );
    }
}
