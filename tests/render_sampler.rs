//! The Owen-scrambled Sobol sampler (`render::sampler`): unbiased where the independent sampler
//! is (analytic scenes, furnaces, agreement in scenes with fog, glass and rough metal), faster
//! convergence where the integrand is low-dimensional. Sobol is the default, so the
//! thread-count determinism test in `tests/render_physics.rs` covers it. Replicates are
//! pixels: each pixel has its own scramble, so pixels of a scene whose answer is the same
//! everywhere are independent estimates.

mod common;

use common::*;
use hyperslice::Rendered;
use hyperslice::render::driver::Options;
use hyperslice::render::sampler::SamplerKind;

fn with(sampler: SamplerKind) -> Options {
    Options {
        sampler,
        ..Options::default()
    }
}

/// Mean over the pixels of the red channel, its standard error from the pixels' spread, and
/// the mean squared error against `want`.
fn pixel_stats(r: &Rendered, want: f64) -> (f64, f64, f64) {
    let v: Vec<f64> = r
        .frames
        .iter()
        .flat_map(|f| &f.color)
        .map(|c| c.x)
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let mse = v.iter().map(|x| (x - want).powi(2)).sum::<f64>() / n;
    (mean, (var / n).sqrt(), mse)
}

/// The floor point under a spherical light, `L = rho L_e (R / d)^3 = 1`, seen by every pixel
/// through a very narrow field of view.
fn emitter(spp: u32) -> String {
    format!(
        "render {{ size = 16 x 16  spp = {spp}  bounces = 1  epsilon = 1e-6 }}
         camera {{ from = [0, 1, -4, 0] look = rotate(yz, 14.036243deg) fov = 0.02deg }}
         object floor {{ shape = halfspace(normal: [0, 1, 0, 0], offset: 0) material = diffuse(albedo: rgb(0.8)) }}
         object lamp {{ shape = hypersphere(1) |> translate([0, 2, 0, 0]) material = light(intensity: 10) }}"
    )
}

#[test]
fn sobol_is_unbiased_and_less_noisy_under_a_spherical_light() {
    let want = 0.8 * 10.0 / 8.0;
    for (light_sampling, least_gain) in [(true, 4.0), (false, 1.5)] {
        let src = emitter(16);
        let opts = |sampler| Options {
            light_sampling,
            ..with(sampler)
        };
        let random = render_with(&src, opts(SamplerKind::Random));
        let sobol = render_with(&src, opts(SamplerKind::Sobol));
        let (m_r, se_r, mse_r) = pixel_stats(&random, want);
        let (m_s, se_s, mse_s) = pixel_stats(&sobol, want);
        eprintln!(
            "light sampling {light_sampling}: random {m_r:.4} +- {se_r:.4} (MSE {mse_r:.3e}), \
             sobol {m_s:.4} +- {se_s:.4} (MSE {mse_s:.3e}): {:.1}x lower MSE",
            mse_r / mse_s
        );
        assert!(
            (m_r - want).abs() < 4.0 * se_r + 1e-6,
            "random: {m_r} +- {se_r}"
        );
        assert!(
            (m_s - want).abs() < 4.0 * se_s + 1e-6,
            "sobol: {m_s} +- {se_s}"
        );
        assert!(
            mse_s * least_gain < mse_r,
            "sobol MSE {mse_s:e} is not {least_gain}x below random's {mse_r:e}"
        );
    }
}

/// A slab of absorbing fog: each sample is 1 if its free flight crosses the slab, else 0, a
/// one-dimensional step. Stratified samples leave one stratum straddling the step, so the
/// error falls as `1/n` instead of `1/sqrt(n)`.
#[test]
fn sobol_converges_faster_on_a_one_dimensional_integrand() {
    let want = (-2.5f64).exp();
    let mut points = vec![];
    for spp in [1u32, 4, 16, 64, 256] {
        let src = format!(
            "render {{ size = 16 x 16  spp = {spp}  bounces = 4 }}
             camera {{ from = [0, 0, -3, 0] fov = 0.5deg }}
             sky = rgb(1)
             object slab {{ shape = hyperbox([50, 50, 0.5, 50]) material = fog(extinction: 2.5, albedo: rgb(0)) }}"
        );
        let r = render_with(&src, with(SamplerKind::Sobol));
        let (mean, se, mse) = pixel_stats(&r, want);
        assert!(
            (mean - want).abs() < 4.0 * se + 1e-12,
            "{spp} spp: {mean} +- {se}"
        );
        points.push(((spp as f64).ln(), mse.sqrt().ln()));
    }
    let slope = slope(&points);
    assert!((-1.2..=-0.8).contains(&slope), "slope {slope}: {points:?}");
}

/// Paths of 30 bounces use more dimensions than the sequence has (256); the rest come from the
/// PCG stream, and the closed furnace is still exact.
#[test]
fn sobol_closed_furnace_is_exact_past_the_sequence_dimensions() {
    let (rho, le, k) = (0.7f64, 0.3, 30);
    let src = format!(
        "render {{ size = 12 x 9  spp = 3  bounces = {k} }}
         camera {{ from = [0.1, 0.2, -0.3, 0.05] look = rotate(xw, 30deg) fov = 100deg }}
         object walls {{ shape = hypersphere(2) |> onion(0.2) material = diffuse(albedo: rgb({rho}), emission: rgb({le})) }}"
    );
    let r = render_with(
        &src,
        Options {
            roulette_from: u32::MAX,
            ..with(SamplerKind::Sobol)
        },
    );
    let want = le * (1.0 - rho.powi(k + 1)) / (1.0 - rho);
    for c in r.frames.iter().flat_map(|f| &f.color) {
        assert!((c.x - want).abs() / want < 1e-5, "{} vs {want}", c.x);
    }
}

/// Fog, glass and rough metal under a light, with light sampling: the two samplers' means
/// agree within 4 standard errors of their difference (the per-pixel standard errors assume
/// independent samples, which overstates the Sobol render's: the test is conservative).
#[test]
fn sobol_agrees_with_random_in_fog_glass_and_metal() {
    let src = "render { size = 4 x 3  spp = 4000  bounces = 5  seed = 1 }
               camera { from = [0, 0.6, -4, 0] fov = 50deg }
               medium = fog(extinction: 0.25, albedo: rgb(0.9, 0.8, 0.7), anisotropy: 0.4)
               object floor { shape = halfspace(offset: -1) material = diffuse(albedo: rgb(0.7)) }
               object ball { shape = hypersphere(0.5) |> translate([-0.8, -0.5, 0.5, 0]) material = shiny(roughness: 0.5, color: rgb(0.9)) }
               object cube { shape = hyperbox(0.3) |> translate([0.8, -0.6, 0, 0]) material = glass(ior: 1.5) }
               object lamp { shape = hypersphere(0.25) |> translate([0.6, 2.5, 0.5, 0.1]) material = light(intensity: 40) }";
    let random = render_with(src, with(SamplerKind::Random));
    let sobol = render_with(
        &src.replace("seed = 1", "seed = 2"),
        with(SamplerKind::Sobol),
    );
    assert_means_agree("random / sobol", &random, &sobol);
}
