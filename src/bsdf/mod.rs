//! Evaluation of the materials: the diffuse (Lambertian) part, used with shadow rays
//! and radiosity, and the perfect-mirror part, followed with reflection rays.
//! Formulas follow Mitsuba 3 so that the same scene file gives the same picture.

pub mod glass;
pub mod microfacet;
pub mod plastic;

use glam::Vec3;

use crate::scene::{BsdfKind, Glossy, Rgb};

/// Unpolarised Fresnel reflectance of a smooth dielectric interface, for light
/// arriving from outside at `cos_i > 0` with relative index `eta = n_in / n_out`.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Hemispherical average of the Fresnel reflectance (Mitsuba's
/// `fresnel_diffuse_reflectance`: Egan & Hilgeman's fit for `eta < 1`, d'Eon &
/// Irving's for `eta >= 1`).
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let i = 1.0 / eta;
        let (i2, i3, i4, i5) = (i * i, i * i * i, i * i * i * i, i * i * i * i * i);
        0.919317 - 3.4793 * i + 6.75335 * i2 - 7.80989 * i3 + 4.98554 * i4 - 1.36881 * i5
    }
}

/// The mean over the hemisphere, cosine-weighted, of a smooth coating's transmittance
/// from outside (2 * integral of (1 - F(mu)) mu dmu, midpoint rule in mu: 32 Fresnel
/// terms, as it runs at every photon hit and every gathered hit).
fn plastic_mean_transmittance(eta: f32) -> f32 {
    // The last index's, per thread: a scene has few, and every diffuse read of a
    // plastic asks.
    thread_local! {
        static LAST: std::cell::Cell<(u32, f32)> = const { std::cell::Cell::new((u32::MAX, 0.0)) };
    }
    LAST.with(|last| {
        let (bits, mean) = last.get();
        if bits == eta.to_bits() {
            return mean;
        }
        let n = 32;
        let mean = 2.0
            * (0..n)
                .map(|a| {
                    let c = (a as f32 + 0.5) / n as f32;
                    (1.0 - fresnel_dielectric(c, eta)) * c
                })
                .sum::<f32>()
            / n as f32;
        last.set((eta.to_bits(), mean));
        mean
    })
}

/// The coating of a coated material (`plastic`, `roughplastic`): how much light it
/// lets through at each angle (see [`BsdfKind::coating_weight`]).
pub enum CoatingWeight<'a> {
    /// A smooth coating of relative index `eta`, its mean transmittance.
    Smooth { eta: f32, mean: f32 },
    /// A rough coating's table.
    Rough(&'a crate::scene::Coating),
}

impl CoatingWeight<'_> {
    /// The weight of light arriving at cosine `cos_l`: the transmittance there over
    /// its mean.
    pub fn at(&self, cos_l: f32) -> f32 {
        self.transmittance(cos_l) / self.mean()
    }

    /// The transmittance from outside at cosine `cos`.
    fn transmittance(&self, cos: f32) -> f32 {
        match self {
            CoatingWeight::Smooth { eta, .. } => 1.0 - fresnel_dielectric(cos, *eta),
            CoatingWeight::Rough(c) => c.transmittance(cos),
        }
    }

    /// The transmittance's cosine-weighted mean over the hemisphere.
    fn mean(&self) -> f32 {
        match self {
            CoatingWeight::Smooth { mean, .. } => *mean,
            CoatingWeight::Rough(c) => c.mean_external,
        }
    }
}

/// The diffuse base of Mitsuba's `plastic` behind its coating: the reflectance with
/// the light the coating reflects back inside added (`nonlinear`: per channel, as
/// repeated bounces; otherwise as one mean term).
fn plastic_base(d: Rgb, eta: f32, nonlinear: bool) -> Rgb {
    let fdr_int = fresnel_diffuse_reflectance(1.0 / eta);
    if nonlinear {
        d / (Vec3::ONE - d * fdr_int)
    } else {
        d / (1.0 - fdr_int)
    }
}

