//! Landmark pairs: the landmarks file read ([`parse_landmarks`]), and the pairs mapped to
//! the cleaned meshes' vertex indices with the checks that name a bad pair (stage 1).

use thiserror::Error;

use super::{Side, SupermeshError};
use crate::mesh::clean::Cleaned;
use crate::mesh::IndexedMesh;

/// A landmarks file that cannot be read.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum LandmarkParseError {
    #[error("landmarks line {line}: expected two vertex indices `vertex_in_a vertex_in_b` (non-negative integers, `#` starts a comment), found {found:?}")]
    Line {
        /// 1-based line number.
        line: usize,
        found: String,
    },
    #[error("the landmarks file has no pairs (only blank lines and comments): give at least one `vertex_in_a vertex_in_b` line, or leave the landmarks out")]
    Empty,
}

/// Landmark pairs read from a file, with the line each came from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Landmarks {
    /// `(vertex of A, vertex of B)`, 0-based in each file's vertex order.
    pub pairs: Vec<(u32, u32)>,
    /// The 1-based line of each pair.
    pub lines: Vec<usize>,
}

impl Landmarks {
    /// `error`, prefixed with the line of the landmark pair it is about.
    pub fn explain(&self, error: &SupermeshError) -> String {
        match error.landmark_pair().and_then(|p| self.lines.get(p)) {
            Some(line) => format!("landmarks line {line}: {error}"),
            None => error.to_string(),
        }
    }
}

/// Parses a landmarks file (format in docs/DESIGN.md, "Landmarks"): one pair
/// `vertex_in_a vertex_in_b` a line, whitespace-separated, 0-based indices in
/// each mesh file's vertex order; blank lines and everything after `#` are
/// ignored; at least one pair.
pub fn parse_landmarks(text: &str) -> Result<Landmarks, LandmarkParseError> {
    let mut out = Landmarks::default();
    for (k, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let parsed = match fields.as_slice() {
            [a, b] => a.parse::<u32>().ok().zip(b.parse::<u32>().ok()),
            _ => None,
        };
        match parsed {
            Some(pair) => {
                out.pairs.push(pair);
                out.lines.push(k + 1);
            }
            None => {
                return Err(LandmarkParseError::Line {
                    line: k + 1,
                    found: raw.trim().to_string(),
                })
            }
        }
    }
    if out.pairs.is_empty() {
        return Err(LandmarkParseError::Empty);
    }
    Ok(out)
}

pub(super) fn map_landmarks(
    pairs: &[(u32, u32)],
    a: (&IndexedMesh, &Cleaned),
    b: (&IndexedMesh, &Cleaned),
) -> Result<Vec<(u32, u32)>, SupermeshError> {
    let inverse = |input: &IndexedMesh, cleaned: &Cleaned| {
        let mut map = vec![u32::MAX; input.vertex_count()];
        for (new, &old) in cleaned.vertex_map.iter().enumerate() {
            map[old as usize] = new as u32;
        }
        map
    };
    let (ia, ib) = (inverse(a.0, a.1), inverse(b.0, b.1));
    let mut out = Vec::with_capacity(pairs.len());
    let mut used: [std::collections::HashMap<u32, usize>; 2] = Default::default();
    for (pair, &(va, vb)) in pairs.iter().enumerate() {
        let mut mapped = [0u32; 2];
        for (k, (side, v, map)) in [(Side::A, va, &ia), (Side::B, vb, &ib)]
            .into_iter()
            .enumerate()
        {
            let Some(&m) = map.get(v as usize) else {
                return Err(SupermeshError::LandmarkOutOfRange {
                    pair,
                    mesh: side,
                    vertex: v,
                    vertices: map.len(),
                });
            };
            if m == u32::MAX {
                return Err(SupermeshError::LandmarkUnused {
                    pair,
                    mesh: side,
                    vertex: v,
                });
            }
            mapped[k] = m;
        }
        for (used, mesh, v) in used
            .iter_mut()
            .zip([(Side::A, va), (Side::B, vb)])
            .map(|(u, (m, v))| (u, m, v))
        {
            if let Some(&first) = used.get(&v) {
                return Err(SupermeshError::LandmarkRepeated {
                    first,
                    second: pair,
                    mesh,
                    vertex: v,
                });
            }
            used.insert(v, pair);
        }
        out.push((mapped[0], mapped[1]));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn landmarks_parse_with_comments_and_name_the_bad_line() {
        let text = "# pairs\n0 5\n\n  12\t7  # nose\n";
        let parsed = parse_landmarks(text).unwrap();
        assert_eq!(parsed.pairs, vec![(0, 5), (12, 7)]);
        assert_eq!(parsed.lines, vec![2, 4]);
        let e = SupermeshError::LandmarkUnused {
            pair: 1,
            mesh: Side::A,
            vertex: 12,
        };
        assert!(
            parsed.explain(&e).starts_with("landmarks line 4: "),
            "{}",
            parsed.explain(&e)
        );
        let err = parse_landmarks("0 5\n1 x\n").unwrap_err();
        assert!(matches!(err, LandmarkParseError::Line { line: 2, .. }));
        assert!(err.to_string().contains("line 2"), "{err}");
        assert_eq!(
            parse_landmarks("# none\n\n"),
            Err(LandmarkParseError::Empty)
        );
        assert!(parse_landmarks("1 2 3").is_err());
        assert!(parse_landmarks("-1 2").is_err());
    }
}
