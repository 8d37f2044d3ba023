//! The body's values, read as the header declares them: ASCII tokens with their line, or
//! little-endian binary scalars ([`Reader`]), each error naming the record being read.

use std::path::Path;

use super::super::text::{self, finite_f32};
use super::super::{LoadError, Location};
use super::header::{Element, Kind, Scalar};

/// The record being read, for error messages.
pub(super) struct Record<'a> {
    pub(super) element: &'a Element,
    pub(super) index: usize,
    pub(super) path: &'a Path,
}

impl Record<'_> {
    fn truncated(&self) -> LoadError {
        LoadError::Truncated {
            path: self.path.to_path_buf(),
            expected: format!(
                "{} {} of the {} declared on header line {}",
                self.element.name, self.index, self.element.count, self.element.line
            ),
        }
    }
}

/// ASCII body tokens with the line each one is on.
pub(super) struct Tokens<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) pos: usize,
    pub(super) line: usize,
}

impl<'a> Tokens<'a> {
    fn next(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        self.bytes.get(start..self.pos).filter(|t| !t.is_empty())
    }
}

pub(super) enum Reader<'a> {
    Ascii(Tokens<'a>),
    Binary { bytes: &'a [u8], pos: usize },
}

/// A value read as its declared type.
enum Number {
    Int(i64),
    Float(f64),
}

impl Reader<'_> {
    pub(super) fn location(&self, record: &Record) -> Location {
        Location::Record {
            element: record.element.name.clone(),
            index: record.index,
            line: match self {
                Reader::Ascii(tokens) => Some(tokens.line),
                Reader::Binary { .. } => None,
            },
        }
    }

    fn number(&mut self, ty: Scalar, record: &Record) -> Result<Number, LoadError> {
        match self {
            Reader::Ascii(tokens) => {
                let token = tokens.next().ok_or_else(|| record.truncated())?;
                let at = self.location(record);
                if ty.is_integer() {
                    text::integer(token, "the value", record.path, &at).map(Number::Int)
                } else {
                    // Straight to f32 when that is the declared type, to keep
                    // the correctly rounded value (see `text::coordinate`).
                    let value = text::coordinate(token, record.path, &at)?;
                    Ok(Number::Float(f64::from(value)))
                }
            }
            Reader::Binary { bytes, pos } => {
                let end = pos
                    .checked_add(ty.size())
                    .filter(|&end| end <= bytes.len())
                    .ok_or_else(|| record.truncated())?;
                let raw = bytes.get(*pos..end).ok_or_else(|| record.truncated())?;
                *pos = end;
                Ok(decode(ty, raw))
            }
        }
    }

    /// A vertex coordinate as a finite `f32`.
    pub(super) fn coordinate(&mut self, ty: Scalar, record: &Record) -> Result<f32, LoadError> {
        match self.number(ty, record)? {
            Number::Int(value) => Ok(value as f32),
            Number::Float(value) => finite_f32(value, record.path, &self.location(record)),
        }
    }

    /// A value of an integer type (the header checks guarantee the type, and
    /// an ASCII token like `1.5` already fails as "not an integer").
    pub(super) fn integer(&mut self, ty: Scalar, record: &Record) -> Result<i64, LoadError> {
        match self.number(ty, record)? {
            Number::Int(value) => Ok(value),
            Number::Float(value) => Err(LoadError::Syntax {
                path: record.path.to_path_buf(),
                at: self.location(record),
                message: format!("expected an integer, found {value}"),
            }),
        }
    }

    /// A list's item count, which must be a non-negative integer.
    pub(super) fn list_size(
        &mut self,
        count_type: Scalar,
        record: &Record,
    ) -> Result<usize, LoadError> {
        let value = self.integer(count_type, record)?;
        usize::try_from(value).map_err(|_| LoadError::Syntax {
            path: record.path.to_path_buf(),
            at: self.location(record),
            message: format!("a list has a negative length {value}"),
        })
    }

    /// Steps over one property of a record without keeping it.
    pub(super) fn skip(&mut self, kind: Kind, record: &Record) -> Result<(), LoadError> {
        let (items, ty) = match kind {
            Kind::Scalar(ty) => (1, ty),
            Kind::List(count, item) => (self.list_size(count, record)?, item),
        };
        match self {
            // Checked against the remaining bytes before moving, so a corrupt
            // list length is a truncation error, not an overflow.
            Reader::Binary { bytes, pos } => {
                *pos = items
                    .checked_mul(ty.size())
                    .and_then(|len| pos.checked_add(len))
                    .filter(|&end| end <= bytes.len())
                    .ok_or_else(|| record.truncated())?;
            }
            Reader::Ascii(tokens) => {
                for _ in 0..items {
                    tokens.next().ok_or_else(|| record.truncated())?;
                }
            }
        }
        Ok(())
    }
}

/// Decodes one little-endian scalar; `raw` has exactly `ty.size()` bytes.
fn decode(ty: Scalar, raw: &[u8]) -> Number {
    let mut buf = [0u8; 8];
    for (slot, &b) in buf.iter_mut().zip(raw) {
        *slot = b;
    }
    let [b0, b1, b2, b3, ..] = buf;
    match ty {
        Scalar::I8 => Number::Int(i64::from(b0 as i8)),
        Scalar::U8 => Number::Int(i64::from(b0)),
        Scalar::I16 => Number::Int(i64::from(i16::from_le_bytes([b0, b1]))),
        Scalar::U16 => Number::Int(i64::from(u16::from_le_bytes([b0, b1]))),
        Scalar::I32 => Number::Int(i64::from(i32::from_le_bytes([b0, b1, b2, b3]))),
        Scalar::U32 => Number::Int(i64::from(u32::from_le_bytes([b0, b1, b2, b3]))),
        Scalar::F32 => Number::Float(f64::from(f32::from_le_bytes([b0, b1, b2, b3]))),
        Scalar::F64 => Number::Float(f64::from_le_bytes(buf)),
    }
}
