//! The shadow image buffer (SIB; paper Sect. 5, after Woodward 1990).
//!
//! For each image sample of the coarse levels, and each *light point* (a point or spot
//! light, or one sub-source of an area light or selected radiant patch), the SIB holds a
//! tri-state: unknown, lit or shadowed. A new sample decides each light point by the
//! paper's rule:
//!
//! ```text
//! for each light point L:
//!     if all already computed neighbouring SIB(L) are equal: take their value
//!     else: cast a shadow ray to L
//!     if not in anti-aliasing: SIB(L, sample) = the result
//! ```
//!
//! Here a record holds entries only for the sources ray traced on the sample's patch
//! (the others are unknown), in words of 64 light points, so the buffer's size follows
//! what the selection casts, not the number of sources in the scene. A light point
//! behind the surface gets neither a ray nor an entry. Neighbours count only if every
//! one of them hit the same object as the new sample: across an object boundary
//! shadows are not coherent, so every ray is cast there (the paper: "object boundaries
//! where we do not use the SIB").

use crate::sampling::Stratum;
use crate::scene::{Bsdf, BsdfKind, Rgb, TexField};
use glam::Vec3;
use half::f16;

/// "No object": a sample whose primary ray hit nothing.
pub const NO_OBJECT: u32 = u32::MAX;

/// The entries of one source in a sample's record, for light points
/// `64 * word .. 64 * word + 64` of the source: which are known, and which of the known
/// ones are lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// Index of the ray-traced source.
    pub source: u32,
    /// Which 64 light points of the source.
    pub word: u32,
    /// Bit k: light point `64 * word + k` is known.
    pub known: u64,
    /// Bit k: light point `64 * word + k` is lit (meaningful where known).
    pub lit: u64,
}

/// Bits `[a, b)` of the 64-bit word `w` (light points numbered within a source).
fn word_mask(w: u32, a: u32, b: u32) -> u64 {
    if b <= 64 * w || a >= 64 * w + 64 {
        return 0;
    }
    let lo = a.max(64 * w) - 64 * w;
    let hi = b.min(64 * w + 64) - 64 * w;
    if hi <= lo {
        0
    } else if hi - lo == 64 {
        u64::MAX
    } else {
        ((1u64 << (hi - lo)) - 1) << lo
    }
}

/// The words `[a, b)` spans.
fn words(a: u32, b: u32) -> std::ops::RangeInclusive<u32> {
    a / 64..=(b.max(a + 1) - 1) / 64
}

/// The value of light points `[a, b)` of `source` in a record, if all are known and
/// equal.
pub fn value(record: &[Entry], source: u32, a: u32, b: u32) -> Option<bool> {
    let mut out = None;
    for w in words(a, b) {
        let m = word_mask(w, a, b);
        let e = record.iter().find(|e| e.source == source && e.word == w)?;
        if e.known & m != m {
            return None;
        }
        let v = match e.lit & m {
            0 => false,
            x if x == m => true,
            _ => return None,
        };
        if out.is_some_and(|o| o != v) {
            return None;
        }
        out = Some(v);
    }
    out
}

/// Sets light points `[a, b)` of `source` to `lit` in a record being built.
pub fn set(record: &mut Vec<Entry>, source: u32, a: u32, b: u32, lit: bool) {
    for w in words(a, b) {
        let m = word_mask(w, a, b);
        let e = match record.iter().position(|e| e.source == source && e.word == w) {
            Some(i) => &mut record[i],
            None => {
                record.push(Entry {
                    source,
                    word: w,
                    known: 0,
                    lit: 0,
                });
                record.last_mut().expect("just pushed")
            }
        };
        e.known |= m;
        e.lit = if lit { e.lit | m } else { e.lit & !m };
    }
}

/// The paper's rule for light points `[a, b)` of `source`: the common value of the
/// neighbours' records, if every neighbour knows them all and all agree; `None`
/// (cast a ray) otherwise, and when there is no neighbour.
pub fn agree(neighbours: &[Neighbour], source: u32, a: u32, b: u32) -> Option<bool> {
    let (first, rest) = neighbours.split_first()?;
    let v = value(first.record, source, a, b)?;
    rest.iter()
        .all(|n| value(n.record, source, a, b) == Some(v))
        .then_some(v)
}

/// An already computed neighbouring sample, as the SIB sees it.
#[derive(Debug, Clone, Copy)]
pub struct Neighbour<'a> {
    /// The object (shape) its primary ray hit, or [`NO_OBJECT`].
    pub object: u32,
    /// Its record.
    pub record: &'a [Entry],
}