impl BsdfKind {
    /// The diffuse BRDF value (1/sr, without the cosine) between the light direction
    /// at cosine `cos_l` and the view direction at cosine `cos_v`, both measured from
    /// the shading normal on the reflecting side (both must be > 0).
    pub fn diffuse_brdf(&self, cos_l: f32, cos_v: f32) -> Rgb {
        match self {
            BsdfKind::Diffuse { reflectance } => *reflectance * std::f32::consts::FRAC_1_PI,
            BsdfKind::Conductor { .. } | BsdfKind::RoughConductor { .. } | BsdfKind::Dielectric { .. } => {
                Vec3::ZERO
            }
            BsdfKind::Plastic { .. } | BsdfKind::RoughPlastic { .. } => match self.coated() {
                Some((base, c)) => base * (c.transmittance(cos_l) * c.transmittance(cos_v)),
                None => Vec3::ZERO,
            },
            BsdfKind::Blend { weight, a, b } => {
                a.diffuse_brdf(cos_l, cos_v) * (1.0 - weight) + b.diffuse_brdf(cos_l, cos_v) * *weight
            }
        }
    }

    /// Weight of the perfect mirror reflection seen from the view direction at
    /// cosine `cos_v`.
    pub fn mirror(&self, cos_v: f32) -> Rgb {
        match self {
            BsdfKind::Diffuse { .. } | BsdfKind::RoughConductor { .. } | BsdfKind::RoughPlastic { .. } => {
                Vec3::ZERO
            }
            BsdfKind::Conductor {
                specular_reflectance,
                fresnel,
            } => *specular_reflectance * fresnel.at(cos_v),
            BsdfKind::Plastic {
                specular_reflectance,
                eta,
                ..
            } => *specular_reflectance * fresnel_dielectric(cos_v, *eta),
            // Seen from outside (the inside is `split`'s).
            BsdfKind::Dielectric {
                eta,
                specular_reflectance,
                thin,
                ..
            } => {
                *specular_reflectance
                    * if *thin {
                        glass::thin_reflectance(cos_v, *eta)
                    } else {
                        fresnel_dielectric(cos_v, *eta)
                    }
            }
            BsdfKind::Blend { weight, a, b } => a.mirror(cos_v) * (1.0 - weight) + b.mirror(cos_v) * *weight,
        }
    }

    /// The diffuse BRDF where it is the same for all directions (Lambert's: `diffuse`,
    /// mirrors' zero, and blends of those); `None` for `plastic`, whose coating's
    /// Fresnel terms weight it by direction.
    pub fn lambertian(&self) -> Option<Rgb> {
        match self {
            BsdfKind::Diffuse { reflectance } => Some(*reflectance * std::f32::consts::FRAC_1_PI),
            BsdfKind::Conductor { .. } | BsdfKind::RoughConductor { .. } | BsdfKind::Dielectric { .. } => {
                Some(Vec3::ZERO)
            }
            BsdfKind::Plastic { .. } | BsdfKind::RoughPlastic { .. } => None,
            BsdfKind::Blend { weight, a, b } => {
                Some(a.lambertian()? * (1.0 - weight) + b.lambertian()? * *weight)
            }
        }
    }

    /// Whether the material reflects diffusely at all (where direct light is computed:
    /// the paper's "diffuse hits").
    pub fn has_diffuse(&self) -> bool {
        match self {
            BsdfKind::Diffuse { reflectance } => reflectance.max_element() > 0.0,
            BsdfKind::Conductor { .. } | BsdfKind::RoughConductor { .. } | BsdfKind::Dielectric { .. } => {
                false
            }
            BsdfKind::Plastic {
                diffuse_reflectance, ..
            }
            | BsdfKind::RoughPlastic {
                diffuse_reflectance, ..
            } => diffuse_reflectance.max_element() > 0.0,
            BsdfKind::Blend { weight, a, b } => {
                (*weight < 1.0 && a.has_diffuse()) || (*weight > 0.0 && b.has_diffuse())
            }
        }
    }

