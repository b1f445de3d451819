//! Image textures (Mitsuba's `bitmap`): texels in linear RGB, looked up at a surface
//! point's (u, v) as Mitsuba 3 does (its `to_uv`, `wrap_mode`, `filter_type`), and
//! their mean, which the radiosity pass takes as the surface's reflectance.

use std::path::Path;
use std::sync::LazyLock;

use glam::{Affine2, Vec2, Vec3};

use super::{luminance, Rgb};

/// How texels between texel centres are found (`filter_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TexFilter {
    /// The texel the point falls in.
    Nearest,
    /// Bilinear interpolation of the four nearest texel centres (Mitsuba's default).
    Bilinear,
    /// Mitsuba 0.6's `trilinear` (and its `ewa`): bilinear in the two levels of the
    /// image's mipmap (box-filtered halvings) whose texels are nearest the width a
    /// camera ray's footprint covers there, blended; bilinear where no footprint is
    /// known (rays past the first bounce, the radiosity pass).
    Trilinear,
}

/// What (u, v) outside [0, 1] reads (`wrap_mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TexWrap {
    /// The image repeats (Mitsuba's default).
    Repeat,
    /// The image repeats, every other copy mirrored.
    Mirror,
    /// The edge texels extend outwards.
    Clamp,
}

/// Texel storage: 8-bit images keep their bytes (decoded through a table at lookup),
/// high dynamic range ones linear floats.
#[derive(Clone, PartialEq)]
enum Texels {
    /// sRGB-encoded bytes (PNG and JPEG, unless `raw`).
    Srgb8(Vec<[u8; 3]>),
    /// Bytes read as linear values / 255 (`raw`).
    Linear8(Vec<[u8; 3]>),
    /// Linear values (EXR, HDR, 16-bit images).
    Float(Vec<[f32; 3]>),
}

/// An image texture.
#[derive(Clone, PartialEq)]
pub struct Texture {
    /// The file, for messages.
    pub name: String,
    width: u32,
    height: u32,
    texels: Texels,
    /// Filter between texels.
    pub filter: TexFilter,
    /// Outside [0, 1].
    pub wrap: TexWrap,
    /// Maps a surface's (u, v) to the image's (`to_uv`).
    pub to_uv: Affine2,
    /// The mean of all texels (linear).
    pub mean: Rgb,
    /// The mipmap's levels past the image itself, each half the one before (box
    /// filtered), down to one texel: built for [`TexFilter::Trilinear`] only.
    mips: Vec<Mip>,
}

/// A footprint of `w` texels reads the mipmap level of texels `w x MIP_SHARPEN` wide:
/// two levels sharper than the textbook choice, whose bilinear lookup in texels as
/// wide as the footprint blurs over about twice it (the staircase's wallpaper went
/// flat). On the staircase (288 x 512, against a 1024-spp Mitsuba image of its
/// bilinear textures) FLIP 0.0687 at 1, 0.0637 at 1/2, 0.0621 at 1/4; 0.0635 without
/// the mipmap, whose point lookups alias where the adaptive sampler takes one
/// sample for 2 x 2 pixels (and refines there for it: 1.40 M samples against 1.27 M).
const MIP_SHARPEN: f32 = 0.25;

/// One level of a mipmap: linear texels, row 0 the top.
#[derive(Debug, Clone, PartialEq)]
struct Mip {
    width: u32,
    height: u32,
    texels: Vec<[f32; 3]>,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Texture")
            .field("name", &self.name)
            .field("size", &(self.width, self.height))
            .field("filter", &self.filter)
            .field("wrap", &self.wrap)
            .field("mean", &self.mean)
            .finish()
    }
}

/// The sRGB transfer function, decoded: byte -> linear value.
static SRGB: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)));

