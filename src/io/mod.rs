//! Images in and out: OpenEXR (linear radiance) and PNG (sRGB, 8 bit); meshes out
//! as OBJ ([`write_obj`]).
//!
//! Every write goes through [`write_atomic`]: the bytes are written to a temporary
//! file beside the target, synced, and renamed over it, so an interrupted run never
//! leaves a partial file and an existing output is only ever replaced by a complete one.

pub mod display;
mod obj;
pub mod solution;

use std::fs::{self, File, OpenOptions};
use std::io::{Cursor, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use glam::Vec3;

#[cfg(test)]
use crate::image::srgb_encode;
use crate::image::{srgb_decode, to_srgb8, Image};
use crate::{Error, Result};

pub use obj::write_obj;

/// The largest image [`read_image`] accepts, in pixels (guards against garbage
/// headers that claim absurd sizes).
pub const MAX_READ_PIXELS: u64 = 1 << 28;

/// The image formats radtrace reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Exr,
    Png,
}

/// The format named by `path`'s extension (case-insensitive), or a usage error
/// saying what `verb` ("read" / "write") could not do.
fn format_of(path: &Path, verb: &str) -> Result<Format> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr") => Ok(Format::Exr),
        Some("png") => Ok(Format::Png),
        Some(other) => Err(Error::Usage(format!(
            "cannot {verb} '{}': unknown image format '.{other}' (use .exr or .png)",
            path.display()
        ))),
        None => Err(Error::Usage(format!(
            "cannot {verb} '{}': no file extension to tell the image format (use .exr or .png)",
            path.display()
        ))),
    }
}

/// Checks that `img` has exactly `width * height` pixels.
fn check_shape(img: &Image, path: &Path) -> Result<()> {
    let expected = u64::from(img.width) * u64::from(img.height);
    if img.pixels.len() as u64 != expected {
        return Err(Error::Usage(format!(
            "cannot write '{}': image is {}x{} but has {} pixels",
            path.display(),
            img.width,
            img.height,
            img.pixels.len()
        )));
    }
    Ok(())
}

/// Encodes `img` as a PNG file in memory.
fn encode_png(img: &Image, path: &Path, exposure: f32) -> Result<Vec<u8>> {
    use image::ImageEncoder;
    let rgb = to_srgb8(img, exposure);
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(&rgb, img.width, img.height, image::ExtendedColorType::Rgb8)
        .map_err(|e| {
            Error::Usage(format!(
                "cannot write '{}': PNG encoding failed: {e}",
                path.display()
            ))
        })?;
    Ok(buf)
}

/// Encodes `img` as a linear RGB 32-bit float OpenEXR file in memory (scan lines,
/// ZIP compression, increasing Y: the most widely supported layout).
fn encode_exr(img: &Image, path: &Path) -> Result<Vec<u8>> {
    use exr::prelude::{Blocks, Compression, Encoding, LineOrder, SpecificChannels, Vec2, WritableImage};
    let width = img.width as usize;
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = img.pixels[y * width + x];
        (p.x, p.y, p.z)
    });
    let image = exr::prelude::Image::from_encoded_channels((width, img.height as usize), encoding, channels);
    let mut buf = Cursor::new(Vec::new());
    let written = catch_unwind(AssertUnwindSafe(|| image.write().to_buffered(&mut buf)));
    match written {
        Ok(Ok(())) => Ok(buf.into_inner()),
        Ok(Err(e)) => Err(Error::Usage(format!(
            "cannot write '{}': OpenEXR encoding failed: {e}",
            path.display()
        ))),
        Err(_) => Err(Error::Usage(format!(
            "cannot write '{}': OpenEXR encoding failed",
            path.display()
        ))),
    }
}

/// Writes `img` as `.exr` (linear, 32-bit float) or `.png` (sRGB 8-bit, scaled by
/// `2^exposure`) according to the extension. Writes to a temporary file beside
/// `path` and renames it, so an interrupted run leaves no partial file.
///
/// The EXR gets the values as they are (including NaN/Inf); the PNG maps NaN to 0
/// and +Inf to full white.
pub fn write_image(img: &Image, path: &Path, exposure: f32) -> Result<()> {
    let format = format_of(path, "write")?;
    check_shape(img, path)?;
    let bytes = match format {
        Format::Exr => encode_exr(img, path)?,
        Format::Png => encode_png(img, path, exposure)?,
    };
    write_atomic(path, &bytes)
}

