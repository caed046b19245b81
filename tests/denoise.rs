//! Denoising filters on synthetic films with a known truth: two planes meeting at a crease, a
//! floating sphere, a sky, Gaussian or skewed Monte Carlo noise with a known standard error.

use glam::{DVec3, DVec4};
use hyperslice::denoise::{AtrousOptions, Temporal, denoise, median::medians};
use hyperslice::film::Film;
use hyperslice::scene::Denoise;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const SKY: u8 = 0;
const PLANE_A: u8 = 1;
const PLANE_B: u8 = 2;
const SPHERE: u8 = 3;

/// A noise-free film plus the region of every pixel.
struct Truth {
    film: Film,
    region: Vec<u8>,
}

/// 96x64: a sky in the top 8 rows (missed rays), plane A (left half, facing the camera),
/// plane B (right half, turned 45 degrees, meeting A at a crease: a normal edge with continuous
/// positions) and a sphere floating in front of A (a position and normal edge), evenly lit or,
/// with `shaded`, lit from the upper left (a smooth but steep gradient towards its silhouette).
fn scene(shaded: bool) -> Truth {
    let (w, h) = (96, 64);
    let f = 0.02;
    let mut film = Film::new(w, h);
    let mut region = vec![SKY; w * h];
    let light = DVec4::new(-0.5, -0.5, -1.0, 0.0).normalize();
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let (xf, yf) = (x as f64 * f, y as f64 * f);
            if y < 8 {
                film.color[p] = DVec3::new(0.2, 0.3, 0.5);
                continue;
            }
            let (dx, dy) = (x as f64 - 30.0, y as f64 - 38.0);
            let r = 14.0;
            let (albedo, irradiance, normal, pos, reg);
            if dx * dx + dy * dy < r * r {
                let nz = (1.0 - (dx * dx + dy * dy) / (r * r)).sqrt();
                normal = DVec4::new(dx / r, dy / r, -nz, 0.0);
                pos = DVec4::new(xf, yf, 3.0 - nz * r * f, 0.25);
                albedo = DVec3::splat(0.9);
                irradiance = if shaded {
                    0.2 + 0.8 * normal.dot(light).max(0.0)
                } else {
                    0.6
                };
                reg = SPHERE;
            } else if x < 48 {
                normal = DVec4::new(0.0, 0.0, -1.0, 0.0);
                pos = DVec4::new(xf, yf, 5.0, 0.25);
                albedo = DVec3::new(0.8, 0.6, 0.4);
                irradiance = 1.0;
                reg = PLANE_A;
            } else {
                normal = DVec4::new(-1.0, 0.0, -1.0, 0.0).normalize();
                pos = DVec4::new(xf, yf, 5.0 + (x as f64 - 48.0) * f, 0.25);
                albedo = DVec3::new(0.3, 0.5, 0.7);
                irradiance = 0.5;
                reg = PLANE_B;
            }
            film.color[p] = albedo * irradiance;
            film.albedo[p] = albedo;
            film.normal[p] = normal;
            film.position[p] = pos;
            film.depth[p] = pos.z;
            region[p] = reg;
        }
    }
    Truth { film, region }
}

fn gaussian(rng: &mut Pcg64) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Gaussian noise of standard deviation `sigma` per channel on every hit pixel (the sky is
/// noise-free), with the standard error set to `sigma`.
fn noisy(truth: &Film, region: &[u8], sigma: f64, rng: &mut Pcg64) -> Film {
    let mut f = truth.clone();
    for ((c, s), r) in f.color.iter_mut().zip(&mut f.std_error).zip(region) {
        if *r == SKY {
            continue;
        }
        *c += sigma * DVec3::new(gaussian(rng), gaussian(rng), gaussian(rng));
        *s = DVec3::splat(sigma);
    }
    f
}

fn rmse(a: &[DVec3], b: &[DVec3], mask: impl Fn(usize) -> bool) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for p in 0..a.len() {
        if mask(p) {
            s += (a[p] - b[p]).length_squared() / 3.0;
            n += 1;
        }
    }
    assert!(n > 0, "empty mask");
    (s / n as f64).sqrt()
}

fn mean_error(a: &[DVec3], b: &[DVec3], mask: impl Fn(usize) -> bool) -> DVec3 {
    let (mut s, mut n) = (DVec3::ZERO, 0usize);
    for p in 0..a.len() {
        if mask(p) {
            s += a[p] - b[p];
            n += 1;
        }
    }
    assert!(n > 0, "empty mask");
    s / n as f64
}

