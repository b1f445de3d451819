//! The one seed and hash scheme of radtrace. Every random choice (pixel and cell
//! jitter, reflection paths, light points, shooting points) takes its numbers from a
//! 32-bit seed made one way: SplitMix64 of a parent ^ a key, folded to 32 bits. The
//! parents are the user's seed (for pixels, adaptive cells and shots: [`pixel_seed`],
//! [`cell_seed`], [`shot_seed`]) or another seed ([`derive`] with a [`Stream`]), and
//! the keys name what the numbers are for. So an image depends on the seed alone, not
//! on the threads or the order of the work, and two streams never share numbers.
//! (The keys are those radtrace has always used, so images are unchanged.)

use glam::{Vec2, Vec3};

/// What a derived seed is for ([`derive`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// The path of sample `k` of a pixel (uniform sampler).
    Sample(u32),
    /// The path of an adaptive sampler's sample, from its cell seed.
    Path,
    /// The continuation of a path after a mirror reflection.
    Reflection,
    /// The continuation of a path through glass.
    Transmission,
    /// The light points of ray-traced source `s` at one hit.
    Light(u32),
    /// Where in each shooting cell the shadow rays of mesh vertex `v` aim (pass 1):
    /// every vertex draws its own points, so the errors of neighbouring vertices do
    /// not move together.
    Receiver(u32),
    /// The jittered points of the shooting cells on piece `k` (a grid of a patch, a
    /// patch of an area light) of one shot (pass 1).
    Cells(u32),
    /// The points a point or spot light's shot samples on the mixed pieces of patch
    /// `p` (pass 1: the power a light's shot passes on).
    Piece(u32),
    /// The directions of a final gather at a point of the image (pass 2).
    Gather,
    /// The points where the mesh reads a textured material's albedo on triangle `t`
    /// (of a shape's stream).
    Texel(u32),
    /// Where a camera ray leaves a thin lens (`thinlens`), from the sample's seed.
    Lens,
}

impl Stream {
    /// The key the parent seed is combined with.
    fn key(self) -> u32 {
        match self {
            Stream::Sample(k) => k.wrapping_mul(0x9E37_79B9),
            Stream::Path => 0x2545_f491,
            Stream::Reflection => 0x5bd1_e995,
            Stream::Transmission => 0x3c6e_f372,
            Stream::Light(s) => s.wrapping_mul(0x85eb_ca6b),
            Stream::Receiver(v) => v.wrapping_mul(0xc2b2_ae35) ^ 0x27d4_eb2f,
            Stream::Cells(k) => k.wrapping_mul(0x1656_67b1) ^ 0x9e37_79b9,
            Stream::Piece(p) => p.wrapping_mul(0x27d4_eb2f) ^ 0x1656_67b1,
            Stream::Gather => 0x7feb_352d,
            Stream::Texel(t) => t.wrapping_mul(0x6a09_e667) ^ 0xbb67_ae85,
            Stream::Lens => 0x3c6e_f372 ^ 0xa54f_f53a,
        }
    }
}

/// The one hash: SplitMix64 of `parent ^ key`, folded to 32 bits.
fn hash(parent: u64, key: u64) -> u32 {
    let h = splitmix64(parent ^ key);
    (h ^ (h >> 32)) as u32
}

/// The seed of pixel `(x, y)` of a view (uniform sampler), from the user's seed.
pub fn pixel_seed(seed: u64, view: u64, x: u32, y: u32) -> u32 {
    hash(seed, splitmix64(view << 48 ^ (y as u64) << 24 ^ x as u64))
}

/// The seed of cell `(x, y)` of an adaptive sampler's `level` (-1 ..) in a view.
pub fn cell_seed(seed: u64, view: u64, level: i32, x: u32, y: u32) -> u32 {
    let key = ((level + 1) as u64) << 58 ^ view << 52 ^ (y as u64) << 26 ^ x as u64;
    hash(seed, splitmix64(key))
}

