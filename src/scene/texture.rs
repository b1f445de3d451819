//! Image textures (Mitsuba's `bitmap`): texels in linear RGB, looked up at a surface
//! point's (u, v) as Mitsuba 3 does (its `to_uv`, `wrap_mode`, `filter_type`), and
//! their mean, which the radiosity pass takes as the surface's reflectance.

use std::path::Path;
use std::sync::LazyLock;

use glam::{Affine2, Vec2, Vec3};

use super::Rgb;

/// How texels between texel centres are found (`filter_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TexFilter {
    /// The texel the point falls in.
    Nearest,
    /// Bilinear interpolation of the four nearest texel centres (Mitsuba's default).
    Bilinear,
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
        };
        let mut sum = glam::DVec3::ZERO;
        for k in 0..n {
            sum += t.texel_at(k).as_dvec3();
        }
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
        let uv = self.to_uv.transform_point2(uv);
        if !uv.is_finite() {
            return self.mean;
        }
        let p = uv * Vec2::new(self.width as f32, self.height as f32);
        match self.filter {
            TexFilter::Nearest => self.texel(p.x.floor() as i64, p.y.floor() as i64),
            TexFilter::Bilinear => {
                let p = p - 0.5;
                let f = p.floor();
                let w = p - f;
                let (x, y) = (f.x as i64, f.y as i64);
                let top = self.texel(x, y) * (1.0 - w.x) + self.texel(x + 1, y) * w.x;
                let bottom = self.texel(x, y + 1) * (1.0 - w.x) + self.texel(x + 1, y + 1) * w.x;
                top * (1.0 - w.y) + bottom * w.y
            }
        }
    }
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
        let lum = |c: Rgb| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
        let p = q * Vec2::new(self.width as f32, self.height as f32) - 0.5;
        let f = p.floor();
        let w = p - f;
        let (x, y) = (f.x as i64, f.y as i64);
        let (h00, h10) = (lum(self.texel(x, y)), lum(self.texel(x + 1, y)));
        let (h01, h11) = (lum(self.texel(x, y + 1)), lum(self.texel(x + 1, y + 1)));
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

    #[test]
    fn bad_texels_are_refused() {
        assert!(Texture::from_linear("t", 2, 2, vec![[0.0; 3]; 3]).is_err());
        assert!(Texture::from_linear("t", 0, 0, vec![]).is_err());
        assert!(Texture::from_linear("t", 1, 1, vec![[f32::NAN, 0.0, 0.0]]).is_err());
    }
}
