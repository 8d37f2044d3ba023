//! The runtime's index buffer in the narrowest width that holds the model's vertex numbers:
//! `u16` for a model of at most 65,536 vertices (a crowd's body: 64 KB of strips an instance
//! instead of 128 KB), `u32` above. The width is chosen once per model, when a state is made;
//! every operation matches it once ([`dispatch`]) and runs a loop generic over
//! [`StripIndex`], so no loop matches per index. Readers get [`Indices`], a borrowed view of
//! either width, which widens to `u32` only where it is copied out (a GPU upload's words).

use std::ops::Range;

/// A word of a runtime's index buffer (`u16` or `u32`): what the runtime's inner loops are
/// generic over.
pub(crate) trait StripIndex: Copy + Eq + Into<u32> + Send + Sync + 'static {
    /// `v`, a vertex number of the model, in this width (the model's width holds every one).
    fn of(v: u32) -> Self;
}

/// `x` as `u32`: a function, so that the bodies [`dispatch`] copies for each width convert the
/// same way (an `into` would be a conversion to itself in the `u32` copy).
#[inline]
fn widen<I: StripIndex>(x: I) -> u32 {
    x.into()
}

impl StripIndex for u16 {
    #[inline]
    fn of(v: u32) -> u16 {
        debug_assert!(v <= u32::from(u16::MAX), "vertex {v} in a u16 buffer");
        v as u16
    }
}

impl StripIndex for u32 {
    #[inline]
    fn of(v: u32) -> u32 {
        v
    }
}

/// The width a runtime stores its indices in ([`StripsState::index_width`]).
///
/// [`StripsState::index_width`]: crate::lodstrips::StripsState::index_width
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IndexWidth {
    U16,
    U32,
}

impl IndexWidth {
    /// The narrowest width that holds every vertex number of a model of `vertex_count`
    /// vertices: `u16` up to 65,536 vertices.
    pub fn for_vertices(vertex_count: u32) -> IndexWidth {
        if vertex_count <= 1 << 16 {
            IndexWidth::U16
        } else {
            IndexWidth::U32
        }
    }

    /// Bytes of one index.
    pub fn bytes(self) -> usize {
        match self {
            IndexWidth::U16 => 2,
            IndexWidth::U32 => 4,
        }
    }
}

/// Runs `$body` with `$v` bound to the slice or vector inside `$value` (an `$enum`, [`IndexBuf`]
/// or [`Indices`], or a reference to one), whichever its width: one match per operation, the
/// body monomorphised for each width.
macro_rules! dispatch {
    ($enum:ident, $value:expr, $v:ident => $body:expr) => {
        match $value {
            $enum::U16($v) => $body,
            $enum::U32($v) => $body,
        }
    };
}
pub(crate) use dispatch;

/// A state's whole index buffer, owned, in its model's width.
#[derive(Clone, Debug)]
pub(crate) enum IndexBuf {
    U16(Vec<u16>),
    U32(Vec<u32>),
}

impl Default for IndexBuf {
    /// Empty, allocating nothing (what a buffer taken out of its state leaves behind).
    fn default() -> Self {
        IndexBuf::U16(Vec::new())
    }
}

impl IndexBuf {
    /// `indices` (vertex numbers that `width` holds) in `width`.
    pub(crate) fn new(indices: &[u32], width: IndexWidth) -> IndexBuf {
        match width {
            IndexWidth::U16 => IndexBuf::U16(indices.iter().map(|&v| u16::of(v)).collect()),
            IndexWidth::U32 => IndexBuf::U32(indices.to_vec()),
        }
    }

    pub(crate) fn view(&self) -> Indices<'_> {
        dispatch!(IndexBuf, self, v => v[..].into())
    }

    /// Bytes on the heap (the capacity).
    pub(crate) fn heap_bytes(&self) -> usize {
        match self {
            IndexBuf::U16(v) => v.capacity() * 2,
            IndexBuf::U32(v) => v.capacity() * 4,
        }
    }
}

