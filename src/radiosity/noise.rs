//! How noisy the photons' light still is: the photons of each kind are dealt into
//! two halves by their chunk (even and odd), each half an estimate of all of that
//! kind's light on its own; where the two halves' estimates differ, the photons
//! have not settled. The solve stops tracing photons once the halves differ, on
//! the mean over the surfaces, by less than [`SETTLED`] of the light there.
//!
//! Measured against the same solve tracing all its photons (FLIP against Mitsuba,
//! two seeds): the glass bulb stops at 106 k of 2.36 M photons, 1.8 -> 0.68 s, FLIP
//! 0.0302 / 0.0300 -> 0.0305 / 0.0301; the Cornell box at 139 k of 596 k, FLIP
//! 0.0238 / 0.0239 -> 0.0240 / 0.0240; the frosted room at 311 k of 488 k, 0.0333 /
//! 0.0357 -> 0.0333 / 0.0363; the hall at 57 k of 280 k, 0.0288 / 0.0288 -> 0.0287 /
//! 0.0291 (a 512-spp reference); the glass window, the paper room and the classroom
//! (whose photons carry 30 % of the light over 229 k vertices) trace them all.
//! The mean is over all the surfaces: light that photons alone bring to a small
//! area (a glossy bowl's reflection) may stay noisier than 2 % there. Judged kind
//! by kind, over the vertices each reaches, the shots' photons on the bowl's and
//! the bulb's few square decimetres (15 % apart) held every solve to all its
//! photons for no change seen in FLIP.
//!
//! The mean cannot see a spike either: one photon that alone found a rare path
//! lights one small vertex many times its neighbours, and the blob it makes is as
//! large on the screen as the object is. So the photons do not stop while a vertex
//! is a [`SPIKE`]. A test scene (an open-air sky map, a rough plastic floor, a half
//! silver sphere): one sky photon off the floor onto a sphere vertex of 34 cm^2 had
//! stopped the solve at 16 k of 618 k photons with a blob ten times its neighbours';
//! now 491 k, the blob gone (FLIP 0.0905 -> 0.0841 against an 8192-spp Mitsuba
//! image). Every scene in `scenes/` stops where it did.

use super::photons::{Chunk, Deposit, KINDS};
use crate::scene::mean;

/// The photons stop once half the difference of the halves' light is, on the
/// area-weighted mean over the vertices that get light, under this fraction of the
/// vertex's light (shot and photons').
pub(super) const SETTLED: f32 = 0.02;

/// A vertex lit more than the mean over the surfaces, where one half's photons
/// brought more than this many times the light the other half's and the shots
/// did, is a spike: a few photons of a path the rest have not yet found (the sky
/// off a glossy floor onto a small sphere: one photon lit one of its vertices ten
/// times its neighbours). The photons have not settled while there is one: the
/// area-weighted mean cannot see it, whatever its size on the screen.
pub(super) const SPIKE: f32 = 4.0;

/// The photons traced before the halves are compared at all, per receiving vertex:
/// before that, most vertices have no deposit in either half, which would pass for
/// settled.
pub(super) const FIRST_PER_VERTEX: u64 = 8;

/// Per kind and half, the light (mean over the channels) each vertex got, and the
/// photons traced.
pub(super) struct Halves {
    light: Vec<[Vec<f32>; 2]>,
    traced: [[u64; 2]; KINDS],
}

impl Halves {
    pub(super) fn new(vertices: usize) -> Self {
        Halves {
            light: (0..KINDS)
                .map(|_| [vec![0.0; vertices], vec![0.0; vertices]])
                .collect(),
            traced: [[0; 2]; KINDS],
        }
    }

    /// Adds a chunk's deposits (of `photons` photons).
    pub(super) fn add(&mut self, chunk: Chunk, photons: u64, deposits: &[Deposit]) {
        let (k, h) = (chunk.kind as usize, (chunk.index % 2) as usize);
        self.traced[k][h] += photons;
        let light = &mut self.light[k][h];
        for d in deposits {
            if let Some(l) = light.get_mut(d.vertex as usize) {
                *l += mean(d.value);
            }
        }
    }

    /// The photons of each kind traced so far (both halves).
    pub(super) fn traced(&self) -> [u64; KINDS] {
        self.traced.map(|[a, b]| a + b)
    }

