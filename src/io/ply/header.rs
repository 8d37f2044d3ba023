//! The PLY header: the format line, then each element's count and record layout of scalar
//! and list properties ([`Header::parse`]), with the scalar types they name.

use std::path::Path;

use super::super::text;
use super::super::{LoadError, Location};

/// A PLY scalar type, with its aliases (`float` = `float32`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub(super) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Scalar(Scalar),
    /// A list: the count's type, then the items' type.
    List(Scalar, Scalar),
}

#[derive(Debug)]
pub(super) struct Property {
    pub(super) name: String,
    pub(super) kind: Kind,
    pub(super) line: usize,
}

#[derive(Debug)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: usize,
    pub(super) properties: Vec<Property>,
    pub(super) line: usize,
}

impl Element {
    /// The fewest bytes one record can take: every scalar at its size and
    /// every list empty in binary; a one-character token and a separator per
    /// value in ASCII.
    pub(super) fn min_record_bytes(&self, encoding: Encoding) -> usize {
        self.properties
            .iter()
            .map(|p| match (encoding, p.kind) {
                (Encoding::Ascii, _) => 2,
                (Encoding::BinaryLittleEndian, Kind::Scalar(ty) | Kind::List(ty, _)) => ty.size(),
            })
            .sum()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Encoding {
    Ascii,
    BinaryLittleEndian,
}

pub(super) struct Header {
    pub(super) encoding: Encoding,
    pub(super) elements: Vec<Element>,
    /// Byte offset of the first body byte, just after `end_header`'s newline.
    pub(super) body_start: usize,
    /// Number of header lines, so ASCII body lines keep file line numbers.
    pub(super) lines: usize,
}

impl Header {
    pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Header, LoadError> {
        let syntax = |line: usize, message: String| LoadError::Syntax {
            path: path.to_path_buf(),
            at: Location::Line(line),
            message,
        };
        let mut encoding = None;
        let mut elements: Vec<Element> = Vec::new();
        let mut offset = 0usize;
        for (n, line) in text::lines(bytes) {
            // The body starts after this line's '\n'; `lines` strips it (and a '\r').
            offset = bytes.len().min(offset + raw_len(bytes, offset));
            let mut words = text::tokens(line);
            let keyword = words.next().unwrap_or_default();
            if n == 1 {
                if keyword != b"ply" || words.next().is_some() {
                    return Err(syntax(
                        1,
                        "not a PLY file: the first line must be `ply`".into(),
                    ));
                }
                continue;
            }
            match keyword {
                b"format" => {
                    let kind = words.next().unwrap_or_default();
                    encoding = Some(match kind {
                        b"ascii" => Encoding::Ascii,
                        b"binary_little_endian" => Encoding::BinaryLittleEndian,
                        b"binary_big_endian" => {
                            return Err(LoadError::Unsupported {
                                path: path.to_path_buf(),
                                what: "binary_big_endian PLY".into(),
                                hint: "convert it to binary_little_endian or ascii (for example with meshlab or `plyfile`)".into(),
                            })
                        }
                        other => {
                            return Err(syntax(
                                n,
                                format!("unknown PLY format {:?} (expected ascii or binary_little_endian)", text::show(other)),
                            ))
                        }
                    });
                }
                b"comment" | b"obj_info" | b"" => {}
                b"element" => {
                    let (Some(name), Some(count), None) =
                        (words.next(), words.next(), words.next())
                    else {
                        return Err(syntax(n, "expected `element NAME COUNT`".into()));
                    };
                    elements.push(Element {
                        name: String::from_utf8_lossy(name).into_owned(),
                        count: text::count(count, "the element count", path, &Location::Line(n))?,
                        properties: Vec::new(),
                        line: n,
                    });
                }
                b"property" => {
                    let Some(element) = elements.last_mut() else {
                        return Err(syntax(n, "a property before any element".into()));
                    };
                    let parts: Vec<&[u8]> = words.collect();
                    let scalar = |name: &[u8]| {
                        Scalar::from_name(name).ok_or_else(|| {
                            syntax(n, format!("unknown property type {:?}", text::show(name)))
                        })
                    };
                    let (kind, name) = match parts.as_slice() {
                        [b"list", count, item, name] => {
                            let count = scalar(count)?;
                            if !count.is_integer() {
                                return Err(syntax(n, "a list's count type must be an integer type".into()));
                            }
                            (Kind::List(count, scalar(item)?), name)
                        }
                        [ty, name] => (Kind::Scalar(scalar(ty)?), name),
                        _ => {
                            return Err(syntax(
                                n,
                                "expected `property TYPE NAME` or `property list COUNT_TYPE ITEM_TYPE NAME`".into(),
                            ))
                        }
                    };
                    element.properties.push(Property {
                        name: String::from_utf8_lossy(name).into_owned(),
                        kind,
                        line: n,
                    });
                }
                b"end_header" => {
                    let Some(encoding) = encoding else {
                        return Err(syntax(n, "the header has no `format` line".into()));
                    };
                    return Ok(Header {
                        encoding,
                        elements,
                        body_start: offset,
                        lines: n,
                    });
                }
                other => {
                    return Err(syntax(
                        n,
                        format!("unknown header keyword {:?}", text::show(other)),
                    ))
                }
            }
        }
        if bytes.is_empty() {
            return Err(syntax(1, "the file is empty".into()));
        }
        Err(LoadError::Truncated {
            path: path.to_path_buf(),
            expected: "the `end_header` line".into(),
        })
    }
}

/// Length of the line starting at `offset`, including its '\n' if present.
fn raw_len(bytes: &[u8], offset: usize) -> usize {
    let rest = bytes.get(offset..).unwrap_or_default();
    match rest.iter().position(|&b| b == b'\n') {
        Some(at) => at + 1,
        None => rest.len(),
    }
}