/// The sRGB transfer function's inverse (IEC 61966-2-1), as Mitsuba applies it to 8-bit
/// images.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// A texture of `width` x `height` linear texels, row 0 the image's top.
    pub fn from_linear(name: &str, width: u32, height: u32, texels: Vec<[f32; 3]>) -> Result<Self, String> {
        Self::new(name, width, height, Texels::Float(texels))
    }

    /// A texture of 8-bit texels, sRGB-encoded unless `raw`.
    pub fn from_bytes(
        name: &str,
        width: u32,
        height: u32,
        texels: Vec<[u8; 3]>,
        raw: bool,
    ) -> Result<Self, String> {
        let t = if raw {
            Texels::Linear8(texels)
        } else {
            Texels::Srgb8(texels)
        };
        Self::new(name, width, height, t)
    }

    fn new(name: &str, width: u32, height: u32, texels: Texels) -> Result<Self, String> {
        let n = match &texels {
            Texels::Srgb8(t) | Texels::Linear8(t) => t.len(),
            Texels::Float(t) => t.len(),
        };
        if width == 0 || height == 0 || n != width as usize * height as usize {
            return Err(format!("{width} x {height} texels expected, {n} given"));
        }
        if let Texels::Float(t) = &texels {
            if let Some(bad) = t.iter().flatten().find(|v| !v.is_finite()) {
                return Err(format!("a texel value is {bad}"));
            }
        }
        let mut t = Texture {
            name: name.to_string(),
            width,
            height,
            texels,
            filter: TexFilter::Bilinear,
            wrap: TexWrap::Repeat,
            to_uv: Affine2::IDENTITY,
            mean: Vec3::ZERO,
            mips: Vec::new(),
        };
        let mut sum = glam::DVec3::ZERO;
        t.each_linear(|v| sum += Vec3::from_array(v).as_dvec3());
        t.mean = (sum / n as f64).as_vec3();
        Ok(t)
    }

    /// Reads a PNG, JPEG, HDR or EXR file. 8-bit images are sRGB-encoded unless
    /// `raw` (Mitsuba's rule for its `bitmap`); the others are linear. Alpha is
    /// dropped; a grey image gives grey texels.
    pub fn load(path: &Path, raw: bool) -> Result<Self, String> {
        let name = path.display().to_string();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if ext == "exr" {
            use exr::prelude::*;
            let image = read_first_rgba_layer_from_file(
                path,
                |res, _| (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
                |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    px[pos.y() * *w + pos.x()] = [r, g, b];
                },
            )
            .map_err(|e| format!("cannot read the EXR image: {e}"))?;
            let size = image.layer_data.size;
            let (_, px) = image.layer_data.channel_data.pixels;
            return Self::from_linear(&name, size.width() as u32, size.height() as u32, px);
        }
        let img = image::ImageReader::open(path)
            .map_err(|e| format!("cannot open the image: {e}"))?
            .with_guessed_format()
            .map_err(|e| format!("cannot read the image: {e}"))?
            .decode()
            .map_err(|e| format!("cannot decode the image: {e}"))?;
        let (w, h) = (img.width(), img.height());
        use image::DynamicImage as D;
        match img {
            D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => {
                let rgb = img.into_rgb8();
                let px = rgb.pixels().map(|p| p.0).collect();
                Self::from_bytes(&name, w, h, px, raw)
            }
            D::ImageRgb32F(_) | D::ImageRgba32F(_) => {
                let rgb = img.into_rgb32f();
                let px = rgb.pixels().map(|p| p.0).collect();
                Self::from_linear(&name, w, h, px)
            }
            _ => {
                // 16-bit images: their values through the same rule as 8-bit ones.
                let rgb = img.into_rgb16();
                let px = rgb
                    .pixels()
                    .map(|p| {
                        p.0.map(|v| {
                            let v = f32::from(v) / 65535.0;
                            if raw {
                                v
                            } else {
                                srgb_to_linear(v)
                            }
                        })
                    })
                    .collect();
                Self::from_linear(&name, w, h, px)
            }
        }
    }

    /// Width and height in texels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Calls `f` with every texel's linear value, in order (the texel format
    /// matched once, not per texel: that was most of a large texture's load time).
    fn each_linear(&self, mut f: impl FnMut([f32; 3])) {
        match &self.texels {
            Texels::Srgb8(t) => {
                let srgb: &[f32; 256] = &SRGB;
                t.iter().for_each(|p| f(p.map(|b| srgb[b as usize])));
            }
            Texels::Linear8(t) => t.iter().for_each(|p| f(p.map(|b| f32::from(b) / 255.0))),
            Texels::Float(t) => t.iter().for_each(|p| f(*p)),
        }
    }

    fn texel_at(&self, k: usize) -> Rgb {
        match &self.texels {
            Texels::Srgb8(t) => Vec3::from_array(t[k].map(|b| SRGB[b as usize])),
            Texels::Linear8(t) => Vec3::from_array(t[k].map(|b| f32::from(b) / 255.0)),
            Texels::Float(t) => Vec3::from_array(t[k]),
        }
    }

    /// Texel (x, y), row 0 the image's top, with the wrap mode applied to
    /// coordinates outside the image.
    pub fn texel(&self, x: i64, y: i64) -> Rgb {
        let x = wrap(x, self.width, self.wrap);
        let y = wrap(y, self.height, self.wrap);
        self.texel_at(y * self.width as usize + x)
    }

    /// The texture at surface parameters `uv` (after `to_uv`), as Mitsuba 3's bitmap:
    /// u runs along the image's rows from its left edge, v down its columns from its
    /// top edge; texel centres sit at half-integer positions.
    pub fn eval(&self, uv: Vec2) -> Rgb {
        self.eval_over(uv, 0.0)
    }

    /// [`Texture::eval`] over a footprint `width` wide in surface parameters (u, v)
    /// (0: a point): a [`TexFilter::Trilinear`] texture reads the mipmap levels whose
    /// texels are about that wide (after `to_uv`); the other filters ignore it.
    pub fn eval_over(&self, uv: Vec2, width: f32) -> Rgb {
        let uv = self.to_uv.transform_point2(uv);
        if !uv.is_finite() {
            return self.mean;
        }
        let size = Vec2::new(self.width as f32, self.height as f32);
        let p = uv * size;
        match self.filter {
            TexFilter::Nearest => self.texel(p.x.floor() as i64, p.y.floor() as i64),
            TexFilter::Trilinear if width > 0.0 && !self.mips.is_empty() => {
                // Texels across the footprint, at the image's own size.
                let across = width * self.to_uv.matrix2.determinant().abs().sqrt() * size.max_element();
                let level = (across * MIP_SHARPEN).max(1.0).log2().min(self.mips.len() as f32);
                let (l0, f) = (level.floor() as usize, level.fract());
                let at = |l: usize| match l {
                    0 => bilinear(p, |x, y| self.texel(x, y)),
                    l => {
                        let m = &self.mips[l - 1];
                        let q = uv * Vec2::new(m.width as f32, m.height as f32);
                        bilinear(q, |x, y| {
                            let x = wrap(x, m.width, self.wrap);
                            let y = wrap(y, m.height, self.wrap);
                            Vec3::from_array(m.texels[y * m.width as usize + x])
                        })
                    }
                };
                if f > 0.0 && l0 < self.mips.len() {
                    at(l0) * (1.0 - f) + at(l0 + 1) * f
                } else {
                    at(l0)
                }
            }
            TexFilter::Bilinear | TexFilter::Trilinear => bilinear(p, |x, y| self.texel(x, y)),
        }
    }

    /// Builds the mipmap that [`TexFilter::Trilinear`] reads (once).
    pub fn build_mipmap(&mut self) {
        if !self.mips.is_empty() || (self.width == 1 && self.height == 1) {
            return;
        }
        let (mut w, mut h) = (self.width, self.height);
        let mut image: Vec<[f32; 3]> = Vec::with_capacity((w * h) as usize);
        self.each_linear(|v| image.push(v));
        while w > 1 || h > 1 {
            let prev = self.mips.last().map_or(&image, |m| &m.texels);
            let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
            let mut next = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                for x in 0..nw {
                    // The 2 x 2 texels below (one row or column where that side is 1).
                    let (x0, y0) = (x * 2, y * 2);
                    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
                    let get = |x: u32, y: u32| Vec3::from_array(prev[(y * w + x) as usize]);
                    let c = (get(x0, y0) + get(x1, y0) + get(x0, y1) + get(x1, y1)) * 0.25;
                    next.push(c.to_array());
                }
            }
            self.mips.push(Mip {
                width: nw,
                height: nh,
                texels: next,
            });
            (w, h) = (nw, nh);
        }
    }
}