    /// The area-weighted mean over the vertices with light of half the difference
    /// between the halves' estimates over the vertex's light (`shot`: what the shots
    /// gave it; `counts`: the photons of each kind in all), or `None` while some kind
    /// has photons in one half only; 1 (unsettled) while a vertex is a [`SPIKE`].
    pub(super) fn noise(&self, counts: [u64; KINDS], shot: &[f32], area: &[f32]) -> Option<f32> {
        let mut scale = [[0.0f32; 2]; KINDS];
        for ((scale, &n), traced) in scale.iter_mut().zip(&counts).zip(&self.traced) {
            if n == 0 {
                continue;
            }
            for (s, &t) in scale.iter_mut().zip(traced) {
                if t == 0 {
                    return None;
                }
                // Each half stands for all of its kind's photons.
                *s = n as f32 / t as f32;
            }
        }
        // Per vertex: the two halves' estimates.
        let halves: Vec<(f32, f32)> = (0..shot.len())
            .map(|v| {
                let (mut x, mut y) = (0.0, 0.0);
                for (light, scale) in self.light.iter().zip(&scale) {
                    x += light[0][v] * scale[0];
                    y += light[1][v] * scale[1];
                }
                (x, y)
            })
            .collect();
        let (mut sum, mut weight, mut lit) = (0.0f64, 0.0f64, 0.0f64);
        for ((&s, &a), &(x, y)) in shot.iter().zip(area).zip(&halves) {
            let total = s + 0.5 * (x + y);
            if total > 0.0 && a > 0.0 {
                sum += f64::from(a * (0.5 * (x - y).abs() / total).min(1.0));
                weight += f64::from(a);
                lit += f64::from(a * total);
            }
        }
        if !(weight > 0.0) {
            return None;
        }
        let mean_light = (lit / weight) as f32;
        let spike = shot.iter().zip(area).zip(&halves).any(|((&s, &a), &(x, y))| {
            a > 0.0 && x.max(y) > SPIKE * (x.min(y) + s) && s + 0.5 * (x + y) > mean_light
        });
        Some(if spike { 1.0 } else { (sum / weight) as f32 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn deposit(vertex: u32, value: f32) -> Deposit {
        Deposit {
            vertex,
            slot: u8::MAX,
            source: None,
            value: Vec3::splat(value),
            caustic: false,
        }
    }

    /// Halves that agree are settled; halves of one kind that give one vertex 1 and
    /// 3 (its photons' light 2, half the difference 1) over shot light 2 leave that
    /// vertex's light a quarter uncertain; a kind with photons in one half only is
    /// not judged at all. Each half stands for all of its kind's photons.
    #[test]
    fn the_noise_is_half_the_halves_difference_over_the_light() {
        let counts = [4096, 0, 0];
        let (c0, c1) = (Chunk { kind: 0, index: 0 }, Chunk { kind: 0, index: 1 });
        let mut h = Halves::new(2);
        h.add(c0, 1024, &[deposit(0, 0.25), deposit(1, 0.5)]);
        assert_eq!(h.noise(counts, &[2.0, 1.0], &[1.0, 1.0]), None);
        h.add(c1, 1024, &[deposit(0, 0.75), deposit(1, 0.5)]);
        // Vertex 0: halves 1 and 3 (0.25 and 0.75 times 4096 / 1024): 1 / (2 + 2);
        // vertex 1: halves alike.
        let n = h.noise(counts, &[2.0, 1.0], &[1.0, 1.0]).unwrap();
        assert!((n - 0.125).abs() < 1e-6, "{n}");
        // Weighted by area.
        let n = h.noise(counts, &[2.0, 1.0], &[3.0, 1.0]).unwrap();
        assert!((n - 0.1875).abs() < 1e-6, "{n}");
        // A second kind that has photons but none traced in its second half.
        h.add(Chunk { kind: 1, index: 0 }, 10, &[deposit(0, 1.0)]);
        assert_eq!(h.noise([4096, 20, 0], &[2.0, 1.0], &[1.0, 1.0]), None);
    }

    /// A small vertex lit by one half's photons alone, above the mean light, holds
    /// the photons unsettled though the area-weighted mean is far under
    /// [`SETTLED`]; the same spike where the vertex stays dimmer than the mean, or
    /// matched by the other half, does not.
    #[test]
    fn one_halfs_spike_on_a_small_vertex_is_not_settled() {
        let counts = [4096, 0, 0];
        let (c0, c1) = (Chunk { kind: 0, index: 0 }, Chunk { kind: 0, index: 1 });
        let area = [1.0, 1.0, 0.01];
        let mut h = Halves::new(3);
        // Vertices 0 and 1: both halves 1 (0.25 times 4096 / 1024); vertex 2: 4 and 0.
        h.add(c0, 1024, &[deposit(0, 0.25), deposit(1, 0.25), deposit(2, 1.0)]);
        h.add(c1, 1024, &[deposit(0, 0.25), deposit(1, 0.25)]);
        // Vertex 2's light 0.5 + 2 against the mean (2 + 2 + 0.025) / 2.01, and its
        // halves 4 > 4 x (0 + 0.5): a spike.
        assert_eq!(h.noise(counts, &[1.0, 1.0, 0.5], &area), Some(1.0));
        // Shot light 0.1 and a quarter of the deposit: 0.6, under the mean. Its own
        // noise 0.5 / 0.6 weighs 0.01 of 2.01.
        let mut dim = Halves::new(3);
        dim.add(c0, 1024, &[deposit(0, 0.25), deposit(1, 0.25), deposit(2, 0.25)]);
        dim.add(c1, 1024, &[deposit(0, 0.25), deposit(1, 0.25)]);
        let n = dim.noise(counts, &[1.0, 1.0, 0.1], &area).unwrap();
        let want = 0.01 * (0.5 / 0.6) / 2.01;
        assert!((n - want).abs() < 1e-6, "{n} against {want}");
        // The other half finds vertex 2 too (1 against 4 over shot 0.5: 4 < 4 x 1.5).
        let mut matched = Halves::new(3);
        matched.add(c0, 1024, &[deposit(0, 0.25), deposit(1, 0.25), deposit(2, 1.0)]);
        matched.add(c1, 1024, &[deposit(0, 0.25), deposit(1, 0.25), deposit(2, 0.25)]);
        let n = matched.noise(counts, &[1.0, 1.0, 0.5], &area).unwrap();
        assert!(n < SETTLED, "{n}");
    }
}
