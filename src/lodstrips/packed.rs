//! The per-frame tables (collapse pairs, entry lifetimes, copies) in the
//! narrowest of `u16` and `u32` that holds their largest value: a vertex
//! index, a LOD or an `S0` slot. Meshes under 65,536 vertices (and strips
//! under 65,536 indices) take half the bytes, larger ones keep `u32`; a read
//! stays one load (tighter bit packing made the one-pass rebuild about 1.7×
//! slower, see docs/benchmarks-log.md, "Per-frame memory after load (issue 13, item 4)").

/// A table of `u32` values stored as `u16` when every value fits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Narrow {
    U16(Box<[u16]>),
    U32(Box<[u32]>),
}

impl Default for Narrow {
    fn default() -> Self {
        Narrow::U16(Box::default())
    }
}

impl Narrow {
    /// The values, stored in `u16` if `max` (at least every value) fits.
    pub(crate) fn new(max: u32, values: impl IntoIterator<Item = u32>) -> Narrow {
        match u16::try_from(max) {
            Ok(_) => Narrow::U16(
                values
                    .into_iter()
                    .map(|v| {
                        debug_assert!(v <= max);
                        v as u16
                    })
                    .collect(),
            ),
            Err(_) => Narrow::U32(values.into_iter().collect()),
        }
    }

    /// Value `i`.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> u32 {
        match self {
            Narrow::U16(v) => u32::from(v[i]),
            Narrow::U32(v) => v[i],
        }
    }

    /// The index of the first value for which `pred` is false, the values being those for
    /// which it is true followed by those for which it is false (`slice::partition_point`).
    pub(crate) fn partition_point(&self, mut pred: impl FnMut(u32) -> bool) -> usize {
        match self {
            Narrow::U16(v) => v.partition_point(|&x| pred(u32::from(x))),
            Narrow::U32(v) => v.partition_point(|&x| pred(x)),
        }
    }

    pub(crate) fn len(&self) -> usize {
        match self {
            Narrow::U16(v) => v.len(),
            Narrow::U32(v) => v.len(),
        }
    }

    /// Heap bytes.
    pub(crate) fn byte_size(&self) -> usize {
        match self {
            Narrow::U16(v) => v.len() * 2,
            Narrow::U32(v) => v.len() * 4,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_the_narrowest_width_that_holds_every_value() {
        let small = Narrow::new(65_535, [0, 7, 65_535]);
        assert!(matches!(small, Narrow::U16(_)));
        assert_eq!((small.get(1), small.get(2), small.len()), (7, 65_535, 3));
        assert_eq!(small.byte_size(), 6);
        let large = Narrow::new(65_536, [65_536, 3]);
        assert!(matches!(large, Narrow::U32(_)));
        assert_eq!((large.get(0), large.get(1)), (65_536, 3));
        assert_eq!(Narrow::default().len(), 0);
    }
}