    /// Diffuse albedo: the fraction of uniformly arriving light reflected diffusely
    /// (what the radiosity pass uses as the reflectance rho). Exact for `diffuse`;
    /// for the coated models, the cosine-weighted average over both directions.
    pub fn diffuse_albedo(&self) -> Rgb {
        match self {
            BsdfKind::Diffuse { reflectance } => *reflectance,
            BsdfKind::Conductor { .. } | BsdfKind::RoughConductor { .. } | BsdfKind::Dielectric { .. } => {
                Vec3::ZERO
            }
            BsdfKind::Blend { weight, a, b } => {
                a.diffuse_albedo() * (1.0 - weight) + b.diffuse_albedo() * *weight
            }
            // rho = pi * integral f cos cos over both hemispheres / pi^2 (cosine-weighted
            // average of the directional albedo). The BRDF is the base times a product of
            // one transmittance per direction, so the double integral is the square of one.
            BsdfKind::Plastic { .. } | BsdfKind::RoughPlastic { .. } => match self.coated() {
                Some((base, c)) => base * (std::f32::consts::PI * c.mean() * c.mean()),
                None => Vec3::ZERO,
            },
        }
    }

    /// Diffuse directional albedo at the view cosine `cos_v`: the fraction of light
    /// arriving alike from all directions that the diffuse part sends towards the
    /// view (the radiance seen is this times the irradiance over pi). Its
    /// cosine-weighted mean over the view directions is [`Self::diffuse_albedo`];
    /// behind a coating it falls as the coating's transmittance towards the view does
    /// (a plastic seen head on sends 6 % more than that mean, at grazing angles less).
    pub fn diffuse_albedo_at(&self, cos_v: f32) -> Rgb {
        match self {
            BsdfKind::Diffuse { reflectance } => *reflectance,
            BsdfKind::Conductor { .. } | BsdfKind::RoughConductor { .. } | BsdfKind::Dielectric { .. } => {
                Vec3::ZERO
            }
            BsdfKind::Blend { weight, a, b } => {
                a.diffuse_albedo_at(cos_v) * (1.0 - weight) + b.diffuse_albedo_at(cos_v) * *weight
            }
            BsdfKind::Plastic { .. } | BsdfKind::RoughPlastic { .. } => match self.coated() {
                Some((base, c)) => base * (std::f32::consts::PI * c.transmittance(cos_v) * c.mean()),
                None => Vec3::ZERO,
            },
        }
    }

    /// What the diffuse light read from the solution (the diffuse part's mean over the
    /// view directions, which pass 1 spreads the light with) is scaled by for the view
    /// at cosine `cos_v`: the diffuse albedo towards the view over that mean (1 for
    /// Lambert's). A smooth plastic door (reflectance 0.6, IOR 1.49) seen at cosine
    /// 0.86 came out 8-9 % darker than Mitsuba's where a Lambertian one matched.
    pub fn diffuse_seen(&self, cos_v: f32) -> Rgb {
        // A coated material's base cancels: its coating's weight towards the view.
        if let Some(c) = self.coating_weight() {
            return Vec3::splat(c.at(cos_v));
        }
        if self.lambertian().is_some() {
            return Vec3::ONE;
        }
        let mean = self.diffuse_albedo();
        Vec3::select(
            mean.cmpgt(Vec3::ZERO),
            self.diffuse_albedo_at(cos_v) / mean.max(Vec3::splat(f32::MIN_POSITIVE)),
            Vec3::ONE,
        )
    }

