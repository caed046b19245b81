//! Diffuse vertices four at a time. Most vertices of a lit scene are diffuse, and each takes a
//! light sample and draws a cosine-weighted direction: chains of square roots, divisions and
//! polynomials that kept the FPU busy one path at a time. Here four vertices run them in the
//! lanes of one vector (`math::lanes`), each lane bit for bit what `reflect` computes for its
//! vertex alone, and each path draws its random numbers in the same order as there.

use super::{Nee, Path, Settings, Shadows, cosine_lobe, facing, scattered, survive};
use crate::math::lanes::{F4, Lane, gather, lane, normalize};
use crate::render::bsdf::Lambert;
use crate::render::frame::FrameScene;
use crate::render::lights::sample_balls;
use crate::render::sampling::{Frame, cosine_hemisphere};
use glam::{DVec3, DVec4};

/// A diffuse hit waiting to scatter: its path, point, normal (either side), hit epsilon, the
/// BSDF sample's random numbers (drawn before the light sample's) and albedo.
pub struct Vertex {
    pub path: u32,
    pub p: DVec4,
    pub n: DVec4,
    pub eps: f64,
    pub u: DVec3,
    pub albedo: DVec3,
}

/// Scatter every vertex, as `reflect` with `Lambert` would one at a time: take its light
/// sample (queued in `shadows`), draw its next direction and play Russian roulette, setting
/// whether its path goes on in `alive`.
pub fn scatter(
    vertices: &[Vertex],
    (paths, alive): (&mut [Path], &mut [bool]),
    fs: &FrameScene,
    s: &Settings,
    nee: &Nee,
    shadows: &mut Shadows,
) {
    for four in vertices.chunks(4) {
        crate::simd::wide!(scatter_four(four, (paths, alive), fs, s, nee, shadows));
    }
}