/// Bilinear interpolation at image position `p` (texels wide, texel centres at
/// half-integers) of the texels `fetch` gives (wrapped as the texture wraps).
fn bilinear(p: Vec2, fetch: impl Fn(i64, i64) -> Rgb) -> Rgb {
    let p = p - 0.5;
    let f = p.floor();
    let w = p - f;
    let (x, y) = (f.x as i64, f.y as i64);
    let top = fetch(x, y) * (1.0 - w.x) + fetch(x + 1, y) * w.x;
    let bottom = fetch(x, y + 1) * (1.0 - w.x) + fetch(x + 1, y + 1) * w.x;
    top * (1.0 - w.y) + bottom * w.y
}

impl Texture {
    /// The gradient in surface (u, v) of the texture's luminance (bilinear between
    /// texel centres, through `to_uv`): what a bump map tilts the normal by.
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        let m = self.to_uv.matrix2;
        let q = self.to_uv.transform_point2(uv);
        if !q.is_finite() {
            return Vec2::ZERO;
        }
        let p = q * Vec2::new(self.width as f32, self.height as f32) - 0.5;
        let f = p.floor();
        let w = p - f;
        let (x, y) = (f.x as i64, f.y as i64);
        let (h00, h10) = (luminance(self.texel(x, y)), luminance(self.texel(x + 1, y)));
        let (h01, h11) = (
            luminance(self.texel(x, y + 1)),
            luminance(self.texel(x + 1, y + 1)),
        );
        let dx = ((1.0 - w.y) * (h10 - h00) + w.y * (h11 - h01)) * self.width as f32;
        let dy = ((1.0 - w.x) * (h01 - h00) + w.x * (h11 - h10)) * self.height as f32;
        // Through the map's (u, v) transform: the chain rule.
        m.transpose() * Vec2::new(dx, dy)
    }

    /// A latitude-longitude environment map at `uv` ([`super::environment_uv`]), as
    /// Mitsuba 3's `envmap` reads its image: texel (x, y) sits at u = x / width (the
    /// first column again at u = 1) and v = y / (height - 1), the first and last rows
    /// at the poles; bilinear in between.
    pub fn eval_lat_long(&self, uv: Vec2) -> Rgb {
        if !uv.is_finite() {
            return self.mean;
        }
        let x = uv.x * self.width as f32;
        let y = (uv.y * (self.height.max(2) - 1) as f32).clamp(0.0, (self.height - 1) as f32);
        let (fx, fy) = (x.floor(), y.floor());
        let (wx, wy) = (x - fx, y - fy);
        let (x0, y0) = (fx as i64, fy as i64);
        let at = |x: i64, y: i64| {
            let x = x.rem_euclid(i64::from(self.width)) as usize;
            let y = y.clamp(0, i64::from(self.height) - 1) as usize;
            self.texel_at(y * self.width as usize + x)
        };
        let top = at(x0, y0) * (1.0 - wx) + at(x0 + 1, y0) * wx;
        let bottom = at(x0, y0 + 1) * (1.0 - wx) + at(x0 + 1, y0 + 1) * wx;
        top * (1.0 - wy) + bottom * wy
    }
}

