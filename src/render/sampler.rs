//! Where a path's random numbers come from: an independent PCG stream per sample, or an
//! Owen-scrambled Sobol sequence per pixel (Burley 2020, the `sobol_burley` crate) whose
//! sample index is the pixel's sample number.
//!
//! Every number is a function of the seed, frame, pixel and sample index only, so images do
//! not depend on the thread count. With Sobol, the samples of one pixel are stratified in
//! every dimension, and jointly within each set of four dimensions that `sobol_burley` draws
//! together: the first two dimensions are the pixel jitter, and path segment `b` (after `b`
//! scattering events) starts at dimension `4 + SEGMENT_DIMENSIONS * b`, the start of a set,
//! so the same dimension usually serves the same decision in every sample and a scattering
//! direction's three numbers come from one set. A segment that uses more (several
//! null-boundary crossings) moves on to the next unused dimension; a dimension is never used
//! twice in one sample. Every point of an Owen-scrambled sequence is uniform on the unit cube,
//! so the estimate stays unbiased whichever decision a dimension ends up serving. Past the
//! sequence's 256 dimensions, and for sample indices past its 2^16 points, the PCG stream
//! takes over.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

/// Dimensions reserved for each path segment: the free flight, the scattering direction (3),
/// the light sample (4), Russian roulette, and room for three null-boundary crossings.
const SEGMENT_DIMENSIONS: u32 = 12;
/// Dimensions set aside for the camera ray: its jitter within the pixel takes two, and the
/// segments start at a set of four. Started two dimensions earlier, each segment's numbers
/// straddled two sets, and the examples' error at 16 spp was 3% to 21% higher (RMSE against
/// a 1,024 to 4,096 spp reference; see `docs/performance.md`).
const CAMERA_DIMENSIONS: u32 = 4;
const _: () = assert!(CAMERA_DIMENSIONS.is_multiple_of(4) && SEGMENT_DIMENSIONS.is_multiple_of(4));
// Sets are computed in pairs (`Sobol::pair`).
const _: () = assert!(sobol_burley::NUM_DIMENSION_SETS_4D.is_multiple_of(2));

/// Which sequence drives the samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Independent uniform numbers (PCG32), one stream per sample.
    Random,
    /// Owen-scrambled Sobol points, one sequence per pixel, with PCG32 beyond its range (the
    /// default: it measured 1.0 to 3.1 dB higher PSNR at 16 spp on every example scene, see
    /// `docs/performance.md`).
    #[default]
    Sobol,
}

impl SamplerKind {
    /// Its name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Random => "random",
            SamplerKind::Sobol => "sobol",
        }
    }
}

/// The random numbers of one sample (one path).
#[derive(Clone, Debug)]
pub struct Sampler {
    /// The PCG stream's seed, and the stream once a number is drawn from it (seeding it costs
    /// as much as a few Sobol numbers, and most Sobol samples never reach it).
    key: u64,
    rng: Option<Pcg32>,
    /// The Sobol sample, when Sobol drives this sample.
    sobol: Option<Sobol>,
    /// The next Sobol dimension.
    dim: u32,
    /// The last pair of sets of four Sobol dimensions computed (`u32::MAX`: none yet) and
    /// their values: eight numbers at once, the same `sobol_burley::sample` gives one at a
    /// time.
    pair: u32,
    eight: [f32; 8],
}

/// One pixel's Owen-scrambled Sobol sequence (`seed`) at one sample index:
/// `sobol_burley::sample_4d` taken apart, with what depends on the sample alone (the shuffled
/// index) computed once instead of for every set of four dimensions.
#[derive(Clone, Copy, Debug)]
struct Sobol {
    seed: u32,
    /// The sample index, bit-reversed and shuffled by the pixel's seed.
    shuffled: u32,
}

