//! Distance primitives, generic over [`Num`], with the semantics of the `.4ds` language
//! (docs/language.md, sections 9-11). Scenes are assembled from these, so a formula is written
//! once and shared by the native scalar, native packet and fidget contenders.

use crate::num::Num;

/// A point (or vector) in 4D: x, y, z, w.
pub type V4<T> = [T; 4];

/// The rotation planes the scenes use (the language has all six).
#[derive(Clone, Copy, Debug)]
pub enum Plane {
    Xz,
    Yw,
}

impl Plane {
    pub fn axes(self) -> (usize, usize) {
        match self {
            Plane::Xz => (0, 2),
            Plane::Yw => (1, 3),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Plane::Xz => "xz",
            Plane::Yw => "yw",
        }
    }
}

/// A rotation by `angle` (radians) in `plane`, with cos/sin computed once in f64 (as the
/// language's compile-time stage would) and rounded to f32.
#[derive(Clone, Copy, Debug)]
pub struct Rotation {
    pub plane: Plane,
    pub angle: f64,
    cos: f32,
    sin: f32,
}

impl Rotation {
    pub fn new(plane: Plane, angle: f64) -> Rotation {
        Rotation {
            plane,
            angle,
            cos: angle.cos() as f32,
            sin: angle.sin() as f32,
        }
    }

    /// Maps a point into the frame of a shape rotated by this rotation, i.e. applies the inverse:
    /// `rotate(s, plane(a, b), θ)` turns the shape from axis a towards axis b, so
    /// `p'_a = cos θ p_a + sin θ p_b`, `p'_b = -sin θ p_a + cos θ p_b`.
    #[inline(always)]
    pub fn inverse_apply<T: Num>(&self, p: V4<T>) -> V4<T> {
        let (a, b) = self.plane.axes();
        let (c, s) = (T::from(self.cos), T::from(self.sin));
        let mut q = p.clone();
        q[a] = c.clone() * q[a].clone() + s.clone() * p[b].clone();
        q[b] = c * p[b].clone() - s * p[a].clone();
        q
    }
}

/// `[f(0), f(1), f(2), f(3)]`. Used instead of `std::array::from_fn`/`map`, which LLVM does not
/// always inline into the AVX2 kernels (they then run out of line, and without AVX2).
#[inline(always)]
pub fn v4<T>(mut f: impl FnMut(usize) -> T) -> V4<T> {
    [f(0), f(1), f(2), f(3)]
}

#[inline(always)]
pub fn sub_const<T: Num>(p: &V4<T>, c: [f32; 4]) -> V4<T> {
    v4(|i| p[i].clone() - T::from(c[i]))
}

#[inline(always)]
pub fn length<T: Num>(v: &V4<T>) -> T {
    let [x, y, z, w] = v.clone();
    (x.clone() * x + y.clone() * y + z.clone() * z + w.clone() * w).sqrt()
}

#[inline(always)]
pub fn max4<T: Num>(v: &V4<T>) -> T {
    v[0].max(&v[1]).max(&v[2].max(&v[3]))
}

/// `hypersphere(r)`: |p| - r.
#[inline(always)]
pub fn hypersphere<T: Num>(p: &V4<T>, r: f32) -> T {
    length(p) - T::from(r)
}

/// `hyperbox(h)`: with q = |p| - h, length(max(q, 0)) + min(max(q.x, q.y, q.z, q.w), 0).
#[inline(always)]
pub fn hyperbox<T: Num>(p: &V4<T>, h: [f32; 4]) -> T {
    let q: V4<T> = v4(|i| p[i].abs() - T::from(h[i]));
    let zero = T::from(0.0);
    let outside: V4<T> = v4(|i| q[i].max(&zero));
    length(&outside) + max4(&q).min(&zero)
}

/// `round(s, r)`: d - r.
#[inline(always)]
pub fn round_by<T: Num>(d: T, r: f32) -> T {
    d - T::from(r)
}

/// `onion(s, th)`: |d| - th/2.
#[inline(always)]
pub fn onion<T: Num>(d: T, thickness: f32) -> T {
    d.abs() - T::from(thickness * 0.5)
}