/// Coordinate `i` of a texel wrapped into `0..n`.
fn wrap(i: i64, n: u32, mode: TexWrap) -> usize {
    let n = i64::from(n);
    let i = match mode {
        TexWrap::Repeat => i.rem_euclid(n),
        TexWrap::Clamp => i.clamp(0, n - 1),
        TexWrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
    };
    i as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Rgb, b: Rgb) -> bool {
        (a - b).abs().max_element() < 1e-5
    }

    /// The sRGB curve at known points: 0, 1, the linear segment, and mid-grey 128,
    /// which decodes to 0.2158605 (IEC 61966-2-1).
    #[test]
    fn srgb_bytes_decode_to_the_standard_curve() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(10.0 / 255.0) - 10.0 / 255.0 / 12.92).abs() < 1e-7);
        assert!((SRGB[128] - 0.215_860_5).abs() < 1e-6);
        let t = Texture::from_bytes("t", 1, 1, vec![[128, 0, 255]], false).unwrap();
        assert!(close(t.mean, Vec3::new(0.215_860_5, 0.0, 1.0)));
        let raw = Texture::from_bytes("t", 1, 1, vec![[128, 0, 255]], true).unwrap();
        assert!(close(raw.mean, Vec3::new(128.0 / 255.0, 0.0, 1.0)));
    }

    /// A 2 x 2 texture: texel centres give the texels exactly (row 0 the top, at v
    /// near 0); between centres bilinear blends, nearest picks; the wrap modes.
    #[test]
    fn lookups_follow_mitsubas_texel_centres_filters_and_wraps() {
        let a = [0.0, 0.0, 0.0];
        let b = [1.0, 0.0, 0.0];
        let c = [0.0, 1.0, 0.0];
        let d = [0.0, 0.0, 1.0];
        let mut t = Texture::from_linear("t", 2, 2, vec![a, b, c, d]).unwrap();
        assert!(close(t.mean, Vec3::splat(0.25)));
        assert!(close(t.eval(Vec2::new(0.25, 0.25)), Vec3::from(a)));
        assert!(close(t.eval(Vec2::new(0.75, 0.25)), Vec3::from(b)));
        assert!(close(t.eval(Vec2::new(0.25, 0.75)), Vec3::from(c)));
        assert!(close(t.eval(Vec2::new(0.75, 0.75)), Vec3::from(d)));
        // Halfway between the four centres: their mean.
        assert!(close(t.eval(Vec2::new(0.5, 0.5)), Vec3::splat(0.25)));
        // At u = 0 (the left edge), repeat blends the left and right columns.
        assert!(close(t.eval(Vec2::new(0.0, 0.25)), Vec3::new(0.5, 0.0, 0.0)));
        t.wrap = TexWrap::Clamp;
        assert!(close(t.eval(Vec2::new(0.0, 0.25)), Vec3::from(a)));
        assert!(close(t.eval(Vec2::new(-3.0, 0.25)), Vec3::from(a)));
        t.wrap = TexWrap::Mirror;
        // u in [1, 2) mirrors: 1.25 reads as 0.75.
        assert!(close(t.eval(Vec2::new(1.25, 0.25)), Vec3::from(b)));
        t.wrap = TexWrap::Repeat;
        assert!(close(t.eval(Vec2::new(1.25, 0.25)), Vec3::from(a)));
        t.filter = TexFilter::Nearest;
        assert!(close(t.eval(Vec2::new(0.49, 0.51)), Vec3::from(c)));
        // to_uv: scale 2 repeats the image twice over the surface.
        t.to_uv = Affine2::from_scale(Vec2::splat(2.0));
        assert!(close(t.eval(Vec2::new(0.4, 0.1)), Vec3::from(b)));
    }

    /// A 4 x 4 image's mipmap: 2 x 2 texels, each the mean of the 2 x 2 texels
    /// under it, then one, the image's mean. Read over a footprint as wide as the
    /// image (after `to_uv`, which repeats it 4 times), a trilinear texture gives
    /// that mean; over no footprint, or as a bilinear texture, the bilinear lookup.
    #[test]
    fn a_mipmap_halves_the_image_by_box_filtering_and_footprints_pick_its_levels() {
        let texels: Vec<[f32; 3]> = (0..16).map(|k| [k as f32, (k % 4) as f32, 1.0]).collect();
        let mut t = Texture::from_linear("t", 4, 4, texels).unwrap();
        t.filter = TexFilter::Trilinear;
        t.build_mipmap();
        assert_eq!(t.mips.len(), 2);
        // Texels 0, 1, 4, 5: means 2.5 and 0.5.
        assert_eq!(t.mips[0].texels[0], [2.5, 0.5, 1.0]);
        // Texels 10, 11, 14, 15.
        assert_eq!(t.mips[0].texels[3], [12.5, 2.5, 1.0]);
        assert_eq!((t.mips[1].width, t.mips[1].height), (1, 1));
        assert!(close(Vec3::from_array(t.mips[1].texels[0]), t.mean));
        let uv = Vec2::new(0.3, 0.6);
        t.to_uv = Affine2::from_scale(Vec2::splat(4.0));
        let point = t.eval_over(uv, 0.0);
        let mut b = t.clone();
        b.filter = TexFilter::Bilinear;
        assert!(close(point, b.eval(uv)));
        // A footprint w wide in u covers 16 w texels (4 repeats of 4): level k is
        // read where 16 w MIP_SHARPEN = 2^k.
        let width = |k: i32| 2f32.powi(k) / 16.0 / MIP_SHARPEN;
        assert!(close(t.eval_over(uv, width(2)), t.mean));
        assert!(close(t.eval_over(uv, width(5)), t.mean));
        assert!(close(b.eval_over(uv, width(2)), point));
        assert!(close(t.eval_over(uv, width(-1)), point));
        // Level 1, bilinear among its four texels (u = 1.2 -> x 2.4 of 2, repeating;
        // y 4.8 of 2); between levels 1 and 2, their blend.
        let half = t.eval_over(uv, width(1));
        let (m, q) = (&t.mips[0], Vec2::new(1.2, 2.4) * 2.0);
        let want = bilinear(q, |x, y| {
            let (x, y) = (wrap(x, 2, TexWrap::Repeat), wrap(y, 2, TexWrap::Repeat));
            Vec3::from_array(m.texels[y * 2 + x])
        });
        assert!(close(half, want), "{half} vs {want}");
        let between = t.eval_over(uv, width(1) * 2f32.sqrt());
        assert!(close(between, (want + t.mean) * 0.5), "{between}");
    }

    #[test]
    fn bad_texels_are_refused() {
        assert!(Texture::from_linear("t", 2, 2, vec![[0.0; 3]; 3]).is_err());
        assert!(Texture::from_linear("t", 0, 0, vec![]).is_err());
        assert!(Texture::from_linear("t", 1, 1, vec![[f32::NAN, 0.0, 0.0]]).is_err());
    }
}
