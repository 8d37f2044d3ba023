//! The bounds-checked cursor every section decoder reads with (the frames, the sections
//! and the surface): a read past the end, a number that overflows or a count beyond what
//! the data can hold is an [`AssetError`] naming the section, never a panic.

use super::AssetError;
use crate::varint;

/// A cursor over one section's bytes; errors name the section.
pub(super) struct Reader<'a> {
    data: &'a [u8],
    pub(super) pos: usize,
    tag: &'static str,
}

impl<'a> Reader<'a> {
    pub(super) fn new(data: &'a [u8], tag: &'static str) -> Self {
        Self { data, pos: 0, tag }
    }

    pub(super) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    pub(super) fn varint(&mut self, what: &dyn Fn() -> String) -> Result<u64, AssetError> {
        varint::read(self.data, &mut self.pos).map_err(|malformed| match malformed {
            varint::Malformed::Truncated => AssetError::Truncated {
                tag: self.tag,
                what: what(),
            },
            varint::Malformed::Overflow => AssetError::BadNumber {
                tag: self.tag,
                what: what(),
            },
        })
    }

    /// A count that must not exceed `limit` (what the bytes or the vertex
    /// count justify), checked before anything is allocated for it.
    pub(super) fn count(
        &mut self,
        what: &dyn Fn() -> String,
        limit: usize,
    ) -> Result<usize, AssetError> {
        let count = self.varint(what)?;
        if count > limit as u64 {
            return Err(AssetError::CountTooLarge {
                tag: self.tag,
                what: what(),
                count,
                limit: limit as u64,
            });
        }
        Ok(count as usize)
    }

    pub(super) fn byte(&mut self, what: &dyn Fn() -> String) -> Result<u8, AssetError> {
        let byte = self
            .data
            .get(self.pos)
            .copied()
            .ok_or_else(|| AssetError::Truncated {
                tag: self.tag,
                what: what(),
            })?;
        self.pos += 1;
        Ok(byte)
    }

    pub(super) fn bytes(
        &mut self,
        len: usize,
        what: &dyn Fn() -> String,
    ) -> Result<&'a [u8], AssetError> {
        let out = self
            .data
            .get(self.pos..)
            .and_then(|rest| rest.get(..len))
            .ok_or_else(|| AssetError::Truncated {
                tag: self.tag,
                what: what(),
            })?;
        self.pos += len;
        Ok(out)
    }

    pub(super) fn finish(&self) -> Result<(), AssetError> {
        if self.pos == self.data.len() {
            Ok(())
        } else {
            Err(AssetError::SectionTrailing {
                tag: self.tag,
                length: self.data.len(),
                used: self.pos,
            })
        }
    }
}
