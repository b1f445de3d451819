//! Rough conductors (Mitsuba's `roughconductor`): the GGX and Beckmann microfacet
//! distributions with Smith's shadowing, a conductor's Fresnel reflectance, and the
//! lobe's evaluation and sampling, with Mitsuba 3's formulas (the types are the
//! scene's: [`Microfacet`], [`Fresnel`], [`Glossy`]). Directions are in the local
//! frame of the shading normal (+z).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use crate::scene::{Fresnel, Glossy, Microfacet, Rgb};

impl Microfacet {
    /// The density of normals `m` (unit, local frame) per unit projected area.
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (au, av) = (self.alpha_u, self.alpha_v);
        let c2 = m.z * m.z;
        let slope = (m.x / au).powi(2) + (m.y / av).powi(2);
        let d = if self.beckmann {
            (-slope / c2).exp() / (PI * au * av * c2 * c2)
        } else {
            1.0 / (PI * au * av * (slope + c2).powi(2))
        };
        if d.is_finite() && d > 1e-20 {
            d
        } else {
            0.0
        }
    }

    /// Smith's masking of direction `v` for microfacets of normal `m`.
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy = (self.alpha_u * v.x).powi(2) + (self.alpha_v * v.y).powi(2);
        let tan2 = xy / (v.z * v.z);
        if self.beckmann {
            let a = 1.0 / tan2.sqrt();
            if a >= 1.6 {
                1.0
            } else {
                (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
            }
        } else {
            2.0 / (1.0 + (1.0 + tan2).sqrt())
        }
    }

    /// Shadowing and masking of a pair of directions (separable Smith).
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.g1(wi, m) * self.g1(wo, m)
    }

    /// The dp/du that orients the distribution ([`Frame::with_tangent`]): `dpdu()`
    /// where it is anisotropic; zero otherwise, which keeps the frame from the normal
    /// alone (an isotropic distribution cannot tell one frame from another, and its
    /// sampled directions stay as they were), so a point's dp/du is found only where
    /// it matters.
    pub fn tangent(&self, dpdu: impl FnOnce() -> Vec3) -> Vec3 {
        if self.alpha_u == self.alpha_v {
            Vec3::ZERO
        } else {
            dpdu()
        }
    }

    /// The density per steradian of the normal `m` that [`Self::sample_visible`]
    /// draws for `wo` (local frame): `G1(wo, m) (wo.m) d(m) / wo.z`, from `g1_wo` =
    /// G1(wo, m) and `d_m` = d(m), which its callers' BSDFs have already found.
    pub fn pdf_m(&self, wo: Vec3, m: Vec3, g1_wo: f32, d_m: f32) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        g1_wo * wo.dot(m).max(0.0) * d_m / wo.z
    }

    /// What a direction `wi` leaving (by reflection or transmission) about a normal
    /// `m` drawn by [`Self::sample_visible`] for `wo` weighs, Fresnel term aside:
    /// `|wo.m| G d(m) / (wo.z pdf_m)` (Walter et al. 2007, eq. 41), that is
    /// `G(wo, wi) / G1(wo)`, at most one. Normals drawn by `d(m) cos(m)` instead
    /// weigh `|wo.m| G / (wo.z m.z)`, which grows without bound as `wo` turns
    /// grazing: a frosted ball's rim, a metal seen edge on, sparkled.
    pub fn weight(&self, wo: Vec3, wi: Vec3, m: Vec3) -> f32 {
        if !(wo.z > 0.0 && m.z > 0.0 && wo.dot(m) > 0.0) {
            return 0.0;
        }
        let g1 = self.g1(wo, m);
        if g1 > 0.0 {
            self.g(wo, wi, m) / g1
        } else {
            0.0
        }
    }
}

