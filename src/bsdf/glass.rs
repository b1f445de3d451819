//! Glass (Mitsuba 3's `dielectric` and `thindielectric`): a smooth interface that
//! splits a ray into its mirror reflection and its transmission, weighted by the
//! Fresnel reflectance. Thick glass bends the transmitted ray by Snell's law and
//! scales radiance by the squared ratio of the indices (radiance mode); a thin pane
//! lets it through unbent, with the light reflected back and forth between its two
//! faces summed into the reflection.

use glam::{Vec2, Vec3};

use super::fresnel_dielectric;
use super::microfacet::Frame;
use crate::scene::{BsdfKind, Microfacet, Rgb};

/// What glass does to a ray that meets it: the weights of its reflection and of its
/// transmission, and the transmission's direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split {
    /// Weight of the mirror reflection (about the normal on the ray's side).
    pub reflect: Rgb,
    /// Weight of the transmitted ray's radiance (zero at total internal reflection).
    pub transmit: Rgb,
    /// The share of power transmitted (`transmit` without the radiance's scaling by
    /// the squared index ratio: what a photon carries on).
    pub power: Rgb,
    /// Direction of the transmitted ray (unit).
    pub dir: Vec3,
}

/// A ray's split at glass about the normal it meets: the shading normal of smooth
/// glass, or a microfacet normal of rough glass ([`BsdfKind::facet`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Facet {
    /// The split about the facet (its reflection is about [`Facet::m`]).
    pub split: Split,
    /// The facet's normal, on the ray's side.
    pub m: Vec3,
    /// The shading normal, on the ray's side.
    n: Vec3,
    /// dp/du, which orients an anisotropic distribution (zero: the frame from the
    /// normal alone, [`Frame::with_tangent`]).
    dpdu: Vec3,
    /// Rough glass's distribution.
    rough: Option<Microfacet>,
}

impl Facet {
    /// What a ray leaving along `wi` (unit) weighs, beside its split's weight, for a
    /// ray that arrived along `-wo`: 1 on smooth glass; on rough glass the facet's
    /// [`Microfacet::weight`] (Walter et al. 2007, eq. 41; facets drawn as `wo` sees
    /// them, as Mitsuba 3's `roughdielectric` does by default).
    pub fn weight(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(d) = self.rough else {
            return 1.0;
        };
        let f = Frame::with_tangent(self.n, self.dpdu);
        d.weight(f.local(wo), f.local(wi), f.local(self.m))
    }
}

impl BsdfKind {
    /// The dp/du that orients rough glass's facets ([`Microfacet::tangent`]; zero for
    /// any other glass).
    pub fn glass_dpdu(&self, dpdu: impl FnOnce() -> Vec3) -> Vec3 {
        match self {
            BsdfKind::Dielectric {
                rough: Some(d),
                thin: false,
                ..
            } => d.tangent(dpdu),
            _ => Vec3::ZERO,
        }
    }

    /// The facet a ray arriving along `-wo` meets on glass of shading normal `ns`
    /// (unit, outward): on rough glass a microfacet normal drawn from `u` by
    /// [`Microfacet::sample_visible`] about the normal on the ray's side, else that
    /// normal; with the split about it. An anisotropic distribution's `alpha_u` lies
    /// along `dpdu` ([`BsdfKind::glass_dpdu`]; zero for any other). `None` if the
    /// material is not glass, or the facet drawn faces away from the ray.
    pub fn facet(&self, wo: Vec3, ns: Vec3, dpdu: Vec3, u: Vec2) -> Option<Facet> {
        let BsdfKind::Dielectric { rough, thin, .. } = self else {
            return None;
        };
        let outside = wo.dot(ns) >= 0.0;
        let n = if outside { ns } else { -ns };
        let (m, rough) = match rough {
            Some(d) if !thin => {
                let frame = Frame::with_tangent(n, dpdu);
                let m = frame.world(d.sample_visible(frame.local(wo), u)).normalize();
                if !(wo.dot(m) > 0.0) {
                    return None;
                }
                (m, Some(*d))
            }
            _ => (n, None),
        };
        let split = self.split(wo, if outside { m } else { -m })?;
        Some(Facet {
            split,
            m,
            n,
            dpdu,
            rough,
        })
    }