/// Distance (Chebyshev, up to `max`) from pixel `p` to the nearest pixel of another region.
fn edge_distance(region: &[u8], w: usize, h: usize, p: usize, max: usize) -> usize {
    let (x, y) = ((p % w) as isize, (p / w) as isize);
    for d in 1..=max as isize {
        for qy in y - d..=y + d {
            for qx in x - d..=x + d {
                if qx < 0 || qy < 0 || qx >= w as isize || qy >= h as isize {
                    continue;
                }
                if region[qy as usize * w + qx as usize] != region[p] {
                    return d as usize - 1;
                }
            }
        }
    }
    max
}

fn no_guides() -> AtrousOptions {
    AtrousOptions {
        sigma_color: f64::INFINITY,
        sigma_normal: f64::INFINITY,
        sigma_position: f64::INFINITY,
        sigma_albedo: f64::INFINITY,
        ..AtrousOptions::default()
    }
}

#[test]
fn atrous_reduces_noise_and_keeps_edges() {
    let Truth {
        film: truth,
        region,
    } = scene(false);
    let (w, h) = (truth.width, truth.height);
    let mut rng = Pcg64::seed_from_u64(1);
    let sigma = 0.08;
    let noisy_film = noisy(&truth, &region, sigma, &mut rng);
    let mut frames = vec![noisy_film.clone()];
    denoise(&mut frames, Denoise::Atrous, &AtrousOptions::default());
    let out = &frames[0].color;

    let flat = |p: usize| {
        (region[p] == PLANE_A || region[p] == PLANE_B) && edge_distance(&region, w, h, p, 3) >= 3
    };
    let before = rmse(&noisy_film.color, &truth.color, flat);
    let after = rmse(out, &truth.color, flat);
    println!(
        "flat regions: RMSE {before:.4} -> {after:.4} ({:.1}x)",
        before / after
    );
    assert!(after * 3.0 < before, "a-trous: RMSE {before} -> {after}");

    let sphere = |p: usize| region[p] == SPHERE;
    let (sb, sa) = (
        rmse(&noisy_film.color, &truth.color, sphere),
        rmse(out, &truth.color, sphere),
    );
    println!(
        "sphere (curved normals, even light): RMSE {sb:.4} -> {sa:.4} ({:.1}x)",
        sb / sa
    );
    assert!(sa * 3.0 < sb);

    // The sky is noise-free and must not change, nor take anything from the hits.
    let sky = |p: usize| region[p] == SKY;
    assert!(rmse(out, &truth.color, sky) < 1e-9);

    // Edges: the pixels on either side of every region boundary (crease: normal only; sphere
    // silhouette: position and normal; sky: missed rays) stay close to the truth, without the
    // systematic error that bleeding from the other side produces.
    let check_edges = |out: &[DVec3], label: &str| -> (f64, f64) {
        let mut worst_bias = 0.0f64;
        let mut worst_rmse = 0.0f64;
        for r in [PLANE_A, PLANE_B, SPHERE] {
            let edge = |p: usize| region[p] == r && edge_distance(&region, w, h, p, 1) == 0;
            let bias = mean_error(out, &truth.color, edge).abs().max_element();
            let e = rmse(out, &truth.color, edge);
            println!("{label}: region {r} edge pixels: |bias| {bias:.4}, RMSE {e:.4}");
            worst_bias = worst_bias.max(bias);
            worst_rmse = worst_rmse.max(e);
        }
        (worst_bias, worst_rmse)
    };
    let (bias, e) = check_edges(out, "a-trous");
    assert!(bias < 0.02, "edge bias {bias}");
    assert!(e < 0.6 * sigma, "edge RMSE {e}");

    // The edge check has teeth: the same kernel without its edge-stopping guides bleeds.
    let mut blurred = vec![noisy_film];
    denoise(&mut blurred, Denoise::Atrous, &no_guides());
    let (bias, _) = check_edges(&blurred[0].color, "plain B3 blur");
    assert!(
        bias > 0.05,
        "an unguided blur should bleed across edges: {bias}"
    );
}