/// Fresnel reflectance of a conductor of complex index `eta + i k` (relative to the
/// outside) for light arriving at cosine `cos_i` (Mitsuba's `fresnel_conductor`).
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let t1 = eta * eta - k * k - s2;
    let a2b2 = (t1 * t1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2b2 + t1)).max(0.0).sqrt();
    let t2 = a2b2 + c2;
    let t3 = 2.0 * cos_i * a;
    let rs = (t2 - t3) / (t2 + t3);
    let t4 = a2b2 * c2 + s4;
    let t5 = t3 * s2;
    // (0 / 0 at normal incidence where eta = k = 0, as Mitsuba's data gives
    // AlSb's red channel: there p is s.)
    let rp = if t4 + t5 > 0.0 {
        rs * (t4 - t5) / (t4 + t5)
    } else {
        rs
    };
    0.5 * (rs + rp)
}

impl Fresnel {
    /// The reflectance at cosine `cos_i` between the light and the microfacet.
    pub fn at(&self, cos_i: f32) -> Rgb {
        let c = cos_i.clamp(0.0, 1.0);
        match *self {
            Fresnel::Conductor { eta, k } => Vec3::new(
                fresnel_conductor(c, eta.x, k.x),
                fresnel_conductor(c, eta.y, k.y),
                fresnel_conductor(c, eta.z, k.z),
            ),
            Fresnel::Schlick { f0 } => f0 + (Vec3::ONE - f0) * (1.0 - c).powi(5),
            Fresnel::Dielectric { eta } => Vec3::splat(super::fresnel_dielectric(c, eta)),
        }
    }

    /// At normal incidence.
    pub fn f0(&self) -> Rgb {
        self.at(1.0)
    }
}

/// The local frame of a lobe: a unit normal (+z) and two tangents about it, the first
/// (+x) the direction in which an anisotropic lobe's roughness is `alpha_u`.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    t: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Frame {
    /// The frame round unit normal `n`.
    pub fn new(n: Vec3) -> Self {
        let (t, b) = n.any_orthonormal_pair();
        Frame { t, b, n }
    }

    /// Mitsuba 3's shading frame round unit normal `n`: the first tangent is `dpdu`
    /// made normal to `n` (Gram-Schmidt), the second `n x` that; [`Frame::new`]'s
    /// where `dpdu` lies along `n` or is not finite.
    pub fn with_tangent(n: Vec3, dpdu: Vec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        match s.try_normalize() {
            Some(t) => Frame { t, b: n.cross(t), n },
            None => Self::new(n),
        }
    }

    /// The frame of `lobe` round unit shading normal `n`, `dpdu()` being dp/du at the
    /// point ([`Microfacet::tangent`]).
    pub fn of_lobe(lobe: &Glossy, n: Vec3, dpdu: impl FnOnce() -> Vec3) -> Self {
        Self::with_tangent(n, lobe.distribution.tangent(dpdu))
    }

    /// World direction `d` in the frame.
    pub fn local(&self, d: Vec3) -> Vec3 {
        Vec3::new(d.dot(self.t), d.dot(self.b), d.dot(self.n))
    }

    /// Local direction `v` in the world.
    pub fn world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

impl Glossy {
    /// [`Self::sample`] in world directions: a direction drawn for viewing direction
    /// `wo` at a surface whose shading frame is `frame` ([`Frame::of_lobe`]), with
    /// its weight.
    pub fn sample_in(&self, frame: &Frame, wo: Vec3, u: Vec2) -> Option<(Vec3, Rgb)> {
        let (wi, w) = self.sample(frame.local(wo), u)?;
        Some((frame.world(wi), w))
    }

