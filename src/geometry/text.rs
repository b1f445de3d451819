//! Text helpers shared by the line-based readers: the OBJ reader
//! ([`super::obj`]) and the `.bpt` reader ([`super::bezier`]).

use std::path::Path;

use crate::error::Pos;
use crate::geometry::MAX_COORD;
use crate::{Error, Result};

/// Splits `bytes` into lines `(1-based number, text)`, dropping `\r` before `\n`.
/// Text that is not UTF-8 is an error naming its line.
pub(crate) fn text_lines<'a>(path: &Path, bytes: &'a [u8]) -> Result<Vec<(u32, &'a str)>> {
    let mut out = Vec::new();
    let mut rest = bytes;
    let mut line: u32 = 0;
    while !rest.is_empty() {
        line = line.saturating_add(1);
        let (l, r) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        rest = r;
        let l = l.strip_suffix(b"\r").unwrap_or(l);
        let s = std::str::from_utf8(l).map_err(|e| {
            let col = String::from_utf8_lossy(&l[..e.valid_up_to()]).chars().count() + 1;
            Error::input(
                path,
                Some(Pos {
                    line,
                    col: col.try_into().unwrap_or(u32::MAX),
                }),
                "not UTF-8 text",
            )
        })?;
        out.push((line, s));
    }
    Ok(out)
}

/// Whitespace-separated tokens of `line` with their 1-based (character) columns.
pub(crate) fn tokens(line: &str) -> Vec<(u32, &str)> {
    let mut out = Vec::new();
    let mut start: Option<(usize, u32)> = None;
    let mut col: u32 = 0;
    for (i, ch) in line.char_indices() {
        col = col.saturating_add(1);
        if ch.is_whitespace() {
            if let Some((s, c)) = start.take() {
                out.push((c, &line[s..i]));
            }
        } else if start.is_none() {
            start = Some((i, col));
        }
    }
    if let Some((s, c)) = start {
        out.push((c, &line[s..]));
    }
    out
}

/// Parses a coordinate: a finite `f32` no larger than [`MAX_COORD`] in magnitude.
pub(crate) fn parse_coord(path: &Path, line: u32, col: u32, tok: &str) -> Result<f32> {
    let x = parse_finite(path, line, col, tok)?;
    if x.abs() > MAX_COORD {
        return Err(Error::input(
            path,
            Some(Pos { line, col }),
            format!("coordinate '{tok}' is absurdly large (at most {MAX_COORD:e})"),
        ));
    }
    Ok(x)
}

/// Parses a finite `f32`; anything else is an error at `line:col`.
pub(crate) fn parse_finite(path: &Path, line: u32, col: u32, tok: &str) -> Result<f32> {
    let pos = Some(Pos { line, col });
    match tok.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(Error::input(path, pos, format!("'{tok}' is not a finite number"))),
        Err(_) => Err(Error::input(path, pos, format!("'{tok}' is not a number"))),
    }
}