/// The seed of shot `shot` of pass 1.
pub fn shot_seed(seed: u64, shot: u64) -> u32 {
    hash(seed, shot.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// A seed derived from `parent` for `stream`.
pub fn derive(parent: u32, stream: Stream) -> u32 {
    hash((parent ^ stream.key()) as u64, 0)
}

/// Two uniform numbers in [0, 1) (24 bits each): a cell's jitter from its seed.
pub fn uniform2(seed: u32) -> Vec2 {
    let h = splitmix64(seed as u64 ^ 0xA076_1D64_78BD_642F);
    let f = |bits: u64| bits as f32 / (1u64 << 24) as f32;
    Vec2::new(f(h >> 40), f((h >> 16) & 0xFF_FFFF))
}

/// Three uniform numbers in [0, 1) (21 bits each) for draw `index` of `seed`.
pub fn uniform3(seed: u32, index: u32) -> [f32; 3] {
    let h = splitmix64((seed as u64) << 32 | index as u64);
    let f = |k: u32| ((h >> (k * 21)) & 0x1F_FFFF) as f32 / (1u32 << 21) as f32;
    [f(0), f(1), f(2)]
}

/// Shirley and Chiu's concentric map of the unit square onto the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let quarter = std::f32::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() >= b.abs() {
        (a, quarter * (b / a))
    } else {
        (b, 2.0 * quarter - quarter * (a / b))
    };
    Vec2::new(r * phi.cos(), r * phi.sin())
}

/// A cosine-distributed unit direction about the unit normal `n`.
pub fn cosine_direction(n: Vec3, u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let (t, b) = n.any_orthonormal_pair();
    let local = Vec2::new(r * phi.cos(), r * phi.sin());
    (t * local.x + b * local.y + n * (1.0 - u.x).max(0.0).sqrt()).normalize()
}

/// The cone from `x` that holds the sphere of centre `c` and radius `r`: its unit
/// axis and its solid angle, or `None` when `x` lies inside the sphere (every
/// direction then meets it).
pub fn sphere_cone(x: Vec3, c: Vec3, r: f32) -> Option<(Vec3, f32)> {
    let d = c - x;
    let dist2 = d.length_squared();
    if !(dist2 > r * r) {
        return None;
    }
    // 1 - cos(theta_max) = (r/d)^2 / (1 + cos(theta_max)), without cancellation.
    let s2 = r * r / dist2;
    let one_minus_cos = s2 / (1.0 + (1.0 - s2).max(0.0).sqrt());
    Some((d / dist2.sqrt(), 2.0 * std::f32::consts::PI * one_minus_cos))
}

/// The solid angle of a cone of half-angle `half` (radians): 4 pi sin^2(half / 2), as
/// 2 pi (1 - cos half) without its cancellation in narrow cones (the sun's disk).
pub fn cone_solid_angle(half: f32) -> f32 {
    4.0 * std::f32::consts::PI * (0.5 * half).sin().powi(2)
}

/// Whether the unit direction `dir` lies in the cone about the unit `axis` of solid
/// angle `solid_angle`: |dir - axis|^2 = 2 (1 - cos) against solid_angle / pi, precise
/// for narrow cones.
pub fn in_cone(axis: Vec3, solid_angle: f32, dir: Vec3) -> bool {
    (dir - axis).length_squared() <= solid_angle / std::f32::consts::PI
}

/// A unit direction uniform over the cone about the unit `axis` of solid angle
/// `solid_angle` (at most 4 pi: the whole sphere).
pub fn cone_direction(axis: Vec3, solid_angle: f32, u: Vec2) -> Vec3 {
    let one_minus_cos = (u.x * solid_angle / (2.0 * std::f32::consts::PI)).min(2.0);
    let cos_t = 1.0 - one_minus_cos;
    let sin_t = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let (t, b) = axis.any_orthonormal_pair();
    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t).normalize()
}

/// Point `j` of `per` (at most 128) stratified points in the unit square, from the
/// draws of `seed` at `index | j` (`index`'s low 7 bits clear): for a power of two,
/// strata as square as they go (2 x 2, 4 x 2, 4 x 4 ...); for another count, `per`
/// columns, one point in each. Two points are a point and its antipode on the torus
/// instead (a shifted two-point lattice, both from draw `index`): apart across an
/// edge of any direction, where two strata would be apart across one direction only.
pub fn stratum(seed: u32, index: u32, j: u32, per: u32) -> Vec2 {
    if per == 2 {
        let [a, b, _] = uniform3(seed, index);
        let h = 0.5 * j as f32;
        return Vec2::new((a + h).fract(), (b + h).fract());
    }
    let [a, b, _] = uniform3(seed, index | j);
    let per = per.max(1);
    let sx = if per.is_power_of_two() {
        1 << per.ilog2().div_ceil(2)
    } else {
        per
    };
    let sy = per / sx;
    Vec2::new(
        ((j % sx) as f32 + a) / sx as f32,
        ((j / sx) as f32 + b) / sy as f32,
    )
}