impl Sobol {
    fn new(index: u32, seed: u32) -> Sobol {
        use sobol_burley::parts::{hash, owen_scramble_rev};
        let shuffled = owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x79c68e4a));
        Sobol { seed, shuffled }
    }

    /// Dimensions `8 pair .. 8 pair + 8`, the sets of four `2 pair` and `2 pair + 1` (below
    /// `NUM_DIMENSION_SETS_4D`), as `sobol_burley::sample_4d(index, set, seed)` computes
    /// each: its hash and Owen scramble written out on arrays of eight, compiled for AVX2
    /// where the CPU has it. The crate's are built for SSE2, which has no multiply of four
    /// 32-bit lanes: each of the seven took five instructions, and `Sampler::get` was a tenth
    /// of the room's render. A path segment's twelve dimensions span three sets, most often
    /// all drawn: in the room a pair at a time computed 357,000 times where a set at a time
    /// did 607,000, at 122 instructions a pair against 100 a set.
    #[inline]
    fn pair(&self, pair: u32) -> [f32; 8] {
        let sobol = points(self.shuffled, pair);
        let seed = self.seed.wrapping_mul(0x9c8f2d3b);
        const KEYS: [u32; 4] = [0x912f69ba, 0x174f18ab, 0x691e72ca, 0xb40cc1b8];
        crate::simd::wide!({
            // Lanes 0 to 3 are set `2 pair`'s, 4 to 7 set `2 pair + 1`'s.
            let scramble: [u32; 8] =
                std::array::from_fn(|i| seed ^ (2 * pair + i as u32 / 4) ^ KEYS[i % 4]);
            // `hash_int4`.
            let h = scramble
                .map(|n| n ^ 0xe6fe3beb)
                .map(|n| (n ^ (n >> 16)).wrapping_mul(0x7feb352d))
                .map(|n| (n ^ (n >> 15)).wrapping_mul(0x846ca68b))
                .map(|n| n ^ (n >> 16));
            // `owen_scramble_int4_rev`, then `reverse_bits` and `to_f32_norm`.
            let n = sobol.map(|n| n ^ n.wrapping_mul(0x3d20adea));
            let n: [u32; 8] =
                std::array::from_fn(|i| n[i].wrapping_add(h[i]).wrapping_mul((h[i] >> 16) | 1));
            n.map(|n| n ^ n.wrapping_mul(0x05526c56))
                .map(|n| n ^ n.wrapping_mul(0x53a22864))
                .map(|n| f32::from_bits((n.reverse_bits() >> 9) | 0x3f80_0000) - 1.0)
        })
    }
}

/// For each pair of sets of four dimensions, and each of the four nibbles of the
/// (bit-reversed) index's top 16 bits that the sequence reads, the XOR of the direction
/// numbers each of the nibble's 16 values selects, both sets' side by side: a pair is four
/// lookups, where `sobol_int4_rev` loops over the index's bits (a loop of random length, whose
/// exit the branch predictor missed every time). The Sobol point is linear in the index's
/// bits, so each entry is `sobol_int4_rev` of the nibble alone.
type Nibbles = [[[u32; 8]; 16]; 4];

/// `sobol_int4_rev(shuffled, set)` of the pair's two sets from the tables, one after the other.
#[inline]
fn points(shuffled: u32, pair: u32) -> [u32; 8] {
    let mut sobol = [0u32; 8];
    for (q, table) in nibbles()[pair as usize].iter().enumerate() {
        let m = &table[(shuffled >> (28 - 4 * q)) as usize & 15];
        sobol = std::array::from_fn(|lane| sobol[lane] ^ m[lane]);
    }
    sobol
}

fn nibbles() -> &'static [Nibbles] {
    static TABLE: std::sync::OnceLock<Vec<Nibbles>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        (0..sobol_burley::NUM_DIMENSION_SETS_4D / 2)
            .map(|pair| {
                std::array::from_fn(|q| {
                    std::array::from_fn(|m| {
                        let bits = (m as u32) << (28 - 4 * q);
                        let set = |k| -> [u32; 4] {
                            sobol_burley::parts::sobol_int4_rev(bits, 2 * pair + k).into()
                        };
                        let (a, b) = (set(0), set(1));
                        std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] })
                    })
                })
            })
            .collect()
    })
}