    /// Rough glass's BSDF (for radiance) from `wi` to `wo` (unit; either side) at
    /// shading normal `ns` (unit, outward), and the density per steradian with which
    /// [`Self::facet`] sends a ray along `wi` (its reflection or its transmission, as
    /// `wi` lies): Walter et al. (2007), eq. 20 and 21, the transmission for radiance
    /// (the squared index ratio divided out), with the densities of eq. 14 and 17
    /// over the facets' [`Microfacet::pdf_m`], in the frame [`Self::facet`] draws
    /// in (`dpdu` as there). `None` if the material is not rough glass.
    pub fn rough_glass_eval(&self, wo: Vec3, wi: Vec3, ns: Vec3, dpdu: Vec3) -> Option<(Rgb, f32)> {
        let BsdfKind::Dielectric {
            eta,
            specular_reflectance,
            specular_transmittance,
            thin: false,
            rough: Some(d),
        } = self
        else {
            return None;
        };
        let none = Some((Vec3::ZERO, 0.0));
        let outside = wo.dot(ns) >= 0.0;
        let n = if outside { ns } else { -ns };
        let eta = if outside { *eta } else { 1.0 / eta };
        let frame = Frame::with_tangent(n, dpdu);
        let (o, i) = (frame.local(wo), frame.local(wi));
        if !(o.z > 0.0) || i.z == 0.0 {
            return none;
        }
        let (value, pdf) = if i.z > 0.0 {
            let h = (o + i).normalize();
            let oh = o.dot(h);
            if !(oh > 0.0) {
                return none;
            }
            let (dh, g1o) = (d.d(h), d.g1(o, h));
            let f = fresnel_dielectric(oh, eta) * dh * (d.g1(i, h) * g1o) / (4.0 * o.z * i.z);
            (*specular_reflectance * f, d.pdf_m(o, h, g1o, dh) / (4.0 * oh))
        } else {
            let h = (o + i * eta).normalize();
            let h = if h.z < 0.0 { -h } else { h };
            let (oh, ih) = (o.dot(h), i.dot(h));
            if !(oh > 0.0 && ih < 0.0) {
                return none;
            }
            let den = oh + eta * ih;
            let (dh, g1o) = (d.d(h), d.g1(o, h));
            let f = (1.0 - fresnel_dielectric(oh, eta)) * dh * (d.g1(i, h) * g1o) * (ih * oh).abs()
                / (-i.z * o.z * den * den);
            (
                *specular_transmittance * f,
                d.pdf_m(o, h, g1o, dh) * eta * eta * ih.abs() / (den * den),
            )
        };
        if value.is_finite() && pdf.is_finite() {
            Some((value, pdf))
        } else {
            none
        }
    }
}

/// The direction refracted from `wi` (unit, pointing away from the surface on the
/// side of `n`, unit) into the other side, with relative index `eta` = index of the
/// far side over that of `wi`'s side; `None` at total internal reflection.
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wi.dot(n);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wi / eta + n * (cos_i / eta - cos_t)).normalize())
}

/// The reflectance of a thin pane of relative index `eta` at cosine `cos`: one face's
/// Fresnel reflectance `r` plus the light reflected between the faces, `2r / (1 + r)`
/// (Mitsuba's `thindielectric`, no absorption inside).
pub fn thin_reflectance(cos: f32, eta: f32) -> f32 {
    let r = fresnel_dielectric(cos, eta);
    if r < 1.0 {
        2.0 * r / (1.0 + r)
    } else {
        1.0
    }
}

impl BsdfKind {
    /// Clear glass of relative index `eta`, thick or a thin pane (Mitsuba's defaults
    /// for the reflectance and transmittance scales: 1).
    pub fn clear_glass(eta: f32, thin: bool) -> BsdfKind {
        BsdfKind::Dielectric {
            eta,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
            thin,
            rough: None,
        }
    }

    /// Whether the material is rough glass (`roughdielectric`).
    pub fn is_rough_glass(&self) -> bool {
        matches!(
            self,
            BsdfKind::Dielectric {
                rough: Some(_),
                thin: false,
                ..
            }
        )
    }

    /// Whether the material is glass (reflects and transmits).
    pub fn is_glass(&self) -> bool {
        matches!(self, BsdfKind::Dielectric { .. })
    }