#[test]
fn shaded_sphere_keeps_its_gradient() {
    // Real shading varies across a curved surface; near the silhouette the kernel is one-sided
    // and averages the steep gradient there, a small bias that the normal guide limits.
    let Truth {
        film: truth,
        region,
    } = scene(true);
    let (w, h) = (truth.width, truth.height);
    let mut rng = Pcg64::seed_from_u64(1);
    let noisy_film = noisy(&truth, &region, 0.08, &mut rng);
    let mut frames = vec![noisy_film.clone()];
    denoise(&mut frames, Denoise::Atrous, &AtrousOptions::default());
    let out = &frames[0].color;
    let sphere = |p: usize| region[p] == SPHERE;
    let silhouette = |p: usize| region[p] == SPHERE && edge_distance(&region, w, h, p, 1) == 0;
    let (sb, sa) = (
        rmse(&noisy_film.color, &truth.color, sphere),
        rmse(out, &truth.color, sphere),
    );
    let bias = mean_error(out, &truth.color, silhouette)
        .abs()
        .max_element();
    println!(
        "shaded sphere: RMSE {sb:.4} -> {sa:.4} ({:.1}x), silhouette bias {bias:.4}",
        sb / sa
    );
    assert!(sa * 2.5 < sb);
    assert!(bias < 0.035);
}

#[test]
fn textures_stay_sharp_by_demodulation() {
    // A checkerboard albedo under smooth light: the colour edges are albedo edges only.
    let (w, h) = (64, 64);
    let mut truth = Film::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let a = if (x / 2 + y / 2) % 2 == 0 { 0.9 } else { 0.1 };
            truth.albedo[p] = DVec3::splat(a);
            truth.color[p] = DVec3::splat(a * (0.5 + x as f64 / 128.0));
            truth.normal[p] = DVec4::new(0.0, 0.0, -1.0, 0.0);
            truth.position[p] = DVec4::new(x as f64 * 0.01, y as f64 * 0.01, 4.0, 0.0);
        }
    }
    let mut rng = Pcg64::seed_from_u64(7);
    let mut f = truth.clone();
    for p in 0..w * h {
        // Noise proportional to the albedo, as a Monte Carlo estimate has.
        let s = 0.2 * truth.albedo[p].x;
        f.color[p] += s * DVec3::new(gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng));
        f.std_error[p] = DVec3::splat(s);
    }
    let before = rmse(&f.color, &truth.color, |_| true);
    let mut frames = vec![f];
    denoise(&mut frames, Denoise::Atrous, &AtrousOptions::default());
    let after = rmse(&frames[0].color, &truth.color, |_| true);
    let bias = mean_error(&frames[0].color, &truth.color, |p| truth.albedo[p].x > 0.5);
    println!(
        "2x2 checker texture: RMSE {before:.4} -> {after:.4}, bias on bright squares {:.4}",
        bias.x
    );
    assert!(after * 3.0 < before);
    assert!(bias.abs().max_element() < 0.01);
}

/// A flat lit plane whose every pixel averages `spp` samples that are 0 with probability 0.9
/// and `10 * albedo` otherwise (mean `albedo`): skewed Monte Carlo noise.
fn skewed_frames(n_frames: usize, spp: u32, rng: &mut Pcg64) -> (Vec<Film>, DVec3) {
    let (w, h) = (128, 128);
    let albedo = DVec3::new(0.5, 0.5, 0.5);
    let mut frames = Vec::new();
    for _ in 0..n_frames {
        let mut f = Film::new(w, h);
        for p in 0..w * h {
            let hits = (0..spp).filter(|_| rng.random::<f64>() < 0.1).count() as f64;
            let n = spp as f64;
            let v = 10.0 * albedo;
            let mean = v * hits / n;
            let var = (v * v * hits / n - mean * mean).max(DVec3::ZERO);
            f.color[p] = mean;
            f.std_error[p] = (var / (n - 1.0)).map(f64::sqrt);
            f.albedo[p] = albedo;
            f.normal[p] = DVec4::new(0.0, 0.0, -1.0, 0.0);
            f.position[p] = DVec4::new((p % w) as f64 * 0.01, (p / w) as f64 * 0.01, 4.0, 0.0);
        }
        frames.push(f);
    }
    (frames, albedo)
}

fn mean_luminance(frames: &[Film]) -> f64 {
    let n: usize = frames.iter().map(|f| f.color.len()).sum();
    frames
        .iter()
        .flat_map(|f| &f.color)
        .map(|c| c.element_sum() / 3.0)
        .sum::<f64>()
        / n as f64
}

