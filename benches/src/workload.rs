//! The two point sets every contender evaluates: uniform random points (incoherent: neighbouring
//! points land in unrelated parts of the scene) and the points a sphere tracer actually visits
//! (coherent: neighbouring rays take similar paths), both stored as structure-of-arrays, the
//! layout batch evaluators want.

use crate::rng::Rng;

#[derive(Clone, Default)]
pub struct Points {
    pub xs: Vec<f32>,
    pub ys: Vec<f32>,
    pub zs: Vec<f32>,
    pub ws: Vec<f32>,
}

impl Points {
    pub fn len(&self) -> usize {
        self.xs.len()
    }

    pub fn get(&self, i: usize) -> [f32; 4] {
        [self.xs[i], self.ys[i], self.zs[i], self.ws[i]]
    }

    pub fn push(&mut self, p: [f32; 4]) {
        self.xs.push(p[0]);
        self.ys.push(p[1]);
        self.zs.push(p[2]);
        self.ws.push(p[3]);
    }
}

/// `n` points uniform in [-h, h]^4, from a fixed seed.
pub fn uniform(n: usize, h: f32) -> Points {
    let mut rng = Rng::new(0x5eed);
    let mut pts = Points::default();
    for _ in 0..n {
        pts.push(std::array::from_fn(|_| rng.range(-h, h)));
    }
    pts
}

/// The marching workload's settings: a pinhole camera looking along +z with y up, a square tile
/// of rays, sphere-traced for a bounded number of steps.
pub struct Camera {
    pub origin: [f32; 4],
    pub tile: usize,
    pub fov_deg: f32,
    pub max_steps: usize,
    pub epsilon: f32,
    pub max_t: f32,
}

impl Camera {
    pub fn at(origin: [f32; 4]) -> Camera {
        Camera {
            origin,
            tile: 64,
            fov_deg: 60.0,
            max_steps: 64,
            epsilon: 1e-3,
            max_t: 30.0,
        }
    }
}

/// Sphere-traces the camera's tile of rays with `sdf` and returns every point at which the
/// distance was evaluated, in evaluation order (ray by ray, row by row).
pub fn march(sdf: impl Fn([f32; 4]) -> f32, cam: &Camera) -> Points {
    let half = (cam.fov_deg.to_radians() * 0.5).tan();
    let mut pts = Points::default();
    for j in 0..cam.tile {
        for i in 0..cam.tile {
            let u = ((i as f32 + 0.5) / cam.tile as f32 * 2.0 - 1.0) * half;
            let v = (1.0 - (j as f32 + 0.5) / cam.tile as f32 * 2.0) * half;
            let len = (u * u + v * v + 1.0).sqrt();
            let dir = [u / len, v / len, 1.0 / len, 0.0];
            let mut t = 0.0;
            for _ in 0..cam.max_steps {
                let p = std::array::from_fn(|k| cam.origin[k] + t * dir[k]);
                pts.push(p);
                let d = sdf(p);
                t += d;
                if d < cam.epsilon || t > cam.max_t {
                    break;
                }
            }
        }
    }
    pts
}