    /// The BRDF (without the cosine) between `wi` and `wo`, local frame.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_pdf(wi, wo).0
    }

    /// The density (solid angle) of [`Self::sample`] giving `wi` from `wo`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_pdf(wi, wo).1
    }

    /// [`Self::eval`] and [`Self::pdf`] together (a light sample at a glossy hit
    /// wants both), the half vector's d(m) and G1(wo, m) found once.
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let m = (wi + wo).normalize();
        let d = self.distribution.d(m);
        if d == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let g1_wo = self.distribution.g1(wo, m);
        let g = self.distribution.g1(wi, m) * g1_wo;
        let value = self.scale * self.fresnel.at(wi.dot(m)) * (d * g / (4.0 * wi.z * wo.z));
        let pdf = self.distribution.pdf_m(wo, m, g1_wo, d) / (4.0 * wo.dot(m).abs());
        (value, pdf)
    }

    /// A direction `wi` drawn for viewing direction `wo` (local frame) from `u`, with
    /// its weight `eval * cos / pdf`; `None` below the surface.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<(Vec3, Rgb)> {
        if wo.z <= 0.0 {
            return None;
        }
        let m = self.distribution.sample_visible(wo, u);
        let wi = 2.0 * wo.dot(m) * m - wo;
        if !(wi.z > 0.0) {
            return None;
        }
        // eval * cos / pdf, with the distribution's d(m) and G1(wo) cancelled.
        let w = self.scale * self.fresnel.at(wi.dot(m)) * self.distribution.weight(wo, wi, m);
        (w.max_element() > 0.0 && w.is_finite()).then_some((wi, w))
    }

    /// The fraction of light from `wo` reflected over the hemisphere (estimated with
    /// `n` x `n` stratified samples of the lobe).
    pub fn albedo(&self, wo: Vec3, n: u32) -> Rgb {
        let mut sum = Vec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                if let Some((_, w)) = self.sample(wo, u) {
                    sum += w;
                }
            }
        }
        sum / (n * n) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    fn near(a: f32, b: f32, rel: f32) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-6)
    }

    /// D, G and G1 against Mitsuba 3's `MicrofacetDistribution` (scalar_rgb, sample
    /// visible normals off) at wi = (0.5, 0.3), wo = (1.1, 2.9) in (theta, phi).
    #[test]
    fn distributions_match_mitsuba() {
        let (wi, wo) = (dir(0.5, 0.3), dir(1.1, 2.9));
        let m = (wi + wo).normalize();
        for (beckmann, au, av, d, g, g1) in [
            (false, 0.1, 0.1, 0.141_476_48, 0.989_793_2, 0.999_255),
            (false, 0.3, 0.15, 0.354_955_73, 0.922_603_1, 0.993_802_3),
            (true, 0.1, 0.1, 3.036_45e-6, 1.0, 1.0),
            (true, 0.3, 0.15, 0.143_987_9, 1.0, 1.0),
        ] {
            let md = Microfacet {
                alpha_u: au,
                alpha_v: av,
                beckmann,
            };
            assert!(
                near(md.d(m), d, 2e-3),
                "{beckmann} {au} {av}: D {} vs {d}",
                md.d(m)
            );
            assert!(near(md.g(wi, wo, m), g, 1e-4), "G {} vs {g}", md.g(wi, wo, m));
            assert!(near(md.g1(wi, m), g1, 1e-4), "G1 {} vs {g1}", md.g1(wi, m));
        }
    }

    /// The conductor Fresnel term against Mitsuba's `fresnel_conductor` for the
    /// classroom's aluminium (eta 1.65746, k 9.22387), and a rough conductor's eval
    /// (times the cosine, as Mitsuba's `eval` returns it) against `roughconductor`'s.
    #[test]
    fn fresnel_and_the_lobe_match_mitsuba() {
        // At normal incidence, ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2): 0.04 for glass.
        assert!((fresnel_conductor(1.0, 1.5, 0.0) - 0.04).abs() < 1e-6);
        // eta = k = 0 (Mitsuba's AlSb in red) reflects everything, at every angle,
        // where the formula's p term is 0 / 0 at normal incidence.
        for c in [1.0, 0.5, 0.0] {
            assert_eq!(fresnel_conductor(c, 0.0, 0.0), 1.0, "{c}");
        }
        for (c, f) in [(1.0, 0.928_047_5), (0.5, 0.913_666), (0.1, 0.844_957_9)] {
            let v = fresnel_conductor(c, 1.65746, 9.22387);
            assert!(near(v, f, 1e-5), "{c}: {v} vs {f}");
        }
        let lobe = Glossy {
            distribution: Microfacet {
                alpha_u: 0.15,
                alpha_v: 0.15,
                beckmann: false,
            },
            fresnel: Fresnel::Conductor {
                eta: Vec3::splat(1.65746),
                k: Vec3::splat(9.22387),
            },
            scale: Vec3::ONE,
        };
        let wo = dir(0.5, 0.3);
        for (wi, want) in [
            (dir(0.6, 0.3 + PI), 3.028_08),
            (dir(0.55, 0.3 + PI + 0.1), 3.292_63),
        ] {
            let v = lobe.eval(wi, wo).x * wi.z;
            assert!(near(v, want, 2e-3), "{v} vs {want}");
        }
    }

    /// The fraction of light from `wo` that `lobe` reflects (first channel), by a
    /// midpoint quadrature in (cos theta, phi) over the hemisphere.
    fn reflected_by_quadrature(lobe: &Glossy, wo: Vec3) -> f32 {
        let n = 600;
        let mut q = 0.0;
        for i in 0..n {
            for j in 0..n {
                let ct = (i as f32 + 0.5) / n as f32;
                let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
                let st = (1.0 - ct * ct).sqrt();
                let wi = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                q += lobe.eval(wi, wo).x * ct;
            }
        }
        q * 2.0 * PI / (n * n) as f32
    }

    /// Seen at a grazing angle (80 degrees), the normals drawn as the view sees them
    /// weigh at most one with a Fresnel of 1, where normals drawn by d(m) cos(m)
    /// carried |wo.m| / (wo.z m.z), up to about 1 / wo.z = 5.8 (the sparkles of a
    /// frosted ball's rim); and the weights' mean is the lobe's albedo by a plain
    /// quadrature over the hemisphere, so the normals are drawn with the density the
    /// weights assume.
    #[test]
    fn visible_normals_weigh_at_most_one() {
        for beckmann in [false, true] {
            let lobe = Glossy {
                distribution: Microfacet {
                    alpha_u: 0.4,
                    alpha_v: 0.4,
                    beckmann,
                },
                fresnel: Fresnel::Schlick { f0: Vec3::ONE },
                scale: Vec3::ONE,
            };
            let wo = dir(1.4, 0.3);
            let (mut most, mut sum, mut drawn) = (0.0f32, 0.0f32, 0);
            for i in 0..64 {
                for j in 0..64 {
                    let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0);
                    if let Some((_, w)) = lobe.sample(wo, u) {
                        most = most.max(w.x);
                        sum += w.x;
                        drawn += 1;
                    }
                }
            }
            assert!(drawn > 2000, "{beckmann}: {drawn}");
            assert!(most <= 1.0 + 1e-3, "{beckmann}: {most}");
            let mean = sum / (64 * 64) as f32;
            let q = reflected_by_quadrature(&lobe, wo);
            assert!((mean - q).abs() < 0.01, "{beckmann}: {mean} vs {q}");
        }
    }

    /// The lobe's sampling weight is eval * cos / pdf (a sample's direction and
    /// weight checked against the two), and the white furnace: with a Fresnel of 1
    /// the reflected fraction is at most 1 and, for a smooth lobe seen from above,
    /// nearly 1 (single scattering loses a little at grazing angles and roughness);
    /// the estimate by sampling equals a plain quadrature over the hemisphere.
    #[test]
    fn sampling_weights_and_the_white_furnace() {
        for beckmann in [false, true] {
            for alpha in [0.05, 0.3, 0.7] {
                let lobe = Glossy {
                    distribution: Microfacet {
                        alpha_u: alpha,
                        alpha_v: alpha * 0.7,
                        beckmann,
                    },
                    fresnel: Fresnel::Schlick { f0: Vec3::ONE },
                    scale: Vec3::ONE,
                };
                for theta in [0.2f32, 0.8, 1.3] {
                    let wo = dir(theta, 0.4);
                    let (wi, w) = lobe.sample(wo, Vec2::new(0.3, 0.6)).unwrap();
                    let direct = lobe.eval(wi, wo) * wi.z / lobe.pdf(wo, wi);
                    assert!((w - direct).abs().max_element() < 1e-4 * direct.x);
                    let a = lobe.albedo(wo, 256).x;
                    assert!(a <= 1.0 + 1e-3, "{beckmann} {alpha} {theta}: {a}");
                    if alpha <= 0.05 && theta < 1.0 {
                        assert!(a > 0.98, "{beckmann} {alpha} {theta}: {a}");
                    }
                    let q = reflected_by_quadrature(&lobe, wo);
                    if alpha >= 0.3 {
                        assert!((q - a).abs() < 0.01, "{beckmann} {alpha} {theta}: {q} vs {a}");
                    }
                }
            }
        }
    }

    /// Mitsuba's shading frame: the first tangent is dp/du made normal to the normal,
    /// the second their cross product; an anisotropic lobe's `alpha_u` lies along
    /// dp/du, so light reflected along it is held to the sharp side of the lobe and
    /// light reflected across it spreads; an isotropic lobe keeps the frame chosen
    /// from the normal alone.
    #[test]
    fn an_anisotropic_lobe_lies_along_dpdu() {
        let f = Frame::with_tangent(Vec3::Z, Vec3::new(1.0, 1.0, 1.0));
        let s = Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!((f.world(Vec3::X) - s).length() < 1e-6, "{:?}", f.world(Vec3::X));
        assert!((f.world(Vec3::Y) - Vec3::new(-1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!((f.world(Vec3::Z) - Vec3::Z).length() < 1e-6);
        // dp/du along the normal: the frame from the normal alone.
        let g = Frame::with_tangent(Vec3::Z, Vec3::Z * 2.0);
        assert!((g.world(Vec3::X) - Frame::new(Vec3::Z).world(Vec3::X)).length() < 1e-6);
        let lobe = |au: f32, av: f32| Glossy {
            distribution: Microfacet {
                alpha_u: au,
                alpha_v: av,
                beckmann: false,
            },
            fresnel: Fresnel::Schlick { f0: Vec3::ONE },
            scale: Vec3::ONE,
        };
        // dp/du along world y; seen from the normal, light 20 degrees off it along y
        // (the u axis, alpha 0.05) and along x (the v axis, alpha 0.5).
        let brushed = lobe(0.05, 0.5);
        let frame = Frame::of_lobe(&brushed, Vec3::Z, || Vec3::Y);
        let wo = Vec3::Z;
        let tilt = 20f32.to_radians();
        let along_u = Vec3::new(0.0, tilt.sin(), tilt.cos());
        let along_v = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        let f_u = brushed.eval(frame.local(along_u), frame.local(wo)).x;
        let f_v = brushed.eval(frame.local(along_v), frame.local(wo)).x;
        // GGX at the half vector 10 degrees off: D(alpha 0.05) is 1e-3 of D(0.5).
        assert!(f_u < 0.01 * f_v, "{f_u} vs {f_v}");
        // Turning dp/du a quarter turn swaps them.
        let turned = Frame::of_lobe(&brushed, Vec3::Z, || Vec3::X);
        let g_u = brushed.eval(turned.local(along_v), turned.local(wo)).x;
        assert!((g_u - f_u).abs() <= 1e-6 * f_u.max(1e-12), "{g_u} vs {f_u}");
        // An isotropic lobe ignores dp/du.
        let round = lobe(0.2, 0.2);
        let a = Frame::of_lobe(&round, Vec3::Z, || Vec3::Y);
        let b = Frame::new(Vec3::Z);
        assert!((a.world(Vec3::X) - b.world(Vec3::X)).length() < 1e-7);
    }
}