/// The SIB as one primary ray's first diffuse hit uses it.
#[derive(Debug)]
pub struct SibQuery<'a> {
    /// Whether neighbours' values are reused (`--sib on`). Off, every shadow ray is
    /// cast, but the record is still filled (for pictures and the shadow criterion).
    pub reuse: bool,
    /// The already computed neighbouring samples (coarser levels).
    pub neighbours: &'a [Neighbour<'a>],
    /// This sample's record, filled by the shading (the caller clears it).
    pub record: &'a mut Vec<Entry>,
    /// Set by the shading: the object the primary ray hit ([`NO_OBJECT`] if none).
    pub object: u32,
    /// The selection's shadow rays per hit to an area source are divided by this (at
    /// least four are cast, or all if fewer): 1 at the stored levels and with the SIB
    /// off, `4^L` at anti-aliasing level L (see [`super::adaptive`]).
    pub ray_divisor: u32,
    /// Which of its pixel's samples at its level this one is: the level's samples
    /// together spread their light points over each group.
    pub stratum: Stratum,
    /// Set by the shading: the first hit's diffuse light, where its texture alone
    /// scales it (see [`Lighting`]).
    pub lighting: Option<Lighting>,
    /// Set by the sampler for a retextured sample: the light samples near it found,
    /// on up to two objects (a pixel across an object's edge); a first hit on one of
    /// those objects, facing the same way, takes it through its own texel.
    pub given: [Option<Given>; 2],
}

/// The light a retextured sample is given (see [`Lighting`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Given {
    /// The object it was found on.
    pub object: u32,
    /// The diffuse light per unit albedo.
    pub per_albedo: Rgb,
    /// The shading normal where it was found.
    pub normal: Vec3,
    /// The rest of the light (glossy, mirror), if taken too; `None`: traced anew.
    pub rest: Option<Rgb>,
}

impl<'a> SibQuery<'a> {
    /// A query with the given neighbours and output record.
    pub fn new(reuse: bool, neighbours: &'a [Neighbour<'a>], record: &'a mut Vec<Entry>) -> Self {
        record.clear();
        SibQuery {
            reuse,
            neighbours,
            record,
            object: NO_OBJECT,
            ray_divisor: 1,
            stratum: Stratum::WHOLE,
            lighting: None,
            given: [None; 2],
        }
    }

    /// Whether the neighbours may be used at a hit on `object`: SIB on, at least one
    /// neighbour, and every neighbour on the same object.
    pub fn usable(&self, object: u32) -> bool {
        self.reuse && !self.neighbours.is_empty() && self.neighbours.iter().all(|n| n.object == object)
    }
}

/// A primary hit's diffuse light as its texture scales it: where only the diffuse
/// reflectance of a (rough) plastic or diffuse material is textured, the diffuse part
/// of the radiance is the texel times light that does not depend on it (the
/// radiosity's texture ratio, the gather's and the light samples' BRDF are all linear
/// in it), so a sample nearby with another texel has `diffuse / albedo` times its own
/// albedo, and the rest (glossy, mirror) unchanged. Kept in half floats (relative
/// error 2^-11), 12 bytes beside every sample of the adaptive sampler: in f32 its 24
/// took the staircase's peak memory at 720 x 1280 from 1.09 to 1.42 GB (1.20 in f16,
/// 1.10 once samples no longer kept their display values).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lighting {
    /// The diffuse albedo at the hit (the texel, through the material's model).
    albedo: [f16; 3],
    /// The diffuse light per unit albedo.
    per_albedo: [f16; 3],
    /// The shading normal at the hit, each coordinate in 1/127ths.
    normal: [i8; 3],
}

/// A kept light is given only to a hit whose shading normal is within this cosine
/// (about 11 degrees) of the normal it was found at: the light of a surface turned
/// another way (the other face of a box, a slab's edge) is another light, which the
/// samples that agreed on it need not have seen.
pub const NORMAL_AGREES: f32 = 0.98;

impl Lighting {
    /// The diffuse part `diffuse` at a hit on `bsdf` (of model `kind` there, shading
    /// normal `normal`), if its texture alone scales it: no texture, or textures on
    /// the diffuse reflectance only (no bump, mask, blend weight or specular
    /// texture), and an albedo above 0 in every channel (a black texel scales nothing
    /// back).
    pub fn of(bsdf: &Bsdf, kind: &BsdfKind, diffuse: Rgb, normal: Vec3) -> Option<Lighting> {
        Lighting::applies(bsdf, kind).then(|| Lighting::new(kind.diffuse_albedo(), diffuse, normal))?
    }

    /// Whether the texture alone scales the diffuse light at a hit on `bsdf` (of
    /// model `kind` there): no texture, or textures on the diffuse reflectance only,
    /// of a diffuse or (rough) plastic model.
    pub fn applies(bsdf: &Bsdf, kind: &BsdfKind) -> bool {
        bsdf.textures
            .iter()
            .all(|t| t.field == TexField::Diffuse && t.path.is_empty())
            && matches!(
                kind,
                BsdfKind::Diffuse { .. } | BsdfKind::Plastic { .. } | BsdfKind::RoughPlastic { .. }
            )
    }