#[test]
fn atrous_keeps_mean_luminance_where_median_darkens() {
    let mut rng = Pcg64::seed_from_u64(2);
    let (frames, truth) = skewed_frames(3, 64, &mut rng);
    let truth = truth.x;
    let noisy_mean = mean_luminance(&frames);
    // RMSE of the red channel against the flat truth, over every pixel of every frame.
    let red_rmse = |frames: &[Film]| {
        let n: usize = frames.iter().map(|f| f.color.len()).sum();
        (frames
            .iter()
            .flat_map(|f| &f.color)
            .map(|c| (c.x - truth).powi(2))
            .sum::<f64>()
            / n as f64)
            .sqrt()
    };
    let noisy_rmse = red_rmse(&frames);

    let mut a = frames.clone();
    denoise(&mut a, Denoise::Atrous, &AtrousOptions::default());
    let a_mean = mean_luminance(&a);
    let a_rmse = red_rmse(&a);

    let mut m = frames.clone();
    denoise(&mut m, Denoise::Median, &AtrousOptions::default());
    let m_mean = mean_luminance(&m);

    let rel = |x: f64| x / truth - 1.0;
    println!(
        "skewed noise (64 spp, 10% of samples at 10x the mean): mean luminance relative to truth: \
         noisy {:+.4}, a-trous {:+.4}, median {:+.4}; RMSE noisy {noisy_rmse:.4} -> a-trous {a_rmse:.4}",
        rel(noisy_mean),
        rel(a_mean),
        rel(m_mean)
    );
    assert!(
        rel(noisy_mean).abs() < 0.005,
        "the input itself is unbiased"
    );
    assert!(
        rel(a_mean).abs() < 0.01,
        "a-trous mean bias {}",
        rel(a_mean)
    );
    // The flux form keeps the image's sum: the filtered mean is the noisy one.
    assert!((a_mean / noisy_mean - 1.0).abs() < 1e-9);
    assert!(
        rel(m_mean) < -0.01,
        "the median is biased dark on skewed noise: {}",
        rel(m_mean)
    );
    assert!(
        a_rmse * 3.0 < noisy_rmse,
        "a-trous must still denoise: {noisy_rmse} -> {a_rmse}"
    );
}

#[test]
fn bias_at_low_sample_counts() {
    // With 8 samples per pixel, 43% of the pixels caught no light: the plain normalised
    // a-trous update loses brightness there; the default flux form does not.
    let mut rng = Pcg64::seed_from_u64(9);
    let (frames, truth) = skewed_frames(3, 8, &mut rng);
    let noisy_mean = mean_luminance(&frames);
    let run = |filter, conserve| {
        let mut f = frames.clone();
        denoise(
            &mut f,
            filter,
            &AtrousOptions {
                conserve,
                ..AtrousOptions::default()
            },
        );
        mean_luminance(&f) / noisy_mean - 1.0
    };
    let (flux, plain, median) = (
        run(Denoise::Atrous, true),
        run(Denoise::Atrous, false),
        run(Denoise::Median, true),
    );
    println!(
        "8 spp skewed noise, mean relative to the noisy mean (noisy itself {:+.4} off the truth): \
         a-trous flux {flux:+.4}, a-trous normalised {plain:+.4}, median {median:+.4}",
        noisy_mean / truth.x - 1.0
    );
    assert!(flux.abs() < 1e-9);
    assert!(
        plain < -0.01,
        "documents the normalised update's dark bias: {plain}"
    );
    assert!(median < -0.05);
}

#[test]
fn median_removes_a_firefly() {
    for n_frames in [1, 3] {
        let mut rng = Pcg64::seed_from_u64(3);
        let mut frames = Vec::new();
        for _ in 0..n_frames {
            let mut f = Film::new(32, 32);
            for p in 0..32 * 32 {
                f.color[p] = DVec3::splat(0.5 + 0.05 * gaussian(&mut rng));
            }
            frames.push(f);
        }
        let k = n_frames / 2;
        let p = 16 * 32 + 16;
        frames[k].color[p] = DVec3::new(1000.0, 500.0, 2000.0);
        // The median as a detector: the firefly is far above its neighbourhood's median.
        let med = medians(&frames);
        let m = med[k].as_ref().unwrap()[p];
        assert!((m - DVec3::splat(0.5)).abs().max_element() < 0.1);
        denoise(&mut frames, Denoise::Median, &AtrousOptions::default());
        let c = frames[k].color[p];
        println!("{n_frames} frame(s): firefly 1000 -> {c:?}");
        assert!(
            (c - DVec3::splat(0.5)).abs().max_element() < 0.1,
            "firefly left: {c:?}"
        );
        for f in &frames {
            assert!(
                f.color.iter().all(|c| c.max_element() < 1.0),
                "firefly spread"
            );
        }
    }
}