/// A discrete distribution drawn in constant time (Walker's alias method, built by
/// Vose's algorithm): a binary search over a cumulative sum of millions of entries
/// misses the cache at every step.
#[derive(Debug, Clone)]
pub struct Alias {
    /// Per column: the chance of keeping the column, and the entry it passes to.
    keep: Vec<f32>,
    alias: Vec<u32>,
    /// Each entry's probability.
    prob: Vec<f64>,
}

impl Alias {
    /// The distribution proportional to `weights` (negative or not-a-number counts as
    /// zero); `None` when no weight is positive.
    pub fn new(weights: &[f64]) -> Option<Self> {
        let clean = |w: f64| if w > 0.0 && w.is_finite() { w } else { 0.0 };
        let total: f64 = weights.iter().map(|&w| clean(w)).sum();
        if !(total > 0.0) {
            return None;
        }
        let n = weights.len();
        let prob: Vec<f64> = weights.iter().map(|&w| clean(w) / total).collect();
        let mut scaled: Vec<f64> = prob.iter().map(|p| p * n as f64).collect();
        let (mut small, mut large): (Vec<u32>, Vec<u32>) =
            (0..n as u32).partition(|&i| scaled[i as usize] < 1.0);
        let mut keep = vec![1.0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            keep[s as usize] = scaled[s as usize] as f32;
            alias[s as usize] = l;
            scaled[l as usize] -= 1.0 - scaled[s as usize];
            if scaled[l as usize] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left keeps its column (rounding only).
        Some(Self { keep, alias, prob })
    }

    /// The entry drawn by three uniform numbers in [0, 1): the first two (42 bits
    /// together) choose a column, the third keeps it or passes to its alias.
    pub fn pick(&self, a: f32, b: f32, c: f32) -> usize {
        let x = (f64::from(a) + f64::from(b) / f64::from(1u32 << 21)).min(1.0 - 1e-15);
        let col = ((x * self.keep.len() as f64) as usize).min(self.keep.len() - 1);
        if c < self.keep[col] {
            col
        } else {
            self.alias[col] as usize
        }
    }

    /// The probability of entry `k`.
    pub fn probability(&self, k: usize) -> f64 {
        self.prob[k]
    }
}

/// SplitMix64's finaliser: a good 64-bit mixing function.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Which of a pixel's samples at an anti-aliasing level this one is, so that the
/// samples share a set of draws: sample `index` of `count` takes its own piece of
/// each stratum (a stretch of a light's group of points, a piece of a gather's cell,
/// of a lobe's square), so that together they cover it as one sample's draws do.
/// The pieces are shifted by the stratum's number, so that one sample's draws do
/// not all sit at the same place in theirs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stratum {
    pub index: u32,
    pub count: u32,
}

impl Stratum {
    /// One sample alone: the whole of every stratum.
    pub const WHOLE: Stratum = Stratum { index: 0, count: 1 };

    /// This sample's piece among `count` for stratum number `k`.
    fn piece_of(self, k: u32) -> u32 {
        let shift = (k.wrapping_mul(0x9e37_79b9) >> 16) % self.count;
        (self.index % self.count + shift) % self.count
    }

    /// `x` in 0..1 moved into this sample's stretch of `count` equal stretches of
    /// 0..1, for stratum number `k`.
    pub fn stretch(self, x: f32, k: u32) -> f32 {
        if self.count <= 1 {
            return x;
        }
        ((self.piece_of(k) as f32 + x) / self.count as f32).min(1.0 - f32::EPSILON)
    }