    /// Albedo `albedo` and diffuse light `diffuse` at shading normal `normal` (unit),
    /// if half floats hold them (the albedo above 0 in every channel, the light per
    /// unit albedo finite).
    pub fn new(albedo: Rgb, diffuse: Rgb, normal: Vec3) -> Option<Lighting> {
        let half = |v: Rgb| v.to_array().map(f16::from_f32);
        let l = Lighting {
            albedo: half(albedo),
            per_albedo: half(diffuse / albedo),
            normal: normal
                .to_array()
                .map(|c| (c.clamp(-1.0, 1.0) * 127.0).round() as i8),
        };
        (l.albedo().min_element() > 0.0 && l.per_albedo().is_finite()).then_some(l)
    }

    /// The diffuse albedo at the hit.
    pub fn albedo(&self) -> Rgb {
        Vec3::from_array(self.albedo.map(f16::to_f32))
    }

    /// The diffuse light per unit albedo.
    pub fn per_albedo(&self) -> Rgb {
        Vec3::from_array(self.per_albedo.map(f16::to_f32))
    }

    /// The shading normal at the hit (unit, within 0.5 degrees).
    pub fn normal(&self) -> Vec3 {
        Vec3::from_array(self.normal.map(|c| f32::from(c) / 127.0)).normalize_or_zero()
    }

    /// The diffuse part of the radiance.
    pub fn diffuse(&self) -> Rgb {
        self.albedo() * self.per_albedo()
    }
}