/// A format error in `path`.
fn bad_file(path: &Path, what: &str, e: impl std::fmt::Display) -> Error {
    Error::input(path, None, format!("not a readable {what} image: {e}"))
}

/// Checks a decoded size against [`MAX_READ_PIXELS`] and `u32`.
fn check_read_size(path: &Path, width: usize, height: usize) -> Result<(u32, u32)> {
    let too_big = || {
        Error::input(
            path,
            None,
            format!("image is too large ({width}x{height} pixels)"),
        )
    };
    let w = u32::try_from(width).map_err(|_| too_big())?;
    let h = u32::try_from(height).map_err(|_| too_big())?;
    if u64::from(w) * u64::from(h) > MAX_READ_PIXELS {
        return Err(too_big());
    }
    Ok((w, h))
}

/// Decodes the first layer with R, G and B channels of an OpenEXR file.
fn decode_exr(path: &Path, bytes: &[u8]) -> Result<Image> {
    use exr::prelude::{ReadChannels, ReadLayers, Vec2};

    // Look at the header first so a garbage size never reaches the allocator.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| bad_file(path, "OpenEXR", e))?;
    for header in meta.headers.iter() {
        check_read_size(path, header.layer_size.width(), header.layer_size.height())?;
    }
    let has_rgb = |h: &exr::meta::header::Header| {
        ["R", "G", "B"]
            .iter()
            .all(|n| h.channels.list.iter().any(|c| c.name == **n))
    };
    if !meta.headers.iter().any(has_rgb) {
        let names: Vec<String> = meta
            .headers
            .iter()
            .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
            .collect();
        return Err(Error::input(
            path,
            None,
            format!(
                "OpenEXR image has no layer with R, G and B channels (it has: {})",
                names.join(", ")
            ),
        ));
    }

    struct Pixels {
        width: usize,
        data: Vec<Vec3>,
    }
    let read = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size: Vec2<usize>, _: &exr::prelude::RgbChannels| Pixels {
                width: size.width(),
                data: vec![Vec3::ZERO; size.area()],
            },
            |px: &mut Pixels, pos: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                px.data[pos.y() * px.width + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes();
    let decoded = catch_unwind(AssertUnwindSafe(|| read.from_buffered(Cursor::new(bytes))));
    let image = match decoded {
        Ok(Ok(image)) => image,
        Ok(Err(e)) => return Err(bad_file(path, "OpenEXR", e)),
        Err(_) => return Err(bad_file(path, "OpenEXR", "decoder failed")),
    };
    let layer = image.layer_data;
    let (width, height) = check_read_size(path, layer.size.width(), layer.size.height())?;
    Ok(Image {
        width,
        height,
        pixels: layer.channel_data.pixels.data,
    })
}

/// Decodes an 8- or 16-bit PNG (grey, grey+alpha, RGB or RGBA; alpha is ignored),
/// converting sRGB to linear.
fn decode_png(path: &Path, bytes: &[u8]) -> Result<Image> {
    use image::{ColorType, ImageFormat, ImageReader};

    let decoded = catch_unwind(AssertUnwindSafe(|| {
        // The reader's default limits bound the allocation for garbage headers.
        ImageReader::with_format(Cursor::new(bytes), ImageFormat::Png).decode()
    }));
    let dynimg = match decoded {
        Ok(Ok(img)) => img,
        Ok(Err(e)) => return Err(bad_file(path, "PNG", e)),
        Err(_) => return Err(bad_file(path, "PNG", "decoder failed")),
    };
    // A file cut short after the last pixel row still decodes; insist on the
    // complete end chunk so a partly written file is never taken for a whole one.
    const IEND: [u8; 12] = [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xAE, 0x42, 0x60, 0x82];
    if !bytes.windows(IEND.len()).rev().any(|w| w == IEND) {
        return Err(bad_file(path, "PNG", "file is truncated (no IEND chunk)"));
    }
    let (width, height) = check_read_size(path, dynimg.width() as usize, dynimg.height() as usize)?;
    let sixteen = matches!(
        dynimg.color(),
        ColorType::L16 | ColorType::La16 | ColorType::Rgb16 | ColorType::Rgba16
    );
    let pixels = if sixteen {
        let rgb = dynimg.into_rgb16();
        rgb.pixels()
            .map(|p| {
                let f = |v: u16| srgb_decode(f32::from(v) / 65535.0);
                Vec3::new(f(p[0]), f(p[1]), f(p[2]))
            })
            .collect()
    } else {
        let lut: Vec<f32> = (0..=255u8).map(|v| srgb_decode(f32::from(v) / 255.0)).collect();
        let rgb = dynimg.into_rgb8();
        rgb.pixels()
            .map(|p| {
                Vec3::new(
                    lut[usize::from(p[0])],
                    lut[usize::from(p[1])],
                    lut[usize::from(p[2])],
                )
            })
            .collect()
    };
    Ok(Image {
        width,
        height,
        pixels,
    })
}

/// Reads an `.exr` (RGB of the first layer that has them; the data window) or
/// `.png` (8/16-bit, converted from sRGB to linear) image. Errors name the file.
pub fn read_image(path: &Path) -> Result<Image> {
    let format = format_of(path, "read")?;
    let bytes = fs::read(path).map_err(|e| Error::io(path, e))?;
    match format {
        Format::Exr => decode_exr(path, &bytes),
        Format::Png => decode_png(path, &bytes),
    }
}

/// The temporary file [`write_atomic`] writes before renaming: hidden, beside the
/// target, unique per process and call.
fn temp_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = format!(".{name}.tmp-{}-{n}", std::process::id());
    path.with_file_name(tmp)
}