#[test]
fn median_erodes_a_thin_line() {
    // Documents the second flaw: a one-pixel line is a minority of every window and vanishes.
    let mut f = Film::new(16, 16);
    for y in 0..16 {
        f.color[y * 16 + 8] = DVec3::ONE;
    }
    let mut frames = vec![f];
    denoise(&mut frames, Denoise::Median, &AtrousOptions::default());
    assert!(frames[0].color.iter().all(|c| *c == DVec3::ZERO));
}

/// Three frames: a static background plane (z = 5) and a bright card (z = 3, same normal and
/// albedo) moving 30 pixels per frame.
fn moving_card(rng: &mut Pcg64, sigma: f64) -> (Vec<Film>, Vec<Vec<DVec3>>, [usize; 3]) {
    let (w, h) = (96, 48);
    let card_x = [12usize, 42, 72];
    let (bg, card) = (DVec3::splat(0.3), DVec3::new(3.0, 2.5, 2.0));
    let mut frames = Vec::new();
    let mut truths = Vec::new();
    for (k, &cx) in card_x.iter().enumerate() {
        let mut f = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                let on_card = (cx..cx + 12).contains(&x) && (18..30).contains(&y);
                let z = if on_card { 3.0 } else { 5.0 };
                f.color[p] = if on_card { card } else { bg };
                f.albedo[p] = DVec3::splat(0.5);
                f.normal[p] = DVec4::new(0.0, 0.0, -1.0, 0.0);
                f.position[p] =
                    DVec4::new(x as f64 * 0.02 * z / 5.0, y as f64 * 0.02 * z / 5.0, z, 0.1);
                let _ = k;
            }
        }
        truths.push(f.color.clone());
        for p in 0..w * h {
            f.color[p] += sigma * DVec3::new(gaussian(rng), gaussian(rng), gaussian(rng));
            f.std_error[p] = DVec3::splat(sigma);
        }
        frames.push(f);
    }
    (frames, truths, card_x)
}

#[test]
fn spatio_temporal_atrous_does_not_ghost_but_helps_static_regions() {
    let mut rng = Pcg64::seed_from_u64(4);
    let sigma = 0.15;
    let (frames, truths, card_x) = moving_card(&mut rng, sigma);
    let w = frames[0].width;
    // Frame 1's background where the card is in frames 0 and 2.
    let ghost = |p: usize| {
        let (x, y) = (p % w, p / w);
        (18..30).contains(&y)
            && [card_x[0], card_x[2]]
                .iter()
                .any(|&cx| (cx..cx + 12).contains(&x))
    };
    // Background far (> 16 px) from the card in every frame.
    let stat = |p: usize| {
        let y = p / w;
        !(2..46).contains(&y)
    };

    let mut st = frames.clone();
    denoise(&mut st, Denoise::Atrous, &AtrousOptions::default());
    let ghost_bias = mean_error(&st[1].color, &truths[1], ghost).max_element();
    let ghost_rmse = rmse(&st[1].color, &truths[1], ghost);
    println!(
        "frame 1 where the card was in frames 0/2: bias {ghost_bias:+.4}, RMSE {ghost_rmse:.4} (noise {sigma})"
    );
    assert!(ghost_bias.abs() < 0.02, "ghost: bias {ghost_bias}");
    assert!(ghost_rmse < 0.3 * sigma, "ghost: RMSE {ghost_rmse}");

    // The static background gains from the neighbouring frames.
    let mut single = vec![frames[1].clone()];
    denoise(&mut single, Denoise::Atrous, &AtrousOptions::default());
    let noisy = rmse(&frames[1].color, &truths[1], stat);
    let alone = rmse(&single[0].color, &truths[1], stat);
    let together = rmse(&st[1].color, &truths[1], stat);
    let mut first = frames.clone();
    let first_opts = AtrousOptions {
        temporal: Temporal::FirstPass,
        ..AtrousOptions::default()
    };
    denoise(&mut first, Denoise::Atrous, &first_opts);
    let first_only = rmse(&first[1].color, &truths[1], stat);
    println!(
        "static background RMSE: noisy {noisy:.4}, single frame {alone:.4}, \
         3 frames (temporal on all passes) {together:.4}, (first pass only) {first_only:.4}"
    );
    assert!(
        together < 0.85 * alone,
        "temporal taps should help: {alone} -> {together}"
    );
    assert!(first_only < alone);

    // Teeth: without the position and colour guides the card leaves a ghost.
    let mut bad = frames.clone();
    let opts = AtrousOptions {
        sigma_position: f64::INFINITY,
        sigma_color: f64::INFINITY,
        ..AtrousOptions::default()
    };
    denoise(&mut bad, Denoise::Atrous, &opts);
    let bad_bias = mean_error(&bad[1].color, &truths[1], ghost).max_element();
    println!("without position/colour guides: ghost bias {bad_bias:+.4}");
    assert!(bad_bias > 0.05);
}