    /// Whether the material is thick glass (`dielectric`, `roughdielectric`): a
    /// surface of a solid whose inside is glass.
    pub fn is_thick_glass(&self) -> bool {
        matches!(self, BsdfKind::Dielectric { thin: false, .. })
    }

    /// Whether shadow rays pass through the material (a thin pane), and with what
    /// share of the light at cosine `cos` to its normal; `None` if it stops them.
    pub fn shadow_transmittance(&self, cos: f32) -> Option<f32> {
        match self {
            BsdfKind::Dielectric {
                eta,
                specular_transmittance,
                thin: true,
                ..
            } => {
                Some((1.0 - thin_reflectance(cos.abs(), *eta)) * crate::scene::mean(*specular_transmittance))
            }
            _ => None,
        }
    }

    /// The share of light a ray carries on through one face of glass at cosine `cos`
    /// to its normal as if unbent: a thin pane's transmittance, or thick glass's
    /// Fresnel transmittance of the face (the same on both faces of a pane, whose
    /// parallel faces leave the ray's direction as it was); `None` if the material is
    /// not glass.
    pub fn straight_transmittance(&self, cos: f32) -> Option<f32> {
        match self {
            BsdfKind::Dielectric { thin: true, .. } => self.shadow_transmittance(cos),
            BsdfKind::Dielectric {
                eta,
                specular_transmittance,
                ..
            } => Some(
                (1.0 - fresnel_dielectric(cos.abs(), *eta)) * crate::scene::mean(*specular_transmittance),
            ),
            _ => None,
        }
    }

