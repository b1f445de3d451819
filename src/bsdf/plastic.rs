//! Mitsuba 3's `roughplastic`: a diffuse base under a rough dielectric coating. The
//! coating reflects by a microfacet lobe ([`Glossy`] with a [`Fresnel::Dielectric`]
//! term); what it lets through to the base and back out is precomputed as Mitsuba
//! does: the transmittance into the coating at 64 cosines (a 32 x 32 Gauss-Legendre
//! rule over the normals visible from each direction, 128 x 128 from the dense
//! side) and the mean internal reflectance, as a [`Coating`].

use std::sync::Mutex;

use glam::{Vec2, Vec3};

use super::fresnel_dielectric;
use crate::sampling::concentric_disk;
use crate::scene::{Coating, CoatingCell, Fresnel, Glossy, Microfacet, Rgb, COATING_RES};

/// The nodes (in [-1, 1]) and weights of the Gauss-Legendre rule of order `n`.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        // Newton's method on P_n from Tricomi's estimate of the i-th root.
        let mut x = -(std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 0 { 1.0 } else { p1 };
            dp = n as f64 * (x * p - p0) / (x * x - 1.0);
            let step = p / dp;
            x -= step;
            if step.abs() < 1e-15 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// The error function (Abramowitz & Stegun 7.1.26: within 1.5e-7).
pub fn erf(x: f32) -> f32 {
    let a = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * a);
    let poly =
        t * (0.254_829_6 + t * (-0.284_496_74 + t * (1.421_413_7 + t * (-1.453_152 + t * 1.061_405_4))));
    let y = 1.0 - poly * (-a * a).exp();
    y.copysign(x)
}

/// The inverse of [`erf`] on (-1, 1) (Giles' single precision approximation).
pub fn erfinv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        let w = w - 2.5;
        [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            0.246_640_73,
            1.501_409_4,
        ]
        .iter()
        .fold(2.810_226_4e-8, |p, c| c + p * w)
    } else {
        let w = w.sqrt() - 3.0;
        [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461_3e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ]
        .iter()
        .fold(-2.002_142_6e-4, |p, c| c + p * w)
    };
    p * x
}

impl Microfacet {
    /// A normal drawn from those visible from `wi` (local frame, `wi.z > 0`), with
    /// density `G1(wi, m) D(m) <wi, m> / cos(wi)`, from `u` in [0, 1)^2: Heitz and
    /// d'Eon's method with Mitsuba 3's slope sampling (a numerical inversion for
    /// Beckmann), so that the quadratures through it are Mitsuba's.
    pub fn sample_visible(&self, wi: Vec3, u: Vec2) -> Vec3 {
        let view = self.stretch(wi);
        let slope = if self.beckmann {
            Vec2::new(
                beckmann_slope(view.0, u.x),
                erfinv(2.0 * u.y.clamp(1e-6, 1.0 - 1e-6) - 1.0),
            )
        } else {
            ggx_slope(view.0, concentric_disk(u))
        };
        self.unstretch(view, slope)
    }

    /// `wi` seen from the unit-roughness distribution: its cosine, and the sine and
    /// cosine of its azimuth.
    fn stretch(&self, wi: Vec3) -> (f32, f32, f32) {
        let s = Vec3::new(self.alpha_u * wi.x, self.alpha_v * wi.y, wi.z).normalize();
        let sin2 = s.x * s.x + s.y * s.y;
        if sin2 <= 4.0 * f32::EPSILON {
            (s.z, 0.0, 1.0)
        } else {
            let r = sin2.sqrt();
            (s.z, (s.y / r).clamp(-1.0, 1.0), (s.x / r).clamp(-1.0, 1.0))
        }
    }

    /// The normal of a slope of the unit-roughness distribution seen from `view`
    /// ([`Self::stretch`]): rotated to the view's azimuth and unstretched.
    fn unstretch(&self, (_, sin_phi, cos_phi): (f32, f32, f32), slope: Vec2) -> Vec3 {
        let sx = (cos_phi * slope.x - sin_phi * slope.y) * self.alpha_u;
        let sy = (sin_phi * slope.x + cos_phi * slope.y) * self.alpha_v;
        Vec3::new(-sx, -sy, 1.0).normalize()
    }
}