/// A 64-bit mix (SplitMix64's finaliser).
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl Sampler {
    /// The numbers of sample `sample` of pixel `pixel` (row-major over the whole image) in
    /// frame `frame`.
    pub fn new(kind: SamplerKind, seed: u64, frame: u32, pixel: u64, sample: u32) -> Sampler {
        let key = mix(mix(mix(seed ^ 0x9e3779b97f4a7c15) ^ frame as u64) ^ pixel);
        let sobol = (kind == SamplerKind::Sobol && sample < 1 << 16)
            .then(|| Sobol::new(sample, (key ^ (key >> 32)) as u32));
        Sampler {
            key: mix(key ^ sample as u64),
            rng: None,
            sobol,
            dim: 0,
            pair: u32::MAX,
            eight: [0.0; 8],
        }
    }

    /// A uniform number in `[0, 1)`.
    #[inline]
    pub fn get(&mut self) -> f64 {
        match self.sobol_set(1) {
            Some((eight, i)) => eight[i] as f64,
            None => self.pcg(),
        }
    }

    /// Three uniform numbers: one Sobol set's where they share one (a segment's directions
    /// start a set), else one at a time.
    #[inline]
    pub fn get3(&mut self) -> DVec3 {
        match self.sobol_set(3) {
            Some((f, l)) => DVec3::new(f[l] as f64, f[l + 1] as f64, f[l + 2] as f64),
            None => DVec3::new(self.get(), self.get(), self.get()),
        }
    }

    /// Where the next `take` Sobol dimensions lie in one set: its pair's eight numbers and
    /// the index of the first, the dimensions taken; none where they do not (or PCG draws
    /// them).
    #[inline(always)]
    fn sobol_set(&mut self, take: u32) -> Option<([f32; 8], usize)> {
        let sobol = self.sobol.as_ref()?;
        let lane = self.dim % 4;
        // (`dim` may be as high as `u32::MAX`: `start_segment` saturates.)
        if lane + take > 4 || self.dim > sobol_burley::NUM_DIMENSIONS - take {
            return None;
        }
        let pair = self.dim / 8;
        if pair != self.pair {
            (self.pair, self.eight) = (pair, sobol.pair(pair));
        }
        let first = self.dim % 8;
        self.dim += take;
        Some((self.eight, first as usize))
    }

    /// The PCG stream's next number, past the Sobol sequence or in its place.
    fn pcg(&mut self) -> f64 {
        let key = self.key;
        self.rng
            .get_or_insert_with(|| Pcg32::seed_from_u64(key))
            .random()
    }

    /// Called as a path segment starts, after `bounces` scattering events: move to the
    /// segment's first dimension unless earlier segments already used it.
    pub fn start_segment(&mut self, bounces: u32) {
        let first = CAMERA_DIMENSIONS.saturating_add(SEGMENT_DIMENSIONS.saturating_mul(bounces));
        self.dim = self.dim.max(first);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pixel's Sobol samples are stratified: 2^k samples put exactly one point in each
    /// of 2^k equal intervals of every dimension, where independent numbers would not.
    #[test]
    fn sobol_stratifies_each_dimension() {
        for dim_skip in [0u32, 1, 5] {
            let n = 64;
            let mut hits = vec![0u32; n];
            for sample in 0..n as u32 {
                let mut s = Sampler::new(SamplerKind::Sobol, 7, 3, 1234, sample);
                s.start_segment(dim_skip);
                let u = s.get();
                assert!((0.0..1.0).contains(&u));
                hits[(u * n as f64) as usize] += 1;
            }
            assert!(hits.iter().all(|&h| h == 1), "{hits:?}");
        }
    }

    /// Four dimensions at a time give the numbers `sample` gives one at a time, across sets
    /// and after a segment jumps ahead into the middle of one.
    #[test]
    fn four_at_a_time_is_one_at_a_time() {
        for (pixel, sample) in [(0, 0), (17, 5), (123_456, 65_535)] {
            let mut s = Sampler::new(SamplerKind::Sobol, 9, 2, pixel, sample);
            let (index, Sobol { seed, .. }) =
                (sample, s.sobol.expect("Sobol drives these samples"));
            let mut expected = vec![];
            for (segment, take) in [(0, 7), (1, 3), (3, 13), (20, 2)] {
                s.start_segment(segment);
                for _ in 0..take {
                    let dim = s.dim;
                    expected.push(sobol_burley::sample(index, dim, seed) as f64);
                    assert_eq!(s.get(), *expected.last().unwrap(), "dimension {dim}");
                }
            }
        }
    }

    /// Three numbers at once are three in a row, wherever they start in a set, across sets
    /// and past the Sobol sequence's dimensions (as far as `start_segment` saturates), and the
    /// next number after them is too.
    #[test]
    fn three_at_once_are_three_in_a_row() {
        for kind in [SamplerKind::Sobol, SamplerKind::Random] {
            for dim in 0..sobol_burley::NUM_DIMENSIONS + 6 {
                let mut a = Sampler::new(kind, 3, 1, 77, 9);
                a.dim = dim;
                let mut b = a.clone();
                let three = a.get3().to_array().map(f64::to_bits);
                let one = [b.get(), b.get(), b.get()].map(f64::to_bits);
                assert_eq!(three, one, "{kind:?} from dimension {dim}");
                assert_eq!(a.get().to_bits(), b.get().to_bits());
            }
            let mut far = Sampler::new(kind, 3, 1, 77, 9);
            far.start_segment(u32::MAX);
            let mut next = far.clone();
            let three = far.get3().to_array().map(f64::to_bits);
            assert_eq!(
                three,
                [next.get(), next.get(), next.get()].map(f64::to_bits)
            );
        }
    }

    /// The tables give `sobol_int4_rev`'s point for every top half of a shuffled index (the
    /// only bits it reads) in every set: every entry of every table is checked.
    #[test]
    fn tables_are_sobol_int4_rev() {
        use sobol_burley::parts::sobol_int4_rev;
        for set in 0..sobol_burley::NUM_DIMENSION_SETS_4D {
            for top in 0u32..1 << 16 {
                let shuffled = top << 16 | 0x1234;
                let want: [u32; 4] = sobol_int4_rev(shuffled, set).into();
                let both = points(shuffled, set / 2);
                let got: [u32; 4] = std::array::from_fn(|i| both[4 * (set as usize % 2) + i]);
                assert_eq!(got, want, "set {set}, {shuffled:#x}");
            }
        }
    }

    /// The sequence taken apart gives `sample_4d`'s numbers in every set of four dimensions,
    /// two sets at a time.
    #[test]
    fn sets_are_sample_4d() {
        let indices = (0..70).chain([255, 4097, 30_000, 65_535]);
        for (index, seed) in indices.zip([0, 7, 0xdead_beef, u32::MAX].into_iter().cycle()) {
            let sobol = Sobol::new(index, seed);
            for pair in 0..sobol_burley::NUM_DIMENSION_SETS_4D / 2 {
                let [a, b] =
                    [2 * pair, 2 * pair + 1].map(|s| sobol_burley::sample_4d(index, s, seed));
                let expected: [f32; 8] = std::array::from_fn(|i| [a, b][i / 4][i % 4]);
                assert_eq!(
                    sobol.pair(pair),
                    expected,
                    "index {index} seed {seed} pair {pair}"
                );
            }
        }
    }

    #[test]
    fn dimensions_are_never_reused() {
        let mut s = Sampler::new(SamplerKind::Sobol, 1, 0, 0, 3);
        s.start_segment(0);
        for _ in 0..40 {
            s.get();
        }
        let before = s.dim;
        s.start_segment(1);
        assert_eq!(s.dim, before, "segment 1's dimensions were already used");
        s.start_segment(10);
        assert_eq!(s.dim, CAMERA_DIMENSIONS + 10 * SEGMENT_DIMENSIONS);
    }

    #[test]
    fn past_the_sequence_the_stream_takes_over() {
        let mut s = Sampler::new(SamplerKind::Sobol, 1, 0, 0, 0);
        s.start_segment(1000);
        let a: Vec<f64> = (0..4).map(|_| s.get()).collect();
        assert!(a.windows(2).all(|w| w[0] != w[1]));
        let mut late = Sampler::new(SamplerKind::Sobol, 1, 0, 0, 1 << 16);
        assert!(late.sobol.is_none());
        assert!((0.0..1.0).contains(&late.get()));
    }

    #[test]
    fn random_is_the_pcg_stream() {
        let mut a = Sampler::new(SamplerKind::Random, 9, 1, 2, 3);
        let mut b = Sampler::new(SamplerKind::Random, 9, 1, 2, 3);
        a.start_segment(4);
        assert_eq!(a.get(), b.get());
        let mut c = Sampler::new(SamplerKind::Random, 9, 1, 2, 4);
        assert_ne!(a.get(), c.get());
    }
}