#[test]
fn one_sample_films_use_a_spatial_noise_estimate() {
    // A one-sample render has no standard error; the filter must still denoise it.
    let Truth {
        film: truth,
        region,
    } = scene(false);
    let mut rng = Pcg64::seed_from_u64(5);
    let mut f = noisy(&truth, &region, 0.08, &mut rng);
    f.std_error.iter_mut().for_each(|s| *s = DVec3::ZERO);
    let (w, h) = (f.width, f.height);
    let flat = |p: usize| {
        (region[p] == PLANE_A || region[p] == PLANE_B) && edge_distance(&region, w, h, p, 3) >= 3
    };
    let before = rmse(&f.color, &truth.color, flat);
    let mut frames = vec![f];
    denoise(&mut frames, Denoise::Atrous, &AtrousOptions::default());
    let after = rmse(&frames[0].color, &truth.color, flat);
    println!("no std_error (spatial estimate): RMSE {before:.4} -> {after:.4}");
    assert!(after * 3.0 < before);
}

fn all_filters() -> [Denoise; 3] {
    [Denoise::None, Denoise::Median, Denoise::Atrous]
}

#[test]
fn no_frames_and_tiny_films() {
    for filter in all_filters() {
        let mut none: Vec<Film> = Vec::new();
        denoise(&mut none, filter, &AtrousOptions::default());

        let mut one = Film::new(1, 1);
        one.color[0] = DVec3::new(0.1, 0.2, 0.3);
        one.std_error[0] = DVec3::splat(0.05);
        one.albedo[0] = DVec3::splat(0.5);
        one.normal[0] = DVec4::new(0.0, 0.0, -1.0, 0.0);
        for n in [1, 2, 3] {
            let mut frames = vec![one.clone(); n];
            denoise(&mut frames, filter, &AtrousOptions::default());
            for f in &frames {
                assert!(
                    (f.color[0] - one.color[0]).abs().max_element() < 1e-12,
                    "{filter:?}"
                );
            }
        }

        // Empty and inconsistent films are left alone.
        let mut odd = vec![
            Film::new(0, 5),
            Film::new(3, 0),
            Film::new(4, 4),
            Film::new(4, 4),
        ];
        odd[2].color.pop();
        odd[3].normal.clear();
        let before = odd.clone();
        denoise(&mut odd, filter, &AtrousOptions::default());
        assert_eq!(odd[..3], before[..3]);

        // Frames of different sizes do not mix.
        let mut mixed = vec![Film::new(3, 3), Film::new(4, 2)];
        mixed[0].color.iter_mut().for_each(|c| *c = DVec3::ONE);
        denoise(&mut mixed, filter, &AtrousOptions::default());
        assert!(mixed[1].color.iter().all(|c| *c == DVec3::ZERO));

        // Options at their extremes.
        let mut frames = vec![one.clone(); 2];
        let extreme = AtrousOptions {
            passes: u32::MAX,
            sigma_color: 0.0,
            sigma_normal: f64::NAN,
            sigma_position: -1.0,
            sigma_albedo: f64::INFINITY,
            sigma_color_decay: f64::NAN,
            temporal: Temporal::FirstPass,
            conserve: true,
        };
        denoise(&mut frames, filter, &extreme);
        assert!(frames[0].color[0].is_finite());
    }
}