/// A runtime's indices, borrowed, in the width they are stored in: `u16` or `u32`
/// ([`IndexWidth`]). Read them a range at a time ([`copy_to`](Self::copy_to),
/// [`extend_mapped`](Self::extend_mapped)), or match the two slices to run a loop generic over
/// the width; [`to_vec`](Self::to_vec) widens a whole copy (tests and tools).
#[derive(Clone, Copy, Debug)]
pub enum Indices<'a> {
    U16(&'a [u16]),
    U32(&'a [u32]),
}

impl<'a> Indices<'a> {
    pub fn width(self) -> IndexWidth {
        match self {
            Indices::U16(_) => IndexWidth::U16,
            Indices::U32(_) => IndexWidth::U32,
        }
    }

    pub fn len(self) -> usize {
        dispatch!(Indices, self, v => v.len())
    }

    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// Index `i`, or `None` past the end.
    pub fn get(self, i: usize) -> Option<u32> {
        dispatch!(Indices, self, v => v.get(i).map(|&x| widen(x)))
    }

    /// The indices of `range`. Panics where `range` is out of bounds, as slice indexing does.
    pub fn slice(self, range: Range<usize>) -> Indices<'a> {
        dispatch!(Indices, self, v => v[range].into())
    }

    /// The indices of `range`, or `None` where it is out of bounds (`slice::get`).
    pub fn get_range(self, range: Range<usize>) -> Option<Indices<'a>> {
        dispatch!(Indices, self, v => v.get(range).map(Into::into))
    }

    /// Copies the indices into `out`, widened to `u32`. Panics where the lengths differ, as
    /// `copy_from_slice` does.
    pub fn copy_to(self, out: &mut [u32]) {
        assert_eq!(out.len(), self.len(), "copy_to: lengths differ");
        dispatch!(Indices, self, v => {
            for (o, &x) in out.iter_mut().zip(v) {
                *o = widen(x);
            }
        })
    }

    /// Appends `f(k, index)` to `out` for the `k`-th index, in order.
    pub fn extend_mapped<T>(self, out: &mut Vec<T>, mut f: impl FnMut(usize, u32) -> T) {
        dispatch!(Indices, self, v => out.extend(v.iter().enumerate().map(|(k, &x)| f(k, widen(x)))))
    }

    /// The indices widened to `u32`, a new vector.
    pub fn to_vec(self) -> Vec<u32> {
        let mut out = Vec::with_capacity(self.len());
        self.extend_mapped(&mut out, |_, v| v);
        out
    }
}

/// Empty.
impl Default for Indices<'_> {
    fn default() -> Self {
        Indices::U32(&[])
    }
}

/// Equal when they hold the same values, whatever their widths.
impl PartialEq for Indices<'_> {
    fn eq(&self, other: &Self) -> bool {
        match (*self, *other) {
            (Indices::U16(a), Indices::U16(b)) => a == b,
            (Indices::U32(a), Indices::U32(b)) => a == b,
            (a, b) => a.len() == b.len() && a.to_vec() == b.to_vec(),
        }
    }
}

impl Eq for Indices<'_> {}

impl<'a> From<&'a [u32]> for Indices<'a> {
    fn from(v: &'a [u32]) -> Self {
        Indices::U32(v)
    }
}

impl<'a> From<&'a [u16]> for Indices<'a> {
    fn from(v: &'a [u16]) -> Self {
        Indices::U16(v)
    }
}

impl<'a, const N: usize> From<&'a [u32; N]> for Indices<'a> {
    fn from(v: &'a [u32; N]) -> Self {
        Indices::U32(v)
    }
}

impl<'a> From<&'a Vec<u32>> for Indices<'a> {
    fn from(v: &'a Vec<u32>) -> Self {
        Indices::U32(v)
    }
}

impl<'a> From<&'a Vec<u16>> for Indices<'a> {
    fn from(v: &'a Vec<u16>) -> Self {
        Indices::U16(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_width_holds_every_vertex_and_reads_widen() {
        assert_eq!(IndexWidth::for_vertices(13_380), IndexWidth::U16);
        assert_eq!(IndexWidth::for_vertices(65_536), IndexWidth::U16);
        assert_eq!(IndexWidth::for_vertices(65_537), IndexWidth::U32);
        let narrow = IndexBuf::new(&[0, 65_535, 7], IndexWidth::U16);
        let wide = IndexBuf::new(&[0, 65_535, 7], IndexWidth::U32);
        assert_eq!(narrow.heap_bytes(), 6);
        assert_eq!(wide.heap_bytes(), 12);
        let (n, w) = (narrow.view(), wide.view());
        assert_eq!((n.width(), w.width()), (IndexWidth::U16, IndexWidth::U32));
        assert_eq!(n, w);
        assert_eq!(n.slice(1..3).to_vec(), [65_535, 7]);
        assert_eq!((n.get(1), n.get(3)), (Some(65_535), None));
        assert_eq!(n.get_range(2..4), None);
        let mut out = [0; 2];
        n.slice(0..2).copy_to(&mut out);
        assert_eq!(out, [0, 65_535]);
        let mut pairs = Vec::new();
        w.extend_mapped(&mut pairs, |k, v| (k, v));
        assert_eq!(pairs, [(0, 0), (1, 65_535), (2, 7)]);
    }
}