    /// How the diffuse part of a coated material (`plastic`, `roughplastic`) weighs the
    /// light arriving at cosine `cos_l` against light arriving alike from all
    /// directions: the coating's transmittance there over its cosine-weighted mean
    /// (more head on, less at grazing angles). `None` where it takes every direction
    /// alike (Lambert's; a blend, whose parts are not weighed apart).
    pub fn coating_weight(&self) -> Option<CoatingWeight<'_>> {
        match self {
            BsdfKind::Plastic { eta, .. } => Some(CoatingWeight::Smooth {
                eta: *eta,
                mean: plastic_mean_transmittance(*eta),
            }),
            BsdfKind::RoughPlastic {
                lobe, pplastic: true, ..
            } => {
                let eta = plastic::coating_eta(lobe);
                Some(CoatingWeight::Smooth {
                    eta,
                    mean: plastic_mean_transmittance(eta),
                })
            }
            BsdfKind::RoughPlastic { lobe, coating, .. } => {
                Some(CoatingWeight::Rough(plastic::coating(lobe, coating)))
            }
            _ => None,
        }
    }

    /// A coated material's diffuse base (its BRDF without the coating's two
    /// transmittances, one per direction) and its coating; `None` for the others.
    fn coated(&self) -> Option<(Rgb, CoatingWeight<'_>)> {
        let coat = self.coating_weight()?;
        let base = match (self, &coat) {
            (
                BsdfKind::Plastic {
                    diffuse_reflectance,
                    eta,
                    nonlinear,
                    ..
                },
                _,
            ) => plastic_base(*diffuse_reflectance, *eta, *nonlinear) / (eta * eta * std::f32::consts::PI),
            (
                BsdfKind::RoughPlastic {
                    diffuse_reflectance,
                    pplastic: true,
                    ..
                },
                _,
            ) => *diffuse_reflectance * std::f32::consts::FRAC_1_PI,
            (
                BsdfKind::RoughPlastic {
                    diffuse_reflectance,
                    lobe,
                    nonlinear,
                    ..
                },
                CoatingWeight::Rough(c),
            ) => c.base(*diffuse_reflectance, plastic::coating_eta(lobe), *nonlinear),
            _ => return None,
        };
        Some((base, coat))
    }

    /// Whether the material reflects light on like a mirror or a glossy metal (what
    /// the lights' photons of pass 1 are aimed at).
    pub fn has_mirror(&self) -> bool {
        self.mirror(1.0).max_element() > 0.0
            || self.mirror(0.0).max_element() > 0.0
            || self.glossy().is_some()
    }

    /// The glossy lobe (a rough conductor's, a rough plastic's coating's), scaled by its weight in a blend. Of a
    /// blend of two glossy materials, the heavier one's alone.
    pub fn glossy(&self) -> Option<Glossy> {
        match self {
            BsdfKind::RoughConductor { lobe } | BsdfKind::RoughPlastic { lobe, .. } => Some(*lobe),
            BsdfKind::Blend { weight, a, b } => {
                let a = a.glossy().map(|g| (g, 1.0 - weight));
                let b = b.glossy().map(|g| (g, *weight));
                let (mut g, w) = match (a, b) {
                    (Some(a), Some(b)) => {
                        if a.1 >= b.1 {
                            a
                        } else {
                            b
                        }
                    }
                    (a, b) => a.or(b)?,
                };
                g.scale *= w;
                (w > 0.0).then_some(g)
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_known_values() {
        // Normal incidence: ((eta-1)/(eta+1))^2.
        let eta = 1.5f32;
        assert!((fresnel_dielectric(1.0, eta) - 0.04).abs() < 1e-6);
        // Grazing incidence reflects everything.
        assert!((fresnel_dielectric(0.0, eta) - 1.0).abs() < 1e-6);
        // From the dense side beyond the critical angle: total internal reflection.
        assert_eq!(fresnel_dielectric(0.2, 1.0 / 1.5), 1.0);
    }

    #[test]
    fn fresnel_diffuse_reflectance_matches_numeric_integral() {
        // Fdr = 2 * integral_0^1 F(cos) cos dcos.
        for eta in [1.0 / 1.49f32, 1.2, 1.49] {
            let n = 20000;
            let num: f32 = (0..n)
                .map(|k| {
                    let c = (k as f32 + 0.5) / n as f32;
                    2.0 * fresnel_dielectric(c, eta) * c / n as f32
                })
                .sum();
            let fit = fresnel_diffuse_reflectance(eta);
            assert!((num - fit).abs() < 0.01, "eta {eta}: numeric {num} vs fit {fit}");
        }
    }

    #[test]
    fn diffuse_is_rho_over_pi_and_blend_mixes() {
        let d = BsdfKind::Diffuse {
            reflectance: Vec3::new(0.5, 0.25, 1.0),
        };
        let f = d.diffuse_brdf(0.3, 0.9);
        assert!((f * std::f32::consts::PI - Vec3::new(0.5, 0.25, 1.0)).length() < 1e-6);
        assert_eq!(d.mirror(0.5), Vec3::ZERO);
        let m = BsdfKind::Conductor {
            specular_reflectance: Vec3::splat(0.9),
            fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
        };
        let b = BsdfKind::Blend {
            weight: 0.25,
            a: Box::new(d.clone()),
            b: Box::new(m),
        };
        assert!((b.diffuse_brdf(0.3, 0.9) - f * 0.75).length() < 1e-6);
        assert!((b.mirror(0.5) - Vec3::splat(0.225)).length() < 1e-6);
        assert!(b.has_diffuse() && b.has_mirror());
    }

    /// A grey rough plastic of roughness `alpha` (Beckmann's or GGX) and relative index
    /// `eta`.
    fn rough_plastic(alpha: f32, beckmann: bool, eta: f32) -> BsdfKind {
        BsdfKind::RoughPlastic {
            diffuse_reflectance: Vec3::splat(0.5),
            lobe: Glossy {
                distribution: crate::scene::Microfacet {
                    alpha_u: alpha,
                    alpha_v: alpha,
                    beckmann,
                },
                fresnel: crate::scene::Fresnel::Dielectric { eta },
                scale: Vec3::ONE,
            },
            nonlinear: false,
            coating: crate::scene::CoatingCell::default(),
            pplastic: false,
        }
    }

    /// The diffuse directional albedo towards a view is the integral of the diffuse
    /// BRDF times the cosine over the light's hemisphere (2 pi integral f(c, cos_v) c
    /// dc, summed here), for smooth and rough plastic, Lambert's and a blend; its
    /// cosine-weighted mean over the views is the albedo pass 1 uses; a plastic seen
    /// head on sends more than that mean, at grazing angles less.
    #[test]
    fn the_diffuse_albedo_towards_a_view_integrates_the_brdf() {
        let plastic = BsdfKind::Plastic {
            diffuse_reflectance: Vec3::new(0.6, 0.6, 0.55),
            specular_reflectance: Vec3::ONE,
            eta: 1.49 / 1.000277,
            nonlinear: false,
        };
        let rough = rough_plastic(0.2, false, 1.5);
        let blend = BsdfKind::Blend {
            weight: 0.3,
            a: Box::new(plastic.clone()),
            b: Box::new(BsdfKind::Diffuse {
                reflectance: Vec3::splat(0.8),
            }),
        };
        let n = 4000;
        for kind in [&plastic, &rough, &blend] {
            let directional = |cv: f32| -> f32 {
                (0..n)
                    .map(|k| {
                        let c = (k as f32 + 0.5) / n as f32;
                        2.0 * std::f32::consts::PI * kind.diffuse_brdf(c, cv).x * c / n as f32
                    })
                    .sum()
            };
            let mut mean = 0.0;
            let m = 200;
            for k in 0..m {
                let cv = (k as f32 + 0.5) / m as f32;
                let at = kind.diffuse_albedo_at(cv).x;
                assert!(
                    (at - directional(cv)).abs() < 2e-3 * at,
                    "{kind:?} at {cv}: {at} vs {}",
                    directional(cv)
                );
                mean += 2.0 * at * cv / m as f32;
            }
            let albedo = kind.diffuse_albedo().x;
            assert!(
                (mean - albedo).abs() < 2e-3 * albedo,
                "{kind:?}: mean {mean} vs {albedo}"
            );
        }
        let (head_on, grazing, albedo) = (
            plastic.diffuse_albedo_at(1.0).x,
            plastic.diffuse_albedo_at(0.1).x,
            plastic.diffuse_albedo().x,
        );
        assert!(
            head_on > 1.05 * albedo && grazing < 0.8 * albedo,
            "{head_on} {grazing} {albedo}"
        );
        // What a read of the solution is scaled by: that ratio, and 1 for Lambert's.
        assert!((plastic.diffuse_seen(1.0).x - head_on / albedo).abs() < 1e-5);
        let lambert = BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.4),
        };
        assert_eq!(lambert.diffuse_seen(0.2), Vec3::ONE);
    }

    /// A coating weighs the light arriving at each angle by its transmittance there
    /// over its mean: light arriving alike from all directions keeps its weight (the
    /// cosine-weighted mean is 1, summed here over 2000 cosines), light head on is
    /// worth more, at grazing angles less; Lambert's takes no weight.
    #[test]
    fn a_coating_weighs_light_by_its_angle_and_keeps_uniform_light_whole() {
        let smooth = BsdfKind::Plastic {
            diffuse_reflectance: Vec3::splat(0.5),
            specular_reflectance: Vec3::ONE,
            eta: 1.49 / 1.000277,
            nonlinear: false,
        };
        let rough = rough_plastic(0.3, true, 1.6);
        for kind in [&smooth, &rough] {
            let w = kind.coating_weight().expect("a coated material");
            let n = 2000;
            let mean: f32 = (0..n)
                .map(|k| {
                    let c = (k as f32 + 0.5) / n as f32;
                    2.0 * w.at(c) * c / n as f32
                })
                .sum();
            assert!((mean - 1.0).abs() < 2e-3, "{kind:?}: {mean}");
            assert!(
                w.at(1.0) > 1.03 && w.at(0.05) < 0.8,
                "{} {}",
                w.at(1.0),
                w.at(0.05)
            );
        }
        let lambert = BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.5),
        };
        assert!(lambert.coating_weight().is_none());
    }

    #[test]
    fn plastic_energy_is_at_most_one() {
        // White plastic: diffuse albedo plus specular albedo stays <= 1 at every angle.
        let p = BsdfKind::Plastic {
            diffuse_reflectance: Vec3::ONE,
            specular_reflectance: Vec3::ONE,
            eta: 1.49 / 1.000277,
            nonlinear: false,
        };
        for cv in [0.1f32, 0.5, 0.9, 1.0] {
            let n = 4000;
            let diffuse: f32 = (0..n)
                .map(|k| {
                    // Integral over the hemisphere of f cos: 2 pi integral f(c) c dc.
                    let c = (k as f32 + 0.5) / n as f32;
                    2.0 * std::f32::consts::PI * p.diffuse_brdf(c, cv).x * c / n as f32
                })
                .sum();
            let total = diffuse + p.mirror(cv).x;
            // Mitsuba's model uses a fitted Fdr, so it is conserving only to ~0.1%.
            assert!(total <= 1.005 && total > 0.85, "cos {cv}: albedo {total}");
        }
    }

    /// A smooth conductor reflects its Fresnel term at the angle (Mitsuba 3's
    /// `conductor`): at normal incidence ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2), rising
    /// to all of `specular_reflectance` at grazing angles.
    #[test]
    fn a_smooth_conductor_follows_its_fresnel_term() {
        let (n, k) = (0.2f32, 3.0f32);
        let m = BsdfKind::Conductor {
            specular_reflectance: Vec3::splat(0.5),
            fresnel: crate::scene::Fresnel::Conductor {
                eta: Vec3::splat(n),
                k: Vec3::splat(k),
            },
        };
        let r0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!(
            (m.mirror(1.0).x - 0.5 * r0).abs() < 1e-5,
            "{} vs {}",
            m.mirror(1.0).x,
            0.5 * r0
        );
        assert!((m.mirror(1e-4).x - 0.5).abs() < 1e-2);
        assert!(m.mirror(0.02).x > m.mirror(1.0).x);
    }
}