/// `scatter` for one to four vertices.
#[inline(always)]
fn scatter_four(
    four: &[Vertex],
    (paths, alive): (&mut [Path], &mut [bool]),
    fs: &FrameScene,
    s: &Settings,
    nee: &Nee,
    shadows: &mut Shadows,
) {
    // Each path's side of its surface, and its light sample's numbers (the light, and where on
    // it), drawn in its own order: after the BSDF's (in `shade`), before the roulette's.
    let mut sides = [(DVec4::ZERO, DVec4::ZERO); 4];
    let mut draws = [None; 4];
    for (l, v) in four.iter().enumerate() {
        let path = &mut paths[v.path as usize];
        sides[l] = facing(path, v.p, v.n, v.eps);
        if let Some((lights, select, u)) = nee.draw(path, v.p) {
            draws[l] = lights.choose(select).map(|i| (i, u));
        }
    }
    // Lanes past the vertices repeat the last one; their numbers are not used.
    let lanes = [0, 1, 2, 3].map(|l: usize| l.min(four.len() - 1));
    let (sides, draws) = (lanes.map(|l| sides[l]), lanes.map(|l| draws[l]));
    let frame = Frame::of(gather(sides.map(|(n, _)| n.to_array())));
    let wi = frame.world(gather(
        lanes.map(|l| (-paths[four[l].path as usize].d).to_array()),
    ));
    let bsdf_wo = cosine_hemisphere(gather(lanes.map(|l| four[l].u.to_array())));
    let out = normalize(frame.world(bsdf_wo));
    // The light samples, where the paths draw them, and their directions in each frame.
    // (A block, not a closure: a closure the compiler does not inline runs without the
    // vector instructions of `wide!`.)
    let mut light = None;
    if let Some(lights) = nee.lights.filter(|_| draws.iter().any(Option::is_some)) {
        let chosen = draws.map(|d| d.map_or(&lights.lights()[0], |(i, _)| &lights.lights()[i]));
        let center = gather(chosen.map(|c| c.center.to_array()));
        let radius = F4(chosen.map(|c| c.radius));
        let u = gather(draws.map(|d| d.map_or([0.0; 3], |(_, u)| u.to_array())));
        let p = gather(lanes.map(|l| four[l].p.to_array()));
        let (drawn, wo, pdf, distance) = sample_balls(p, center, radius, u);
        light = Some((drawn, wo, pdf, distance, frame.world(wo)));
    }
    for (l, v) in four.iter().enumerate() {
        let path = &mut paths[v.path as usize];
        let lambert = Lambert { albedo: v.albedo };
        let (wi, o) = (DVec4::from_array(lane(wi, l)), sides[l].1);
        let mut sampled = false;
        if let Some(lights) = nee.lights {
            if let (Some((i, _)), Some((drawn, wo, pdf, distance, local))) = (draws[l], light) {
                let numbers = (drawn.at(l), lane(wo, l), pdf.at(l), distance.at(l));
                let ls = lights.drawn(i, numbers);
                // `queue` asks for the light sample's own direction, which the lanes turned
                // into the vertex's frame already (`local`).
                let wo_local = DVec4::from_array(lane(local, l));
                let lobe = |_| cosine_lobe(&lambert, wi, wo_local);
                let m = path.stack.medium(fs.medium);
                nee.queue(lights, path, v.path, ls, o, m, lobe, shadows);
            }
            sampled = true;
        }
        let b = lambert.sampled(wi, DVec4::from_array(lane(bsdf_wo, l)));
        alive[v.path as usize] = b.is_some_and(|b| {
            let delta = scattered(path, b, DVec4::from_array(lane(out, l)), o, sampled);
            survive(path, s, delta)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::{LightSampling, Stack, reflect};
    use super::*;
    use crate::compile::Frames;
    use crate::render::frame::{Build, FrameSource};
    use crate::render::march::{MarcherKind, Ray};
    use crate::render::sampler::{Sampler, SamplerKind};
    use rand::{Rng, SeedableRng};

    /// Every number of a path that scattering sets, as bits (NaN equal to itself).
    fn state(path: &mut Path) -> Vec<u64> {
        let vectors = [
            path.beta.extend(path.eta_scale),
            path.radiance.extend(path.mis_pdf),
        ];
        let vectors = vectors.into_iter().chain([path.o, path.d, path.mis_from]);
        let mut bits: Vec<u64> = vectors
            .flat_map(|v| v.to_array().map(f64::to_bits))
            .collect();
        bits.extend([path.bounces as u64, path.sampler.get().to_bits()]);
        bits
    }

    /// Diffuse vertices scattered four at a time (in groups of one to nine, so every lane count
    /// runs) leave their paths, the light samples' shadow rays and the roulette's verdicts bit
    /// for bit as `reflect` with `Lambert` leaves them one at a time: with and without light
    /// sampling, from points outside the lights, inside them and on their surfaces, with
    /// normals on either side of the path, along the axes and with signed zeros.
    #[test]
    fn four_at_a_time_scatter_as_each_alone() {
        let source = "render { size = 8 x 8  spp = 1 }
            camera { from = [0, 0, -6, 0]  to = [0, 0, 0, 0] }
            medium = fog(extinction: 0.3, albedo: 0.8)
            object a { shape = hypersphere(0.3) |> translate([1, 0.5, 0, 0])
                       material = light(rgb(1, 0.5, 0.2), intensity: 30) }
            object b { shape = hypersphere(0.8) |> translate([-1, 0, 0.5, 0.2])
                       material = light(rgb(1), intensity: 2) }
            object c { shape = hyperbox(3) |> onion(0.1)  material = diffuse(rgb(0.5)) }";
        let scene = crate::Compilation::from_source("t.4ds", source).scene;
        let scene = scene.expect("the test scene compiles");
        let frames = Frames::new(&scene);
        let fs = frames.at(0.0, Build::marcher(MarcherKind::Auto));
        assert_eq!(fs.lights.lights().len(), 2);
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        for (sampler, light_sampling) in [(SamplerKind::Sobol, true), (SamplerKind::Random, true)]
            .into_iter()
            .chain([(SamplerKind::Sobol, false)])
        {
            let s = Settings {
                shot: *frames.shot(),
                roulette_from: 0,
                light_sampling,
                sampler,
            };
            let nee = Nee {
                lights: light_sampling.then_some(&fs.lights),
                interior: false,
            };
            let coordinate = |rng: &mut rand_pcg::Pcg64Mcg| match rng.random_range(0..8) {
                0 => 0.0,
                1 => -0.0,
                2 => 1.0,
                _ => rng.random_range(-2.0..2.0),
            };
            let (mut paths, mut vertices) = (vec![], vec![]);
            for i in 0..3000u32 {
                let p = match rng.random_range(0..6) {
                    // On the small light's surface and inside the big one.
                    0 => DVec4::new(1.0, 0.8, 0.0, 0.0),
                    1 => DVec4::new(-1.0, 0.1, 0.5, 0.2),
                    _ => DVec4::from_array(std::array::from_fn(|_| coordinate(&mut rng))),
                };
                let unit = |rng: &mut rand_pcg::Pcg64Mcg| {
                    let v = DVec4::from_array(std::array::from_fn(|_| coordinate(rng)));
                    v.try_normalize().unwrap_or(DVec4::W)
                };
                let mut sampler = Sampler::new(sampler, 5, 1, i as u64, rng.random_range(0..64));
                sampler.start_segment(rng.random_range(0..4));
                let mut path = Path {
                    pixel: 0,
                    sampler,
                    beta: DVec3::new(rng.random(), rng.random(), rng.random()),
                    eta_scale: 1.0,
                    radiance: DVec3::ZERO,
                    o: DVec4::ZERO,
                    d: unit(&mut rng),
                    bounces: rng.random_range(0..6),
                    crossings: 0,
                    stack: Stack::EMPTY,
                    flight: false,
                    primary: false,
                    mis_pdf: 0.0,
                    mis_from: DVec4::ZERO,
                };
                let u = path.u3();
                let albedo = DVec3::new(rng.random(), rng.random(), 0.9);
                let (n, eps) = (unit(&mut rng), rng.random_range(1e-6..1e-2));
                vertices.push(Vertex {
                    path: i,
                    p,
                    n,
                    eps,
                    u,
                    albedo,
                });
                paths.push(path);
            }
            let (mut one, mut four) = (paths.clone(), paths);
            let (mut alive_one, mut alive_four) = (vec![false; one.len()], vec![true; one.len()]);
            let (mut shadows_one, mut shadows_four) = (Shadows::default(), Shadows::default());
            for v in &vertices {
                let path = &mut one[v.path as usize];
                let lambert = Lambert { albedo: v.albedo };
                let light: LightSampling = Some((&fs, &nee, v.path, &mut shadows_one));
                let delta = reflect(path, v.p, v.n, &lambert, v.u, v.eps, light);
                alive_one[v.path as usize] = delta.is_some_and(|d| survive(path, &s, d));
            }
            let mut rest = &vertices[..];
            while !rest.is_empty() {
                let (group, after) = rest.split_at(rng.random_range(1..=9).min(rest.len()));
                let (four, alive) = (&mut four[..], &mut alive_four[..]);
                scatter(group, (four, alive), &fs, &s, &nee, &mut shadows_four);
                rest = after;
            }
            assert_eq!(alive_one, alive_four);
            for (a, b) in one.iter_mut().zip(four.iter_mut()) {
                assert_eq!(state(a), state(b), "{a:?}");
            }
            let sent = shadows_one.pending.len();
            assert!(!light_sampling || sent > 1000, "{sent} shadow rays");
            assert_eq!(shadows_one.pending, shadows_four.pending);
            let bits = |r: &Ray| [r.o, r.d].map(|v| v.to_array().map(f64::to_bits));
            let rays = |s: &Shadows| s.rays.iter().map(|r| (bits(r), r.tmax.to_bits())).collect();
            let rays: (Vec<_>, Vec<_>) = (rays(&shadows_one), rays(&shadows_four));
            assert_eq!(rays.0, rays.1);
        }
    }
}