#[test]
fn nan_pixels_do_not_spread() {
    let Truth {
        film: truth,
        region,
    } = scene(false);
    let mut rng = Pcg64::seed_from_u64(6);
    let mut f = noisy(&truth, &region, 0.08, &mut rng);
    let w = f.width;
    let bad = [
        20 * w + 20,
        20 * w + 21,
        40 * w + 60,
        10 * w + 5,
        30 * w + 30,
    ];
    f.color[bad[0]] = DVec3::new(f64::NAN, 0.5, 0.5);
    f.color[bad[1]] = DVec3::splat(f64::NAN);
    f.color[bad[2]] = DVec3::new(f64::INFINITY, 0.0, 0.0);
    f.color[bad[3]] = DVec3::splat(f64::NEG_INFINITY);
    f.color[bad[4]] = DVec3::splat(f64::NAN);
    // Broken guides elsewhere.
    f.normal[50 * w + 10] = DVec4::splat(f64::NAN);
    f.position[51 * w + 70] = DVec4::splat(f64::INFINITY);
    f.std_error[52 * w + 30] = DVec3::splat(f64::NAN);
    f.albedo[12 * w + 12] = DVec3::splat(f64::NAN);
    for filter in [Denoise::Median, Denoise::Atrous] {
        let mut frames = vec![f.clone(), f.clone(), f.clone()];
        denoise(&mut frames, filter, &AtrousOptions::default());
        for fr in &frames {
            for (p, c) in fr.color.iter().enumerate() {
                if !bad.contains(&p) {
                    assert!(c.is_finite(), "{filter:?}: pixel {p} became {c:?}");
                }
            }
            let err = rmse(&fr.color, &truth.color, |p| {
                !bad.contains(&p) && region[p] != SKY
            });
            assert!(err < 0.06, "{filter:?}: {err}");
        }
        // An isolated NaN is filled from its neighbours.
        assert!(frames[1].color[bad[4]].is_finite(), "{filter:?}");
    }

    // A film with nothing valid stays exactly as it was.
    let mut all_nan = Film::new(5, 4);
    all_nan
        .color
        .iter_mut()
        .for_each(|c| *c = DVec3::splat(f64::NAN));
    for filter in all_filters() {
        let mut frames = vec![all_nan.clone()];
        denoise(&mut frames, filter, &AtrousOptions::default());
        assert!(frames[0].color.iter().all(|c| c.is_nan()));
    }
}

#[test]
fn filter_none_is_bit_identical() {
    let Truth {
        film: truth,
        region,
    } = scene(false);
    let mut rng = Pcg64::seed_from_u64(8);
    let mut f = noisy(&truth, &region, 0.08, &mut rng);
    f.color[3] = DVec3::new(f64::NAN, -0.0, f64::INFINITY);
    let mut frames = vec![f.clone(), f.clone()];
    denoise(&mut frames, Denoise::None, &AtrousOptions::default());
    for fr in &frames {
        let bits = |c: &Vec<DVec3>| {
            c.iter()
                .flat_map(|v| v.to_array().map(f64::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&fr.color), bits(&f.color));
    }
}

#[test]
#[ignore = "timing"]
fn timing() {
    let n: usize = std::env::var("DN_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(512);
    let big = Film::new(n, n);
    let mut frames = vec![big.clone(), big.clone(), big];
    let mut rng = Pcg64::seed_from_u64(10);
    for f in &mut frames {
        for p in 0..n * n {
            f.normal[p] = DVec4::new(0.0, 0.0, -1.0, 0.0);
            f.albedo[p] = DVec3::splat(0.5);
            f.position[p] = DVec4::new((p % n) as f64, (p / n) as f64, 1.0, 0.0);
            f.std_error[p] = DVec3::splat(0.1);
            f.color[p] = DVec3::splat(0.5 + 0.1 * gaussian(&mut rng));
        }
    }
    for conserve in [false, true] {
        let mut fr = frames.clone();
        let t = std::time::Instant::now();
        denoise(
            &mut fr,
            Denoise::Atrous,
            &AtrousOptions {
                conserve,
                ..AtrousOptions::default()
            },
        );
        println!("{n}x{n}x3 a-trous (conserve {conserve}): {:?}", t.elapsed());
    }
    let t = std::time::Instant::now();
    denoise(&mut frames, Denoise::Median, &AtrousOptions::default());
    println!("{n}x{n}x3 median: {:?}", t.elapsed());
}