/// The nearest point of the D4 lattice (integer points with an even coordinate sum), by Conway and
/// Sloane's decoder: round every coordinate (half away from zero); if the sum is odd, re-round the
/// coordinate with the largest rounding error |p_i - r_i| the other way (r_k += 1 if p_k > r_k,
/// else -1). Ties for the largest error go to the lowest index.
///
/// Written without branches so that packets and fidget can run it: `odd` is the parity as 0.0/1.0
/// (s - 2 floor(s/2), exact for integer s), and `todo` (= odd until one coordinate has been
/// flipped) walks the coordinates, flipping the first one whose error is the maximum.
#[inline(always)]
pub fn d4_nearest<T: Num>(p: &V4<T>) -> V4<T> {
    let r: V4<T> = v4(|i| p[i].round());
    let e: V4<T> = v4(|i| p[i].clone() - r[i].clone());
    let a: V4<T> = v4(|i| e[i].abs());
    let sum = r[0].clone() + r[1].clone() + r[2].clone() + r[3].clone();
    let odd = sum.clone() - T::from(2.0) * (sum * T::from(0.5)).floor();
    let worst = max4(&a);
    let (one, zero) = (T::from(1.0), T::from(0.0));
    let mut todo = odd;
    let mut out = r;
    for k in 0..4 {
        // a_k >= worst, as 1 - [worst > a_k]
        let is_worst = one.clone() - worst.gt(&a[k]);
        let flip = todo.clone() * is_worst;
        // +1 if p_k > r_k, else -1
        let dir = T::from(2.0) * e[k].gt(&zero) - one.clone();
        out[k] = out[k].clone() + flip.clone() * dir;
        todo = todo - flip;
    }
    out
}

/// `s |> tile(d4(1))`: s evaluated at p minus the nearest lattice point.
#[inline(always)]
pub fn tile_d4<T: Num>(p: &V4<T>) -> V4<T> {
    let c = d4_nearest(p);
    v4(|i| p[i].clone() - c[i].clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nearest D4 point by brute force over the 3^4 integer points around p.
    fn brute_d4(p: [f32; 4]) -> [f32; 4] {
        let base = p.map(f32::floor);
        let mut best = ([0.0; 4], f32::INFINITY);
        for m in 0..81u32 {
            let c: [f32; 4] =
                std::array::from_fn(|i| base[i] - 1.0 + ((m / 3u32.pow(i as u32)) % 3) as f32);
            if (c.iter().sum::<f32>() as i64).rem_euclid(2) != 0 {
                continue;
            }
            let d: f32 = (0..4).map(|i| (p[i] - c[i]).powi(2)).sum();
            if d < best.1 {
                best = (c, d);
            }
        }
        best.0
    }

    #[test]
    fn d4_decoder_matches_brute_force() {
        let mut rng = crate::rng::Rng::new(7);
        for _ in 0..20000 {
            let p: [f32; 4] = std::array::from_fn(|_| rng.range(-5.0, 5.0));
            let got = d4_nearest(&p);
            let want = brute_d4(p);
            let dist = |c: [f32; 4]| (0..4).map(|i| (p[i] - c[i]).powi(2)).sum::<f32>();
            assert!(
                (dist(got) - dist(want)).abs() < 1e-5,
                "{p:?}: {got:?} vs {want:?}"
            );
            assert_eq!((got.iter().sum::<f32>() as i64).rem_euclid(2), 0);
        }
    }

    #[test]
    fn rotation_turns_a_towards_b() {
        // A shape rotated 90deg in xz: the shape's +x axis now points along +z, so the world point
        // (0, 0, 1, 0) is the shape-frame point (1, 0, 0, 0).
        let r = Rotation::new(Plane::Xz, std::f64::consts::FRAC_PI_2);
        let q = r.inverse_apply([0.0f32, 0.0, 1.0, 0.0]);
        assert!((q[0] - 1.0).abs() < 1e-6 && q[2].abs() < 1e-6, "{q:?}");
    }
}