    /// What glass does to a ray arriving along `-wo` at a surface of shading normal
    /// `ns` (unit; `wo` on either side): `None` if the material is not glass.
    pub fn split(&self, wo: Vec3, ns: Vec3) -> Option<Split> {
        let BsdfKind::Dielectric {
            eta,
            specular_reflectance,
            specular_transmittance,
            thin,
            ..
        } = self
        else {
            return None;
        };
        let cos = wo.dot(ns);
        // The normal on the ray's side, and the index across (far over near).
        let (n, eta_t) = if cos >= 0.0 { (ns, *eta) } else { (-ns, 1.0 / eta) };
        let cos = cos.abs();
        if *thin {
            let r = thin_reflectance(cos, *eta);
            let transmit = *specular_transmittance * (1.0 - r);
            return Some(Split {
                reflect: *specular_reflectance * r,
                transmit,
                power: transmit,
                dir: -wo,
            });
        }
        let r = fresnel_dielectric(cos, eta_t);
        let (power, dir) = match refract(wo, n, eta_t) {
            Some(d) if r < 1.0 => (*specular_transmittance * (1.0 - r), d),
            _ => (Vec3::ZERO, -wo),
        };
        Some(Split {
            reflect: *specular_reflectance * r,
            // Radiance across the interface scales by the inverse squared index ratio.
            transmit: power / (eta_t * eta_t),
            power,
            dir,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glass(thin: bool) -> BsdfKind {
        BsdfKind::clear_glass(1.5, thin)
    }

    /// Clear rough glass of relative index 1.5 and roughness `alpha_u`, `alpha_v`.
    fn rough_glass(alpha_u: f32, alpha_v: f32, beckmann: bool) -> BsdfKind {
        BsdfKind::Dielectric {
            eta: 1.5,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
            thin: false,
            rough: Some(Microfacet {
                alpha_u,
                alpha_v,
                beckmann,
            }),
        }
    }

    /// Rough glass (GGX and Beckmann, alpha 0.3, relative index 1.5), met from outside
    /// at 0 and 50 degrees and from inside at 25: the mean weights of the reflected and
    /// the transmitted rays over many facets drawn ([`BsdfKind::facet`]) are the
    /// integrals over the hemispheres of Walter et al.'s (2007) microfacet BRDF, F D G
    /// / (4 |cos i| |cos o|), and BTDF for radiance, (1 - F) D G |i.h| |o.h| / (|cos
    /// i| |cos o| (o.h + eta i.h)^2), times the cosine, by quadrature.
    #[test]
    fn rough_glass_reflects_and_transmits_as_the_microfacet_bsdf_integrates() {
        use crate::sampling::uniform3;
        for beckmann in [false, true] {
            let d = Microfacet {
                alpha_u: 0.3,
                alpha_v: 0.3,
                beckmann,
            };
            let kind = BsdfKind::Dielectric {
                eta: 1.5,
                specular_reflectance: Vec3::ONE,
                specular_transmittance: Vec3::ONE,
                thin: false,
                rough: Some(d),
            };
            for (deg, outside) in [(0.0f32, true), (50.0, true), (25.0, false)] {
                let th = deg.to_radians();
                // Local frame: the normal on the ray's side is +z.
                let wo = Vec3::new(th.sin(), 0.0, th.cos());
                let ns = if outside { Vec3::Z } else { -Vec3::Z };
                let eta = if outside { 1.5f32 } else { 1.0 / 1.5 };
                // Sampled.
                let n = 400_000;
                let (mut r_mean, mut t_mean) = (0.0f64, 0.0f64);
                for k in 0..n {
                    let [u, v, _] = uniform3(17, k);
                    let Some(f) = kind.facet(wo, ns, Vec3::ZERO, Vec2::new(u, v)) else {
                        continue;
                    };
                    let wr = 2.0 * wo.dot(f.m) * f.m - wo;
                    r_mean += f64::from(f.split.reflect.x * f.weight(wo, wr));
                    if f.split.transmit.x > 0.0 {
                        t_mean += f64::from(f.split.transmit.x * f.weight(wo, f.split.dir));
                    }
                }
                r_mean /= n as f64;
                t_mean /= n as f64;
                // Quadrature over directions wi (uniform in cos theta and phi).
                let (nc, np) = (3000, 720);
                let (mut r_int, mut t_int) = (0.0f64, 0.0f64);
                for i in 0..nc {
                    for j in 0..np {
                        let c = (i as f32 + 0.5) / nc as f32;
                        let phi = (j as f32 + 0.5) / np as f32 * std::f32::consts::TAU;
                        let sn = (1.0 - c * c).sqrt();
                        let up = Vec3::new(sn * phi.cos(), sn * phi.sin(), c);
                        let dw = f64::from(2.0 * std::f32::consts::TAU / (nc * np) as f32) / 2.0;
                        // Reflection into the upper hemisphere.
                        let h = (wo + up).normalize();
                        let fr = fresnel_dielectric(wo.dot(h), eta) * d.d(h) * d.g(wo, up, h)
                            / (4.0 * wo.z * up.z);
                        r_int += f64::from(fr * up.z) * dw;
                        // Transmission into the lower one.
                        let wi = Vec3::new(up.x, up.y, -up.z);
                        let mut h = (wo + wi * eta).normalize();
                        if h.z < 0.0 {
                            h = -h;
                        }
                        if wo.dot(h) > 0.0 && wi.dot(h) < 0.0 {
                            let den = wo.dot(h) + eta * wi.dot(h);
                            let ft = (1.0 - fresnel_dielectric(wo.dot(h), eta))
                                * d.d(h)
                                * d.g(wo, wi, h)
                                * (wi.dot(h) * wo.dot(h)).abs()
                                / (wi.z.abs() * wo.z * den * den);
                            if ft.is_finite() {
                                t_int += f64::from(ft * wi.z.abs()) * dw;
                            }
                        }
                    }
                }
                let what = format!("beckmann {beckmann}, {deg} deg, outside {outside}");
                assert!(
                    (r_mean - r_int).abs() < 0.001 + 0.005 * r_int,
                    "{what}: R {r_mean} vs {r_int}"
                );
                assert!(
                    (t_mean - t_int).abs() < 0.001 + 0.005 * t_int,
                    "{what}: T {t_mean} vs {t_int}"
                );
                assert!(t_int > 0.2, "{what}: {t_int}");
            }
        }
    }

    /// Rough glass's BSDF times the cosine over its density, for the rays the facets
    /// send, is the weight those rays carry (so that the light samples and the rays
    /// can be weighed against each other).
    #[test]
    fn rough_glass_evaluates_to_the_weights_its_rays_carry() {
        use crate::sampling::uniform3;
        let kind = rough_glass(0.2, 0.2, false);
        let mut checked = 0;
        for (k, ns) in (0..2000).zip([Vec3::Z, -Vec3::Z].into_iter().cycle()) {
            let [a, b, c] = uniform3(5, k);
            let wo = Vec3::new(0.8 * a - 0.4, 0.3 * b, 1.0).normalize();
            let Some(f) = kind.facet(wo, ns, Vec3::ZERO, Vec2::new(c, a)) else {
                continue;
            };
            let wr = 2.0 * wo.dot(f.m) * f.m - wo;
            let mut rays = vec![(wr, f.split.reflect.x * f.weight(wo, wr))];
            if f.split.transmit.x > 0.0 {
                rays.push((f.split.dir, f.split.transmit.x * f.weight(wo, f.split.dir)));
            }
            for (wi, w) in rays {
                let (value, pdf) = kind.rough_glass_eval(wo, wi, ns, Vec3::ZERO).unwrap();
                if w > 0.0 {
                    let got = value.x * wi.dot(ns).abs() / pdf;
                    assert!((got - w).abs() <= 1e-3 * w.max(1.0), "{got} {w}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 2000, "{checked}");
        assert_eq!(
            glass(false).rough_glass_eval(Vec3::Z, Vec3::Z, Vec3::Z, Vec3::ZERO),
            None
        );
    }

    /// Rough glass of a tiny roughness splits a ray as smooth glass does.
    #[test]
    fn rough_glass_of_a_tiny_roughness_is_smooth_glass() {
        let smooth = glass(false);
        let rough = BsdfKind::Dielectric {
            eta: 1.5,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
            thin: false,
            rough: Some(Microfacet {
                alpha_u: 1e-4,
                alpha_v: 1e-4,
                beckmann: false,
            }),
        };
        let wo = Vec3::new(0.6, 0.0, 0.8);
        for ns in [Vec3::Z, -Vec3::Z] {
            let a = smooth.split(wo, ns).unwrap();
            let f = rough.facet(wo, ns, Vec3::ZERO, Vec2::new(0.3, 0.7)).unwrap();
            assert!((f.split.dir - a.dir).length() < 1e-3, "{} {}", f.split.dir, a.dir);
            assert!((f.split.reflect - a.reflect).abs().max_element() < 1e-3);
            assert!((f.split.transmit - a.transmit).abs().max_element() < 1e-3);
            let w = f.weight(wo, f.split.dir);
            assert!((w - 1.0).abs() < 1e-3, "{w}");
        }
    }

    #[test]
    fn refraction_obeys_snells_law() {
        let n = Vec3::Z;
        for deg in [0.0f32, 20.0, 45.0, 80.0] {
            let th = deg.to_radians();
            let wi = Vec3::new(th.sin(), 0.0, th.cos());
            let t = refract(wi, n, 1.5).unwrap();
            // Below the surface, on the far side of the normal from wi's tangent part.
            assert!(t.z < 0.0 && t.x <= 0.0);
            let sin_t = (t.x * t.x + t.y * t.y).sqrt();
            assert!(
                (th.sin() - 1.5 * sin_t).abs() < 1e-5,
                "{deg}: {} vs {}",
                th.sin(),
                1.5 * sin_t
            );
        }
        // From inside glass (eta 1/1.5) beyond the critical angle asin(1/1.5) = 41.8 deg:
        // total internal reflection.
        let th = 45f32.to_radians();
        assert!(refract(Vec3::new(th.sin(), 0.0, th.cos()), n, 1.0 / 1.5).is_none());
        let th = 40f32.to_radians();
        assert!(refract(Vec3::new(th.sin(), 0.0, th.cos()), n, 1.0 / 1.5).is_some());
    }

    #[test]
    fn glass_splits_by_fresnel_and_scales_radiance_across() {
        // Normal incidence from outside: r = ((1.5 - 1) / 2.5)^2 = 0.04; the transmitted
        // ray goes straight in, its radiance weight (1 - 0.04) / 1.5^2.
        let s = glass(false).split(Vec3::Z, Vec3::Z).unwrap();
        assert!((s.reflect.x - 0.04).abs() < 1e-6);
        assert!((s.transmit.x - 0.96 / 2.25).abs() < 1e-6);
        assert!((s.power.x - 0.96).abs() < 1e-6);
        assert!((s.dir - -Vec3::Z).length() < 1e-6);
        // The same from inside (normal facing out): same r, weight (1 - r) * 1.5^2.
        let s = glass(false).split(-Vec3::Z, Vec3::Z).unwrap();
        assert!((s.reflect.x - 0.04).abs() < 1e-6);
        assert!((s.transmit.x - 0.96 * 2.25).abs() < 1e-5);
        assert!((s.dir - Vec3::Z).length() < 1e-6);
        // From inside past the critical angle: all reflected.
        let th = 60f32.to_radians();
        let s = glass(false)
            .split(Vec3::new(th.sin(), 0.0, -th.cos()), Vec3::Z)
            .unwrap();
        assert_eq!((s.reflect.x, s.transmit.x), (1.0, 0.0));
        // 60 degrees from outside: Fresnel's s and p terms by hand.
        let (ci, ct) = (0.5f32, (1.0f32 - 0.75 / 2.25).sqrt());
        let rs = ((ci - 1.5 * ct) / (ci + 1.5 * ct)).powi(2);
        let rp = ((1.5 * ci - ct) / (1.5 * ci + ct)).powi(2);
        let s = glass(false)
            .split(Vec3::new(th.sin(), 0.0, th.cos()), Vec3::Z)
            .unwrap();
        assert!((s.reflect.x - 0.5 * (rs + rp)).abs() < 1e-6);
    }

    #[test]
    fn a_thin_pane_sums_its_inner_reflections_and_does_not_bend() {
        // r = 0.04 a face: 0.04 + 0.96^2 0.04 (1 + 0.04^2 + ...) = 2 r / (1 + r).
        let series: f32 = 0.04 + 0.96 * 0.96 * 0.04 / (1.0 - 0.04 * 0.04);
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let s = glass(true).split(wo, Vec3::Z).unwrap();
        let r = fresnel_dielectric(wo.z, 1.5);
        let series_at = r + (1.0 - r) * (1.0 - r) * r / (1.0 - r * r);
        assert!((s.reflect.x - series_at).abs() < 1e-6);
        assert!((s.reflect.x + s.transmit.x - 1.0).abs() < 1e-6);
        assert!((s.dir + wo).length() < 1e-6);
        assert!((thin_reflectance(1.0, 1.5) - series).abs() < 1e-6);
        // Shadow rays see the same transmittance from either side; thick glass stops them.
        let t = glass(true).shadow_transmittance(-0.7).unwrap();
        assert!((t - (1.0 - thin_reflectance(0.7, 1.5))).abs() < 1e-6);
        assert_eq!(glass(false).shadow_transmittance(1.0), None);
    }

    /// Anisotropic rough glass lies along dp/du: light reflected 20 degrees off the
    /// normal along dp/du (alpha_u 0.05) is under 1 % of that along the other tangent
    /// (alpha_v 0.5); facets drawn spread the same way; with no dp/du (isotropic glass)
    /// the frame from the normal is kept.
    #[test]
    fn anisotropic_rough_glass_lies_along_dpdu() {
        let kind = rough_glass(0.05, 0.5, false);
        assert_eq!(kind.glass_dpdu(|| Vec3::X), Vec3::X);
        assert_eq!(glass(false).glass_dpdu(|| Vec3::X), Vec3::ZERO);
        let (wo, ns) = (Vec3::Z, Vec3::Z);
        let tilt = 20f32.to_radians();
        let along_x = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        let along_y = Vec3::new(0.0, tilt.sin(), tilt.cos());
        let f = |wi: Vec3, dpdu: Vec3| kind.rough_glass_eval(wo, wi, ns, dpdu).unwrap().0.x;
        assert!(f(along_x, Vec3::X) < 0.01 * f(along_y, Vec3::X));
        assert!(f(along_y, Vec3::Y) < 0.01 * f(along_x, Vec3::Y));
        // The facets drawn with dp/du along x lean along y far more than along x.
        let (mut sx, mut sy) = (0.0f32, 0.0f32);
        for i in 0..16 {
            for j in 0..16 {
                let u = Vec2::new((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                if let Some(fc) = kind.facet(wo, ns, Vec3::X, u) {
                    sx += fc.m.x * fc.m.x;
                    sy += fc.m.y * fc.m.y;
                }
            }
        }
        assert!(sx < 0.05 * sy, "{sx} vs {sy}");
    }
}