/// The slope along the view of a visible normal of the unit-roughness Beckmann
/// distribution seen from cosine `c`, from `u` in [0, 1) (the other slope is
/// `erfinv(2 v - 1)`): in erf's domain, from the exact solution at grazing
/// incidence, three Newton steps on the CDF.
fn beckmann_slope(c: f32, u: f32) -> f32 {
    let tan = (1.0 - c * c).max(0.0).sqrt() / c;
    let cot = 1.0 / tan;
    let inv_sqrt_pi = 0.564_189_6;
    let maxval = erf(cot);
    let u = u.clamp(1e-6, 1.0 - 1e-6);
    let mut x = maxval - (maxval + 1.0) * erf((-u.ln()).sqrt());
    let target = u * (1.0 + maxval + inv_sqrt_pi * tan * (-cot * cot).exp());
    for _ in 0..3 {
        let slope = erfinv(x);
        let value = 1.0 + x + inv_sqrt_pi * tan * (-slope * slope).exp() - target;
        x -= value / (1.0 - slope * tan);
    }
    erfinv(x)
}

/// The slope of a visible normal of the unit-roughness GGX distribution seen from
/// cosine `c`, from a point `p` of the unit disk: the point moved onto the projected
/// visible hemisphere, and that point's normal.
fn ggx_slope(c: f32, mut p: Vec2) -> Vec2 {
    let s = 0.5 * (1.0 + c);
    let h = (1.0 - p.x * p.x).max(0.0).sqrt();
    p.y = h + (p.y - h) * s;
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    let sin = (1.0 - c * c).max(0.0).sqrt();
    let norm = 1.0 / (sin * p.y + c * z);
    Vec2::new((c * p.y - sin * z) * norm, p.x * norm)
}

/// A product Gauss-Legendre rule on the unit square, with what of
/// [`Microfacet::sample_visible`] depends on the nodes alone.
struct Rule {
    /// Nodes in [0, 1) and their weights (summing to 1).
    nodes: Vec<(f32, f64)>,
    /// Beckmann's second slope at each node.
    erfinv: Vec<f32>,
    /// GGX's disk point at each pair of nodes (row-major).
    disk: Vec<Vec2>,
}

impl Rule {
    fn new(n: usize) -> Self {
        let nodes: Vec<(f32, f64)> = gauss_legendre(n)
            .into_iter()
            .map(|(x, w)| ((0.5 * x + 0.5) as f32, 0.5 * w))
            .collect();
        let erfinv = nodes
            .iter()
            .map(|&(u, _)| erfinv(2.0 * u.clamp(1e-6, 1.0 - 1e-6) - 1.0))
            .collect();
        let disk = nodes
            .iter()
            .flat_map(|&(x, _)| nodes.iter().map(move |&(y, _)| concentric_disk(Vec2::new(x, y))))
            .collect();
        Rule { nodes, erfinv, disk }
    }

    /// The mean over the normals of `d` visible from `wi` of `f(m)`.
    fn visible_mean(&self, d: &Microfacet, wi: Vec3, f: impl Fn(Vec3) -> f32) -> f64 {
        let view = d.stretch(wi);
        let n = self.nodes.len();
        let mut sum = 0.0;
        for (j, &(ux, wx)) in self.nodes.iter().enumerate() {
            let sx = d.beckmann.then(|| beckmann_slope(view.0, ux));
            let mut row = 0.0;
            for (k, &(_, wy)) in self.nodes.iter().enumerate() {
                let slope = match sx {
                    Some(sx) => Vec2::new(sx, self.erfinv[k]),
                    None => ggx_slope(view.0, self.disk[j * n + k]),
                };
                let m = d.unstretch(view, slope);
                if m.is_finite() {
                    row += f64::from(f(m)) * wy;
                }
            }
            sum += row * wx;
        }
        sum
    }
}