/// Which point and spot lights a sample knows, and which of those are lit, for the
/// shadow criterion of the adaptive sampler: `slot[s]` is source s's place among the
/// point and spot lights (`None` for other sources); `out` (zeroed) gets the known
/// words, then as many lit words, bit `k % 64` of word `k / 64` for place k.
pub fn point_bits(record: &[Entry], slot: &[Option<u32>], out: &mut [u64]) {
    let words = out.len() / 2;
    for e in record {
        let Some(Some(k)) = slot.get(e.source as usize) else {
            continue;
        };
        let (w, bit) = (*k as usize / 64, 1u64 << (k % 64));
        if e.word == 0 && e.known & 1 != 0 && w < words {
            out[w] |= bit;
            if e.lit & 1 != 0 {
                out[words + w] |= bit;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No texture, or only a texture on the diffuse reflectance, of a diffuse or
    /// plastic model, with every channel above 0, scales the diffuse light alone; the
    /// normal is kept within half a degree.
    #[test]
    fn lighting_is_kept_where_the_texel_alone_scales_the_diffuse_light() {
        use crate::testutil::slot;
        let rho = glam::Vec3::new(0.5, 0.4, 0.3);
        let diffuse = BsdfKind::Diffuse { reflectance: rho };
        let bsdf = |fields: &[TexField]| Bsdf {
            name: "b".into(),
            kind: diffuse.clone(),
            twosided: false,
            textures: fields.iter().map(|&f| slot(f, 0)).collect(),
        };
        let light = glam::Vec3::new(0.1, 0.2, 0.3);
        let n = glam::Vec3::new(0.36, -0.48, 0.8);
        let l = Lighting::of(&bsdf(&[TexField::Diffuse]), &diffuse, light * rho, n).unwrap();
        // Within half floats' rounding.
        assert!(((l.per_albedo() - light) / light).abs().max_element() < 1e-3);
        assert!(((l.albedo() - rho) / rho).abs().max_element() < 1e-3);
        assert!(((l.diffuse() - light * rho) / (light * rho)).abs().max_element() < 2e-3);
        assert!(l.normal().dot(n) > 0.99996, "{}", l.normal());
        // Light past what half floats hold is not kept.
        assert_eq!(Lighting::new(rho, glam::Vec3::splat(1e6), n), None);
        let plain = Lighting::of(&bsdf(&[]), &diffuse, light * rho, n).expect("untextured");
        assert!(((plain.per_albedo() - light) / light).abs().max_element() < 1e-3);
        let mirror = BsdfKind::Conductor {
            specular_reflectance: glam::Vec3::ONE,
            fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
        };
        assert_eq!(Lighting::of(&bsdf(&[]), &mirror, light, n), None, "a metal");
        for other in [
            TexField::Bump(Default::default()),
            TexField::Normal(Default::default()),
            TexField::Opacity,
            TexField::Specular,
        ] {
            let b = bsdf(&[TexField::Diffuse, other]);
            assert_eq!(Lighting::of(&b, &diffuse, light, n), None, "{other:?}");
        }
        let mut blended = bsdf(&[TexField::Diffuse]);
        blended.textures[0].path = vec![true];
        assert_eq!(Lighting::of(&blended, &diffuse, light, n), None, "inside a blend");
        let black = BsdfKind::Diffuse {
            reflectance: glam::Vec3::new(0.5, 0.0, 0.3),
        };
        assert_eq!(
            Lighting::of(&bsdf(&[TexField::Diffuse]), &black, light, n),
            None,
            "black channel"
        );
    }

    fn rec(entries: &[(u32, u32, bool)]) -> Vec<Entry> {
        let mut r = Vec::new();
        for &(s, p, lit) in entries {
            set(&mut r, s, p, p + 1, lit);
        }
        r
    }

    #[test]
    fn masks_cover_exactly_the_range() {
        assert_eq!(word_mask(0, 0, 64), u64::MAX);
        assert_eq!(word_mask(0, 3, 5), 0b11000);
        assert_eq!(word_mask(1, 60, 70), 0b11_1111);
        assert_eq!(word_mask(0, 60, 70), 0xF << 60);
        assert_eq!(word_mask(2, 60, 70), 0);
        assert_eq!(words(60, 70), 0..=1);
        assert_eq!(words(0, 64), 0..=0);
    }

    #[test]
    fn set_and_value_round_trip_across_words() {
        let mut r = Vec::new();
        set(&mut r, 3, 0, 100, true);
        assert_eq!(r.len(), 2);
        assert_eq!(value(&r, 3, 0, 100), Some(true));
        assert_eq!(value(&r, 3, 99, 100), Some(true));
        assert_eq!(value(&r, 3, 100, 101), None, "never set: unknown");
        assert_eq!(value(&r, 2, 0, 1), None, "other source: unknown");
        set(&mut r, 3, 10, 12, false);
        assert_eq!(value(&r, 3, 10, 12), Some(false));
        assert_eq!(value(&r, 3, 8, 12), None, "mixed: no single value");
        assert_eq!(value(&r, 3, 0, 10), Some(true));
    }

    #[test]
    fn neighbours_must_all_know_and_agree() {
        let lit = rec(&[(0, 0, true)]);
        let lit2 = rec(&[(0, 0, true), (1, 5, false)]);
        let dark = rec(&[(0, 0, false)]);
        let none = rec(&[]);
        let n = |r: &'static [Entry]| Neighbour { object: 1, record: r };
        let (lit, lit2, dark, none) = (lit.leak(), lit2.leak(), dark.leak(), none.leak());
        assert_eq!(agree(&[n(lit), n(lit2)], 0, 0, 1), Some(true));
        assert_eq!(agree(&[n(lit), n(dark)], 0, 0, 1), None);
        assert_eq!(agree(&[n(lit), n(none)], 0, 0, 1), None, "unknown disagrees");
        assert_eq!(agree(&[n(dark)], 0, 0, 1), Some(false));
        assert_eq!(agree(&[], 0, 0, 1), None, "no neighbour: cast");
        assert_eq!(agree(&[n(lit2)], 1, 5, 6), Some(false));
    }

    #[test]
    fn the_sib_is_usable_only_on_the_neighbours_object() {
        let r: Vec<Entry> = Vec::new();
        let ns = [
            Neighbour {
                object: 2,
                record: &r,
            },
            Neighbour {
                object: 2,
                record: &r,
            },
        ];
        let mut out = Vec::new();
        let q = SibQuery::new(true, &ns, &mut out);
        assert!(q.usable(2));
        assert!(!q.usable(3));
        let mixed = [
            ns[0],
            Neighbour {
                object: 5,
                record: &r,
            },
        ];
        let mut out = Vec::new();
        assert!(!SibQuery::new(true, &mixed, &mut out).usable(2));
        let mut out = Vec::new();
        assert!(!SibQuery::new(false, &ns, &mut out).usable(2), "sib off");
        let mut out = Vec::new();
        assert!(!SibQuery::new(true, &[], &mut out).usable(2), "no neighbours");
    }

    #[test]
    fn point_bits_pick_the_point_lights_first_light_point() {
        let r = rec(&[(0, 0, true), (1, 0, false), (2, 7, true), (3, 0, true)]);
        let slot = [Some(0), Some(1), None, None];
        let mut out = [0u64; 2];
        point_bits(&r, &slot, &mut out);
        assert_eq!(out, [0b11, 0b01]);
    }

    /// Every point light has its bit, not only the first 64 sources.
    #[test]
    fn point_bits_reach_past_64_lights() {
        let r = rec(&[(3, 0, true), (69, 0, false), (130, 0, true)]);
        let mut slot = vec![None; 131];
        for (s, k) in [(3, 0), (69, 65), (130, 128)] {
            slot[s] = Some(k);
        }
        let mut out = [0u64; 6];
        point_bits(&r, &slot, &mut out);
        assert_eq!(out, [0b1, 0b10, 0b1, 0b1, 0, 0b1]);
    }
}