/// Held while [`write_atomic`] has a temporary file on disk; [`exit_after_writes`]
/// takes it too, so an interrupt never leaves a temporary file behind.
static WRITING: Mutex<()> = Mutex::new(());

/// Ends the process with `code` once no [`write_atomic`] is under way (an output
/// being written is finished and renamed first): the Ctrl-C handler.
pub fn exit_after_writes(code: i32) -> ! {
    let _writing = WRITING.lock().unwrap_or_else(|e| e.into_inner());
    std::process::exit(code)
}

/// Writes `bytes` to `path` through a temporary file in the same directory, synced
/// and then renamed over `path`: readers see either the old file or the complete new
/// one. On error the temporary file is removed; an interrupt (see
/// [`exit_after_writes`]) waits for the rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if path.file_name().is_none() {
        return Err(Error::output(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"),
        ));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::output(
            path,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("directory '{}' does not exist", dir.display()),
            ),
        ));
    }
    let tmp = temp_path(path);
    let _writing = WRITING.lock().unwrap_or_else(|e| e.into_inner());
    let result = (|| {
        let mut file = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    match result {
        Ok(()) => {
            // Make the rename itself durable where the platform allows it.
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
            Ok(())
        }
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(Error::output(path, e))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir() -> tempfile::TempDir {
        tempfile::tempdir().unwrap()
    }

    /// A small deterministic generator (xorshift) for test data.
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn f32(&mut self) -> f32 {
            (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn gradient(w: u32, h: u32) -> Image {
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let u = x as f32 / (w - 1) as f32;
                let v = y as f32 / (h - 1) as f32;
                img.pixels[(y * w + x) as usize] = Vec3::new(u, v, u * v);
            }
        }
        img
    }

    #[test]
    fn png_round_trip_gradient() {
        let dir = tmpdir();
        let path = dir.path().join("grad.PNG");
        let img = gradient(64, 32);
        write_image(&img, &path, 0.0).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!((back.width, back.height), (64, 32));
        // Re-encoding what was read gives exactly the bytes that were written.
        assert_eq!(to_srgb8(&back, 0.0), to_srgb8(&img, 0.0));
        // And each value lies within one 8-bit step of the original (in sRGB).
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                let d = (srgb_encode(a[c]) - srgb_encode(b[c])).abs();
                assert!(d <= 0.5 / 255.0 + 1e-6, "{} vs {}", a[c], b[c]);
            }
        }
    }

    #[test]
    fn png_reads_grey_16bit_and_rgba() {
        let dir = tmpdir();
        // 16-bit grey.
        let p16 = dir.path().join("g16.png");
        let grey =
            image::ImageBuffer::<image::Luma<u16>, _>::from_raw(3, 1, vec![0u16, 32768, 65535]).unwrap();
        grey.save(&p16).unwrap();
        let img = read_image(&p16).unwrap();
        assert_eq!((img.width, img.height), (3, 1));
        assert_eq!(img.pixels[0], Vec3::ZERO);
        assert!((img.pixels[1].x - srgb_decode(32768.0 / 65535.0)).abs() < 1e-6);
        assert_eq!(img.pixels[1].x, img.pixels[1].z);
        assert!((img.pixels[2].y - 1.0).abs() < 1e-6);
        // 8-bit RGBA: alpha ignored.
        let p8 = dir.path().join("rgba.png");
        let rgba = image::RgbaImage::from_raw(1, 1, vec![255, 128, 0, 7]).unwrap();
        rgba.save(&p8).unwrap();
        let img = read_image(&p8).unwrap();
        assert!((img.pixels[0].x - 1.0).abs() < 1e-6);
        assert!((img.pixels[0].y - srgb_decode(128.0 / 255.0)).abs() < 1e-7);
        assert_eq!(img.pixels[0].z, 0.0);
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tmpdir();
        let path = dir.path().join("rand.exr");
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let (w, h) = (37, 23);
        let mut img = Image::new(w, h);
        for p in &mut img.pixels {
            *p = Vec3::new(rng.f32() * 100.0, rng.f32(), rng.f32() * 1e-3);
        }
        // Some awkward values too.
        img.pixels[0] = Vec3::new(0.0, -0.0, f32::MIN_POSITIVE);
        img.pixels[1] = Vec3::new(1e30, -5.5, 1.0 / 3.0);
        write_image(&img, &path, 3.0).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!((back.width, back.height), (w, h));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                assert_eq!(a[c].to_bits(), b[c].to_bits());
            }
        }
    }

    #[test]
    fn exr_is_readable_by_the_generic_reader() {
        // The file has standard R, G, B float channels in one layer.
        let dir = tmpdir();
        let path = dir.path().join("x.exr");
        let img = gradient(8, 4);
        write_image(&img, &path, 0.0).unwrap();
        let meta = exr::meta::MetaData::read_from_file(&path, true).unwrap();
        assert_eq!(meta.headers.len(), 1);
        let names: Vec<String> = meta.headers[0]
            .channels
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R"]);
        for c in &meta.headers[0].channels.list {
            assert_eq!(c.sample_type, exr::meta::attribute::SampleType::F32);
        }
    }

    #[test]
    fn exr_without_rgb_is_an_error_naming_the_file() {
        use exr::prelude::*;
        let dir = tmpdir();
        let path = dir.path().join("depth.exr");
        let channels = SpecificChannels::build()
            .with_channel("Z")
            .with_pixel_fn(|_| (1.0f32,));
        exr::prelude::Image::from_channels((4, 4), channels)
            .write()
            .to_file(&path)
            .unwrap();
        let err = read_image(&path).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, crate::Error::Input { .. }));
        assert!(
            msg.contains("depth.exr") && msg.contains("R, G and B") && msg.contains("Z"),
            "{msg}"
        );
    }

    #[test]
    fn unknown_extension_is_a_usage_error() {
        let dir = tmpdir();
        let path = dir.path().join("out.jpg");
        let err = write_image(&Image::new(2, 2), &path, 0.0).unwrap_err();
        assert!(matches!(err, Error::Usage(_)));
        let msg = err.to_string();
        assert!(msg.contains("out.jpg") && msg.contains("'.jpg'"), "{msg}");
        assert!(msg.contains("use .exr or .png"), "{msg}");
        assert!(!path.exists());
        let err = write_image(&Image::new(2, 2), &dir.path().join("noext"), 0.0).unwrap_err();
        assert!(matches!(err, Error::Usage(_)));
        assert!(matches!(read_image(&path), Err(Error::Usage(_))));
    }

    #[test]
    fn missing_directory_is_an_output_error_naming_the_path() {
        let dir = tmpdir();
        let path = dir.path().join("no/such/dir/out.png");
        let err = write_image(&Image::new(2, 2), &path, 0.0).unwrap_err();
        assert!(matches!(err, Error::Output { .. }));
        let msg = err.to_string();
        assert!(msg.contains("no/such/dir/out.png"), "{msg}");
        assert!(msg.contains("does not exist"), "{msg}");
        let err = write_atomic(&path, b"x").unwrap_err();
        assert!(matches!(err, Error::Output { .. }));
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tmpdir();
        let path = dir.path().join("stats.json");
        fs::write(&path, b"old contents that are longer").unwrap();
        write_atomic(&path, b"{\"new\":1}").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"{\"new\":1}");
        write_image(&gradient(4, 4), &dir.path().join("a.png"), 0.0).unwrap();
        write_image(&gradient(4, 4), &dir.path().join("a.exr"), 0.0).unwrap();
        let mut names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["a.exr", "a.png", "stats.json"]);
    }

    #[test]
    fn atomic_write_failure_keeps_old_file_and_removes_temp() {
        // Renaming a file over a non-empty directory fails: the temp must go away.
        let dir = tmpdir();
        let target = dir.path().join("taken");
        fs::create_dir(&target).unwrap();
        fs::write(target.join("inside"), b"keep").unwrap();
        let err = write_atomic(&target, b"data").unwrap_err();
        assert!(matches!(err, Error::Output { .. }));
        assert!(err.to_string().contains("taken"));
        let names: Vec<_> = fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
        assert_eq!(fs::read(target.join("inside")).unwrap(), b"keep");
    }

    #[test]
    fn relative_path_without_directory_works() {
        // A bare file name writes into the current directory; use a unique name.
        let name = format!("radtrace-io-test-{}.json", std::process::id());
        let path = Path::new(&name);
        write_atomic(path, b"1").unwrap();
        assert_eq!(fs::read(path).unwrap(), b"1");
        fs::remove_file(path).unwrap();
    }

    #[test]
    fn garbage_and_truncated_files_are_errors_not_panics() {
        let dir = tmpdir();
        let mut rng = Rng(12345);
        for (i, ext) in ["exr", "png"].iter().cycle().take(40).enumerate() {
            let len = (rng.next_u64() % 4096) as usize;
            let mut bytes: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
            // Half of them start with the right magic number to get past the sniffing.
            if i % 4 < 2 {
                let magic: &[u8] = if *ext == "exr" {
                    &[0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0]
                } else {
                    &[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a]
                };
                bytes.splice(0..0, magic.iter().copied());
            }
            let path = dir.path().join(format!("junk{i}.{ext}"));
            fs::write(&path, &bytes).unwrap();
            let err = read_image(&path).unwrap_err();
            assert!(err.to_string().contains(&format!("junk{i}.{ext}")), "{err}");
        }
        // Truncated valid files, at several cut points.
        let img = gradient(40, 30);
        for ext in ["exr", "png"] {
            let good = dir.path().join(format!("good.{ext}"));
            write_image(&img, &good, 0.0).unwrap();
            let full = fs::read(&good).unwrap();
            for cut in [0, 1, 8, 20, full.len() / 3, full.len() / 2, full.len() - 1] {
                let path = dir.path().join(format!("cut{cut}.{ext}"));
                fs::write(&path, &full[..cut]).unwrap();
                let Err(err) = read_image(&path) else {
                    panic!("truncated {ext} at {cut} of {} bytes was accepted", full.len());
                };
                assert!(err.to_string().contains(&format!("cut{cut}.{ext}")), "{err}");
            }
        }
        // A missing file is an I/O error naming it.
        let missing = dir.path().join("missing.exr");
        let err = read_image(&missing).unwrap_err();
        assert!(matches!(err, Error::Io { .. }));
        assert!(err.to_string().contains("missing.exr"));
    }

    #[test]
    fn png_write_of_non_finite_pixels() {
        let dir = tmpdir();
        let path = dir.path().join("nan.png");
        let img = Image {
            width: 2,
            height: 1,
            pixels: vec![Vec3::splat(f32::NAN), Vec3::splat(f32::INFINITY)],
        };
        write_image(&img, &path, 0.0).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!(back.pixels, vec![Vec3::ZERO, Vec3::ONE]);
    }

    #[test]
    fn bad_pixel_count_is_an_error() {
        let dir = tmpdir();
        let img = Image {
            width: 3,
            height: 3,
            pixels: vec![Vec3::ZERO; 4],
        };
        assert!(write_image(&img, &dir.path().join("x.exr"), 0.0).is_err());
        assert!(write_image(&img, &dir.path().join("x.png"), 0.0).is_err());
    }
}