/// `eta` of a rough plastic's lobe (its Fresnel term is a dielectric's).
pub fn coating_eta(lobe: &Glossy) -> f32 {
    match lobe.fresnel {
        Fresnel::Dielectric { eta } => eta,
        _ => 1.0,
    }
}

/// The coating of the rough plastic of lobe `lobe`, computed the first time (once
/// per distinct roughness and index in the process: some 30 ms each).
pub fn coating<'a>(lobe: &Glossy, cell: &'a CoatingCell) -> &'a Coating {
    type Key = (bool, u32, u32);
    static MADE: Mutex<Vec<(Key, Coating)>> = Mutex::new(Vec::new());
    cell.get_or_init(|| {
        let eta = coating_eta(lobe);
        let key = (
            lobe.distribution.beckmann,
            lobe.distribution.alpha_u.to_bits(),
            eta.to_bits(),
        );
        let made = |m: &Vec<(Key, Coating)>| m.iter().find(|(k, _)| *k == key).map(|(_, c)| c.clone());
        if let Some(c) = made(&MADE.lock().unwrap_or_else(|e| e.into_inner())) {
            return c;
        }
        let c = make_coating(&lobe.distribution, eta);
        MADE.lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((key, c.clone()));
        c
    })
}

/// Mitsuba 3's precomputation for a coating of roughness `distribution` (isotropic)
/// and relative index `eta`: the transmittance from outside (one minus the Fresnel
/// reflectance, times the masking of the refracted direction) at each tabulated
/// cosine, and twice the cosine-weighted mean of the reflectance from inside.
pub fn make_coating(distribution: &Microfacet, eta: f32) -> Coating {
    let alpha = distribution.alpha_u.max(1e-4);
    let d = Microfacet {
        alpha_u: alpha,
        alpha_v: alpha,
        beckmann: distribution.beckmann,
    };
    let order = |eta: f32| if eta > 1.0 { 32 } else { 128 };
    let (outer, inner) = (Rule::new(order(eta)), Rule::new(order(1.0 / eta)));
    let mut external = [0.0f32; COATING_RES];
    let mut internal = 0.0;
    for (i, t) in external.iter_mut().enumerate() {
        let mu = (i as f32 / (COATING_RES - 1) as f32).max(1e-6);
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        *t = outer.visible_mean(&d, wi, |m| {
            let c = wi.dot(m);
            let sin2_t = (1.0 - c * c).max(0.0) / (eta * eta);
            if sin2_t >= 1.0 {
                return 0.0;
            }
            let cos_t = -(1.0 - sin2_t).sqrt();
            let wt = m * (c / eta + cos_t) - wi / eta;
            if wt.z * wi.z >= 0.0 {
                return 0.0;
            }
            d.g1(wt, m) * (1.0 - fresnel_dielectric(c, eta))
        }) as f32;
        let r = inner.visible_mean(&d, wi, |m| {
            let c = wi.dot(m);
            let wr = 2.0 * c * m - wi;
            if wr.z <= 0.0 {
                return 0.0;
            }
            d.g1(wr, m) * fresnel_dielectric(c, 1.0 / eta)
        });
        internal += r * f64::from(mu);
    }
    let internal_reflectance = (2.0 * internal / COATING_RES as f64) as f32;
    // 2 * integral of the piecewise linear t(mu) mu, segment by segment.
    let h = 1.0 / (COATING_RES - 1) as f32;
    let mean_external = external
        .windows(2)
        .enumerate()
        .map(|(i, w)| {
            let (a, b) = (i as f32 * h, (i + 1) as f32 * h);
            h * (w[0] * (2.0 * a + b) + w[1] * (a + 2.0 * b)) / 6.0
        })
        .sum::<f32>()
        * 2.0;
    Coating {
        external,
        internal_reflectance,
        mean_external,
    }
}

