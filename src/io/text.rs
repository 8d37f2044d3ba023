//! Line and token scanning shared by the text formats (OBJ, OFF, ASCII PLY).
//!
//! Files are scanned as bytes, not decoded as UTF-8 up front: a Latin-1
//! comment or material name must not make a whole mesh unreadable, and only
//! the tokens we actually parse (numbers, keywords) need to be ASCII.

use super::{LoadError, Location};
use std::path::Path;

/// The lines of `bytes` with their 1-based numbers, `\n` and a trailing `\r`
/// (CRLF files) removed. A final line without `\n` is still yielded.
pub(crate) fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    // `split` yields one empty piece after a final '\n'; it is an empty line
    // and every caller skips empty lines, so it needs no special case.
    bytes.split(|&b| b == b'\n').enumerate().map(|(i, line)| {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        (i + 1, line)
    })
}

/// `line` up to its first `#` (OBJ and OFF comments).
pub(crate) fn strip_comment(line: &[u8]) -> &[u8] {
    match line.iter().position(|&b| b == b'#') {
        Some(at) => &line[..at],
        None => line,
    }
}

/// The whitespace-separated tokens of a line.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// A token for an error message: lossy, and cut short so a line of garbage
/// does not flood the terminal.
pub(crate) fn show(token: &[u8]) -> String {
    let text = String::from_utf8_lossy(token);
    match text.char_indices().nth(32) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.into_owned(),
    }
}

fn syntax(path: &Path, at: &Location, message: String) -> LoadError {
    LoadError::Syntax {
        path: path.to_path_buf(),
        at: at.clone(),
        message,
    }
}

/// A coordinate: must parse and be finite as an `f32` (a value that only
/// overflows in the conversion, like `1e39`, is as unusable as `inf`).
/// Parsed straight to `f32` (correctly rounded) rather than through `f64`,
/// whose double rounding could move a value by one ulp and break welding of
/// positions that are bit-identical in other tools.
pub(crate) fn coordinate(token: &[u8], path: &Path, at: &Location) -> Result<f32, LoadError> {
    let text = std::str::from_utf8(token).ok();
    let value: f32 = text
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| syntax(path, at, format!("{:?} is not a number", show(token))))?;
    if value.is_finite() {
        return Ok(value);
    }
    let wide: f64 = text
        .and_then(|t| t.parse().ok())
        .unwrap_or(f64::from(value));
    Err(LoadError::NonFinite {
        path: path.to_path_buf(),
        at: at.clone(),
        value: wide,
    })
}

/// Narrows a coordinate to `f32`, rejecting NaN, infinities and overflow.
pub(crate) fn finite_f32(value: f64, path: &Path, at: &Location) -> Result<f32, LoadError> {
    let narrow = value as f32;
    if narrow.is_finite() {
        Ok(narrow)
    } else {
        Err(LoadError::NonFinite {
            path: path.to_path_buf(),
            at: at.clone(),
            value,
        })
    }
}

/// An integer token (a count or an index), `what` naming it for the message.
pub(crate) fn integer(
    token: &[u8],
    what: &str,
    path: &Path,
    at: &Location,
) -> Result<i64, LoadError> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| {
            syntax(
                path,
                at,
                format!("{what} {:?} is not an integer", show(token)),
            )
        })
}

/// A count from a header: a non-negative integer.
pub(crate) fn count(
    token: &[u8],
    what: &str,
    path: &Path,
    at: &Location,
) -> Result<usize, LoadError> {
    let value = integer(token, what, path, at)?;
    usize::try_from(value).map_err(|_| syntax(path, at, format!("{what} {value} is negative")))
}

/// `count` records of at least `min_bytes` each cannot fit in a file of
/// `file_len` bytes beyond that many: reserving by the header alone would let
/// a 20-byte file claiming 4 billion faces allocate gigabytes before the
/// truncation is noticed.
pub(crate) fn capacity(count: usize, file_len: usize, min_bytes: usize) -> usize {
    count.min(file_len / min_bytes.max(1) + 1)
}

/// `bytes` without a leading UTF-8 byte-order mark (`EF BB BF`, written
/// first by many Windows editors). It is not part of the first line: left
/// there, it glues onto the first keyword (`\u{feff}v`, `\u{feff}OFF`).
pub(crate) fn strip_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}
