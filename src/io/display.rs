//! Streaming images to the tev HDR viewer over TCP (`--display-server HOST:PORT`, as
//! pbrt-v4 has it): the image is created once, then each update (every step of the
//! progressive display, and the final image) is sent as strips of rows.
//!
//! tev's protocol (its `Ipc.h`): every packet is a little-endian `u32` size that counts
//! itself, a type byte, then its fields: `u8` booleans, NUL-terminated strings,
//! little-endian `i32`/`i64` and `f32`. Types used: 4, *CreateImage* (grab focus, name,
//! width, height, channel count, channel names), and 6, *UpdateImageV3* (grab focus,
//! name, channel count, channel names, x, y, width, height, each channel's offset and
//! stride into the floats, the floats).

use std::io::Write;
use std::net::TcpStream;

use crate::image::Image;
use crate::{Error, Result};

/// tev's packet types.
const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_V3: u8 = 6;
/// Rows per update packet (512 px wide: 1.5 MB of floats at most).
const STRIP_PIXELS: usize = 1 << 17;
const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// A connection to a tev viewer showing one image.
pub struct Display {
    stream: TcpStream,
    name: String,
    width: u32,
    height: u32,
}

/// A packet being written: the size is filled in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Self {
        Packet(vec![0, 0, 0, 0, kind])
    }
    fn bool(&mut self, v: bool) -> &mut Self {
        self.0.push(u8::from(v));
        self
    }
    fn str(&mut self, s: &str) -> &mut Self {
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn finish(mut self) -> Vec<u8> {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        self.0
    }
}

impl Display {
    /// Connects to tev at `addr` (`HOST:PORT`) and creates an image `name` of
    /// `width` x `height` with channels R, G, B.
    pub fn connect(addr: &str, name: &str, width: u32, height: u32) -> Result<Self> {
        let fail =
            |e: std::io::Error| Error::Usage(format!("--display-server {addr}: cannot reach tev there: {e}"));
        let mut stream = TcpStream::connect(addr).map_err(fail)?;
        let mut p = Packet::new(CREATE_IMAGE);
        p.bool(true)
            .str(name)
            .i32(width as i32)
            .i32(height as i32)
            .i32(CHANNELS.len() as i32);
        for c in CHANNELS {
            p.str(c);
        }
        stream.write_all(&p.finish()).map_err(fail)?;
        Ok(Display {
            stream,
            name: name.to_string(),
            width,
            height,
        })
    }

    /// Sends `image` (of the size given at [`Display::connect`]) as the image's new
    /// content, in strips of rows.
    pub fn update(&mut self, image: &Image) -> std::io::Result<()> {
        let w = self.width as usize;
        if image.width != self.width || image.height != self.height {
            return Err(std::io::Error::other("image size differs from the display's"));
        }
        let rows = (STRIP_PIXELS / w.max(1)).max(1);
        for (k, strip) in image.pixels.chunks(rows * w).enumerate() {
            let h = strip.len() / w;
            let mut p = Packet::new(UPDATE_IMAGE_V3);
            p.bool(false).str(&self.name).i32(CHANNELS.len() as i32);
            for c in CHANNELS {
                p.str(c);
            }
            p.i32(0).i32((k * rows) as i32).i32(w as i32).i32(h as i32);
            // Interleaved RGB: channel c starts at c, every third float.
            for c in 0..CHANNELS.len() {
                p.i64(c as i64);
            }
            for _ in 0..CHANNELS.len() {
                p.i64(CHANNELS.len() as i64);
            }
            for px in strip {
                p.f32(px.x).f32(px.y).f32(px.z);
            }
            self.stream.write_all(&p.finish())?;
        }
        self.stream.flush()
    }
}