impl Coating {
    /// The transmittance from outside at cosine `cos` (interpolated in the table).
    pub fn transmittance(&self, cos: f32) -> f32 {
        let x = cos.clamp(0.0, 1.0) * (COATING_RES - 1) as f32;
        let i = (x as usize).min(COATING_RES - 2);
        let w = x - i as f32;
        self.external[i] * (1.0 - w) + self.external[i + 1] * w
    }

    /// The diffuse base behind the coating: reflectance `d` with the light the
    /// coating reflects back inside added (`nonlinear`: per channel, as repeated
    /// bounces; otherwise as one mean term), over `eta^2` (the radiance's dilution on
    /// the way out) and pi.
    pub fn base(&self, d: Rgb, eta: f32, nonlinear: bool) -> Rgb {
        let ri = self.internal_reflectance;
        let b = if nonlinear {
            d / (Vec3::ONE - d * ri)
        } else {
            d / (1.0 - ri)
        };
        b / (eta * eta * std::f32::consts::PI)
    }
}

#[cfg(test)]
mod tests {
    use std::f32::consts::PI;

    use super::*;
    use crate::scene::BsdfKind;

    fn dir(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    fn rough_plastic(beckmann: bool, alpha: f32, int_ior: f32, nonlinear: bool, d: f32) -> BsdfKind {
        BsdfKind::RoughPlastic {
            diffuse_reflectance: Vec3::new(d, 0.5 * d, 0.25 * d),
            lobe: Glossy {
                distribution: Microfacet {
                    alpha_u: alpha,
                    alpha_v: alpha,
                    beckmann,
                },
                fresnel: Fresnel::Dielectric {
                    eta: int_ior / 1.000_277,
                },
                scale: Vec3::ONE,
            },
            nonlinear,
            coating: CoatingCell::default(),
            pplastic: false,
        }
    }

    /// The (view, light) direction pairs, as (theta, phi), at which the tests below
    /// compare `eval` with Mitsuba's.
    const DIRS: [((f32, f32), (f32, f32)); 5] = [
        ((0.5, 0.3), (0.6, 0.3 + PI)),
        ((0.2, 0.0), (1.2, 2.0)),
        ((1.3, 0.1), (1.25, 0.1 + PI + 0.2)),
        ((0.0, 0.0), (0.9, 1.0)),
        ((1.5, 0.0), (0.1, 0.0)),
    ];

    /// Mitsuba's `eval` (the BRDF times the cosine of the light direction) from the
    /// lobe and the diffuse part, view direction `wi`, light direction `wo`.
    fn eval(kind: &BsdfKind, wi: Vec3, wo: Vec3) -> (Rgb, Rgb) {
        let lobe = kind.glossy().unwrap();
        let diffuse = kind.diffuse_brdf(wo.z, wi.z) * wo.z;
        (lobe.eval(wo, wi) * wo.z + diffuse, diffuse)
    }

    /// `eval` against Mitsuba 3's: the numbers are `roughplastic`'s `eval` in
    /// Mitsuba 3.9 (scalar_rgb; `ext_ior` its default 1.000277, diffuse reflectance
    /// (d, d/2, d/4)) with view direction `wi` and light direction `wo` given as
    /// (theta, phi): the whole BSDF (times the light's cosine, as Mitsuba returns it)
    /// in three channels, and its diffuse component alone (`BSDFContext.component =
    /// 1`) in the first. Through the diffuse part, this checks the coating's table.
    #[test]
    fn eval_matches_mitsuba() {
        type Case = ((f32, f32), (f32, f32), [f32; 3], f32);
        type Material = (bool, f32, f32, bool, f32);
        // Per direction pair: the three channels, and the diffuse part's first.
        type Values = [([f32; 3], f32); 5];
        let table: [(Material, Values); 4] = [
            (
                (true, 0.1, 1.49, false, 0.5),
                [
                    ([0.415638, 0.351631, 0.319628], 0.128014),
                    ([0.0496287, 0.0248144, 0.0124072], 0.0496287),
                    ([0.0330295, 0.0165894, 0.00836935], 0.0328803),
                    ([0.0946782, 0.0473391, 0.0236696], 0.0946782),
                    ([0.0769224, 0.0384612, 0.0192306], 0.0769224),
                ],
            ),
            (
                (false, 0.3, 1.49, false, 0.5),
                [
                    ([0.127688, 0.0829463, 0.0605752], 0.0894843),
                    ([0.0375207, 0.0198285, 0.0109824], 0.0353843),
                    ([0.140632, 0.127927, 0.121574], 0.0254102),
                    ([0.0698592, 0.0369161, 0.0204446], 0.0658862),
                    ([0.0854656, 0.0454298, 0.0254119], 0.0800716),
                ],
            ),
            (
                (false, 0.05, 1.7, true, 0.8),
                [
                    ([0.767761, 0.674139, 0.649232], 0.136715),
                    ([0.0528168, 0.016761, 0.00716858], 0.0526521),
                    ([0.0517405, 0.0280451, 0.021741], 0.0346024),
                    ([0.101246, 0.032167, 0.0137888], 0.100876),
                    ([0.0793897, 0.0255053, 0.0111696], 0.0786873),
                ],
            ),
            (
                (true, 0.6, 1.33, false, 0.2),
                [
                    ([0.0435472, 0.0244555, 0.0149097], 0.0381833),
                    ([0.0187155, 0.0108155, 0.00686549], 0.0158001),
                    ([0.0963599, 0.0902629, 0.0872144], 0.0121939),
                    ([0.0319682, 0.0177858, 0.0106946], 0.0283647),
                    ([0.0436738, 0.0247326, 0.0152621], 0.0378823),
                ],
            ),
        ];
        for ((beckmann, alpha, ior, nonlinear, d), values) in table {
            let kind = rough_plastic(beckmann, alpha, ior, nonlinear, d);
            let cases: Vec<Case> = DIRS
                .iter()
                .zip(values)
                .map(|(&(a, b), (v, f))| (a, b, v, f))
                .collect();
            for ((ti, pi), (to, po), want, want_diffuse) in cases {
                let (got, diffuse) = eval(&kind, dir(ti, pi), dir(to, po));
                let want = Vec3::from(want);
                assert!(
                    ((got - want).abs() / want).max_element() < 0.01,
                    "{beckmann} {alpha} {ior}, wi ({ti}, {pi}), wo ({to}, {po}): {got} vs {want}"
                );
                assert!(
                    (diffuse.x - want_diffuse).abs() < 0.01 * want_diffuse,
                    "{beckmann} {alpha} {ior}: diffuse {} vs {want_diffuse}",
                    diffuse.x
                );
            }
        }
    }

    /// Mitsuba 3's `pplastic` (scalar_rgb, 3.9): its `eval` (times the light's
    /// cosine) in three channels, and its diffuse component alone (`BSDFContext.
    /// component = 1`) in the first, at the direction pairs [`DIRS`]
    /// (view `wi`, light `wo`, as (theta, phi); diffuse reflectance (d, d/2, d/4)). The
    /// diffuse part is the base over pi times the smooth interface's two transmittances,
    /// with no internal reflection or `eta^2` as `roughplastic` has them. The third
    /// material's lobe is anisotropic (alpha_u 0.1 along x, alpha_v 0.4), which
    /// `roughplastic` refuses.
    #[test]
    fn pplastic_eval_matches_mitsuba() {
        type Material = (bool, f32, f32, f32, f32);
        type Values = [([f32; 3], f32); 5];
        let table: [(Material, Values); 4] = [
            (
                (true, 0.1, 0.1, 1.49, 0.5),
                [
                    ([0.408513, 0.348068, 0.317846], 0.120888),
                    ([0.046893, 0.023446, 0.011723], 0.046893),
                    ([0.030964, 0.015557, 0.007853], 0.030815),
                    ([0.089468, 0.044734, 0.022367], 0.089468),
                    ([0.050328, 0.025164, 0.012582], 0.050328),
                ],
            ),
            (
                (false, 0.3, 0.3, 1.49, 0.5),
                [
                    ([0.159092, 0.098648, 0.068426], 0.120888),
                    ([0.049029, 0.025583, 0.01386], 0.046893),
                    ([0.146037, 0.130629, 0.122926], 0.030815),
                    ([0.093441, 0.048707, 0.02634], 0.089468),
                    ([0.055722, 0.030558, 0.017976], 0.050328),
                ],
            ),
            (
                (false, 0.1, 0.4, 1.7, 0.8),
                [
                    ([0.286011, 0.195033, 0.149545], 0.181954),
                    ([0.078143, 0.043185, 0.025706], 0.069916),
                    ([0.37663, 0.353971, 0.342641], 0.045319),
                    ([0.136832, 0.069677, 0.0361], 0.13431),
                    ([0.075763, 0.038164, 0.019364], 0.075199),
                ],
            ),
            (
                (true, 0.6, 0.6, 1.33, 0.2),
                [
                    ([0.055678, 0.030521, 0.017942], 0.050314),
                    ([0.022839, 0.012877, 0.007896], 0.019923),
                    ([0.09774, 0.090953, 0.087559], 0.013574),
                    ([0.041, 0.022301, 0.012952], 0.037396),
                    ([0.027884, 0.016838, 0.011315], 0.022092),
                ],
            ),
        ];
        for ((beckmann, alpha_u, alpha_v, ior, d), values) in table {
            let kind = BsdfKind::RoughPlastic {
                diffuse_reflectance: Vec3::new(d, 0.5 * d, 0.25 * d),
                lobe: Glossy {
                    distribution: Microfacet {
                        alpha_u,
                        alpha_v,
                        beckmann,
                    },
                    fresnel: Fresnel::Dielectric { eta: ior / 1.000_277 },
                    scale: Vec3::ONE,
                },
                nonlinear: false,
                coating: CoatingCell::default(),
                pplastic: true,
            };
            for (&((ti, pi), (to, po)), (want, want_diffuse)) in DIRS.iter().zip(values) {
                let (got, diffuse) = eval(&kind, dir(ti, pi), dir(to, po));
                let want = Vec3::from(want);
                assert!(
                    ((got - want).abs() / want).max_element() < 0.01,
                    "{beckmann} ({alpha_u}, {alpha_v}) {ior}, wi ({ti}, {pi}), wo ({to}, {po}): {got} vs {want}"
                );
                assert!(
                    (diffuse.x - want_diffuse).abs() < 0.005 * want_diffuse,
                    "{beckmann} ({alpha_u}, {alpha_v}) {ior}: diffuse {} vs {want_diffuse}",
                    diffuse.x
                );
            }
        }
    }

    /// The white furnace: a white rough plastic's directional albedo (the lobe's by
    /// sampling, the diffuse part's by quadrature) stays below 1 and near Mitsuba 3's
    /// (the mean sampling weight of 2^20 samples of its `roughplastic`, llvm_ad_rgb,
    /// diffuse reflectance 1); the diffuse albedo pass 1 uses is the cosine-weighted
    /// mean of the diffuse part's, and with the lobe's share of photons (its
    /// reflectance at normal incidence) the choice of pass 1 stays a probability.
    #[test]
    fn white_furnace_matches_mitsuba() {
        let cosines = [0.05f32, 0.2, 0.5, 0.8, 1.0];
        for ((beckmann, alpha, ior), mitsuba) in [
            ((true, 0.1, 1.49), [0.9227, 0.9484, 0.9696, 0.9682, 0.9680]),
            ((false, 0.3, 1.49), [0.6160, 0.6439, 0.6732, 0.6887, 0.6945]),
            ((false, 0.05, 1.7), [0.8787, 0.9405, 0.9445, 0.9429, 0.9428]),
            ((true, 0.6, 1.33), [0.6756, 0.6954, 0.7138, 0.7250, 0.7325]),
        ] {
            let mut kind = rough_plastic(beckmann, alpha, ior, false, 1.0);
            if let BsdfKind::RoughPlastic {
                diffuse_reflectance, ..
            } = &mut kind
            {
                *diffuse_reflectance = Vec3::ONE;
            }
            let lobe = kind.glossy().unwrap();
            // No mirror part: the coating's reflection is the lobe; the base is
            // diffuse but not Lambertian.
            assert_eq!(kind.mirror(0.7), Vec3::ZERO);
            assert!(kind.has_diffuse() && kind.has_mirror() && kind.lambertian().is_none());
            let n = 2000;
            // The diffuse part's directional albedo: 2 pi integral f(c) c dc.
            let directional = |cv: f32| -> f32 {
                (0..n)
                    .map(|k| {
                        let c = (k as f32 + 0.5) / n as f32;
                        2.0 * PI * kind.diffuse_brdf(c, cv).x * c / n as f32
                    })
                    .sum()
            };
            for (cv, want) in cosines.into_iter().zip(mitsuba) {
                let wo = Vec3::new((1.0 - cv * cv).sqrt(), 0.0, cv);
                let total = directional(cv) + lobe.albedo(wo, 256).x;
                assert!(total <= 1.0, "{beckmann} {alpha} {ior}, cos {cv}: {total}");
                assert!(
                    (total - want).abs() < 0.01,
                    "{beckmann} {alpha} {ior}, cos {cv}: {total} vs Mitsuba's {want}"
                );
            }
            let mean: f32 = (0..n)
                .map(|k| {
                    let c = (k as f32 + 0.5) / n as f32;
                    2.0 * directional(c) * c / n as f32
                })
                .sum();
            let rho = kind.diffuse_albedo().x;
            assert!((rho - mean).abs() < 2e-3, "{rho} vs {mean}");
            assert!(rho + lobe.fresnel.f0().x <= 1.0, "{rho}");
        }
    }

    /// The visible normals have their density `G1(wi, m) D(m) <wi, m> / cos(wi)`:
    /// the mean of `cos(m)` through the quadrature equals its integral against
    /// that density over a fine grid of the hemisphere; and the Gauss-Legendre rule
    /// integrates polynomials of degree `2n - 1` exactly.
    #[test]
    fn visible_normals_have_their_density() {
        let rule = gauss_legendre(8);
        let sum: f64 = rule.iter().map(|&(x, w)| w * x.powi(14)).sum();
        assert!((sum - 2.0 / 15.0).abs() < 1e-12, "{sum}");
        let rule = Rule::new(128);
        for beckmann in [false, true] {
            for alpha in [0.3f32, 0.8] {
                let d = Microfacet {
                    alpha_u: alpha,
                    alpha_v: alpha,
                    beckmann,
                };
                for theta in [0.0f32, 0.6, 1.2] {
                    let wi = Vec3::new(theta.sin(), 0.0, theta.cos());
                    let got = rule.visible_mean(&d, wi, |m| m.z);
                    let n = 600;
                    // (Normalised: Beckmann's G1 is a rational fit, within 0.35%.)
                    let (mut want, mut norm) = (0.0f64, 0.0f64);
                    for i in 0..n {
                        let t = (i as f32 + 0.5) / n as f32 * PI / 2.0;
                        for j in 0..2 * n {
                            let p = (j as f32 + 0.5) / n as f32 * PI;
                            let m = dir(t, p);
                            let density = d.d(m) * d.g1(wi, m) * wi.dot(m).max(0.0) / wi.z;
                            want += f64::from(density * m.z * t.sin());
                            norm += f64::from(density * t.sin());
                        }
                    }
                    want /= norm;
                    assert!(
                        (got - want).abs() < 1e-3,
                        "{beckmann} {alpha} {theta}: {got} vs {want}"
                    );
                    // The same normal by the plain sampling routine.
                    let u = Vec2::new(0.3, 0.8);
                    let m = d.sample_visible(wi, u);
                    assert!(wi.dot(m) > 0.0 && (m.length() - 1.0).abs() < 1e-5);
                }
            }
        }
    }
}