    /// `xi` in the unit square moved into this sample's piece of a grid of at least
    /// `count` pieces (`ceil(sqrt(count))` columns), for stratum number `k`.
    pub fn piece(self, xi: Vec2, k: u32) -> Vec2 {
        if self.count <= 1 {
            return xi;
        }
        let cols = (self.count as f32).sqrt().ceil() as u32;
        let rows = self.count.div_ceil(cols);
        let s = self.piece_of(k);
        let at = (Vec2::new((s % cols) as f32, (s / cols) as f32) + xi) / Vec2::new(cols as f32, rows as f32);
        at.min(Vec2::splat(1.0 - f32::EPSILON))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Streams, keys and parents all change the seed; the same inputs give the same.
    #[test]
    fn seeds_differ_by_stream_key_and_parent() {
        let a = pixel_seed(7, 0, 1, 2);
        assert_eq!(a, pixel_seed(7, 0, 1, 2));
        assert_ne!(a, pixel_seed(7, 0, 2, 1));
        assert_ne!(a, pixel_seed(8, 0, 1, 2));
        assert_ne!(a, pixel_seed(7, 1, 1, 2));
        assert_ne!(cell_seed(7, 0, 0, 1, 2), cell_seed(7, 0, 1, 1, 2));
        // The streams derived from one path seed at a hit: the reflection and each
        // source's light points; and the samples of one pixel.
        let at_hit = [
            derive(a, Stream::Reflection),
            derive(a, Stream::Light(0)),
            derive(a, Stream::Light(1)),
            derive(a, Stream::Light(2)),
        ];
        let in_pixel = [0, 1, 2, 3].map(|k| derive(a, Stream::Sample(k)));
        for kids in [at_hit, in_pixel] {
            for i in 0..kids.len() {
                for j in 0..i {
                    assert_ne!(kids[i], kids[j], "{i} {j}");
                }
            }
        }
        assert_ne!(derive(a, Stream::Path), derive(a, Stream::Reflection));
    }

    /// The uniform numbers lie in [0, 1) and are evenly spread: the mean of many is
    /// 1/2 and each tenth of the interval holds about a tenth of them.
    #[test]
    fn uniforms_are_uniform() {
        let n = 20_000u32;
        let mut bins = [0u32; 10];
        let mut sum = 0.0f64;
        for i in 0..n {
            let s = cell_seed(3, 0, 0, i, 0);
            let [a, b, c] = uniform3(s, i);
            let v = uniform2(s);
            for x in [a, b, c, v.x, v.y] {
                assert!((0.0..1.0).contains(&x));
                sum += x as f64;
                bins[(x * 10.0) as usize] += 1;
            }
        }
        let total = 5.0 * n as f64;
        assert!((sum / total - 0.5).abs() < 0.005, "{}", sum / total);
        for b in bins {
            assert!((b as f64 / total - 0.1).abs() < 0.005, "{bins:?}");
        }
    }

    #[test]
    fn cosine_directions_lie_in_the_hemisphere_with_mean_cosine_two_thirds() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(1);
        let k = 20000;
        let mut sum = 0.0;
        for _ in 0..k {
            let d = cosine_direction(n, Vec2::new(rng.random(), rng.random()));
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!(d.dot(n) >= 0.0);
            sum += d.dot(n) as f64;
        }
        // E[cos] under p = cos / pi is 2/3.
        assert!((sum / k as f64 - 2.0 / 3.0).abs() < 0.01, "{}", sum / k as f64);
    }

    /// Stratified points fall in the unit square, one in each stratum (4 x 4 for 16,
    /// 4 x 2 for 8, 3 columns for 3), and two points are half the torus apart in both
    /// coordinates.
    #[test]
    fn strata_hold_one_point_each_and_two_points_are_antipodes() {
        for (per, sx, sy) in [
            (16u32, 4u32, 4u32),
            (8, 4, 2),
            (4, 2, 2),
            (1, 1, 1),
            (3, 3, 1),
            (12, 12, 1),
        ] {
            let mut seen = vec![false; per as usize];
            for j in 0..per {
                let u = stratum(5, 3 << 8, j, per);
                assert!(
                    (0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y),
                    "per {per}: {u}"
                );
                let (i, l) = ((u.x * sx as f32) as u32, (u.y * sy as f32) as u32);
                assert!(
                    !seen[(l * sx + i) as usize],
                    "per {per}: stratum ({i}, {l}) twice"
                );
                seen[(l * sx + i) as usize] = true;
            }
        }
        for index in [0, 1 << 8, 7 << 8] {
            let (p, q) = (stratum(11, index, 0, 2), stratum(11, index, 1, 2));
            let d = (p - q).abs();
            assert!((d.x - 0.5).abs() < 1e-6 && (d.y - 0.5).abs() < 1e-6, "{p} {q}");
        }
    }

    /// Entries are drawn as often as their weights ask, and a zero weight never.
    #[test]
    fn alias_draws_follow_the_weights() {
        let w = [1.0, 0.0, 3.0, 0.5, 5.5, f64::NAN, 2.0];
        let t = Alias::new(&w).unwrap();
        let n = 600_000u32;
        let mut counts = [0u32; 7];
        for i in 0..n {
            let [a, b, c] = uniform3(shot_seed(9, i as u64), 0);
            counts[t.pick(a, b, c)] += 1;
        }
        let total = 12.0;
        for (k, &c) in counts.iter().enumerate() {
            let want = if w[k] > 0.0 { w[k] / total } else { 0.0 };
            assert!((t.probability(k) - want).abs() < 1e-12);
            let got = c as f64 / n as f64;
            assert!((got - want).abs() < 0.003, "entry {k}: {got} against {want}");
        }
        assert!(Alias::new(&[0.0, -1.0]).is_none());
    }
}
