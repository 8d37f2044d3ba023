//! The reduction rule set (module docs of `build`): a touched strip's unneeded runs cut
//! right to left, each cut recorded as a resize and its tokens' lifetimes kept.

use super::{degenerate, Tokens};
use crate::collapse::NEVER;
use crate::lodstrips::runtime::cut;
use crate::lodstrips::{
    kind_len, push_resize, ResizeRun, KIND_B, KIND_BC, KIND_BCC, KIND_C, KIND_NONE,
};

/// A strip's region of the build buffer with the token bookkeeping beside it.
pub(super) struct Region<'a> {
    pub(super) values: &'a mut [u32],
    pub(super) tokens: &'a mut Tokens,
    /// Start of the region in the whole buffer (and in `tokens.at`).
    pub(super) base: usize,
    /// The LOD from which this step's cuts hold (the step index + 1).
    pub(super) death: u32,
}

impl Region<'_> {
    /// Cuts `values[i..i+len]` of the live `values[..live]` like
    /// [`cut`], and records the lifetimes: the run's tokens die, the
    /// replacement's copies are born and linked after the run's last token.
    fn cut(&mut self, live: usize, i: usize, len: usize, kind: u16) -> usize {
        let at = &mut self.tokens.at[self.base..self.base + live];
        let mut link = at[i + len - 1];
        let after_run = self.tokens.next[link as usize];
        for &t in &at[i..i + len] {
            self.tokens.death[t as usize] = self.death;
        }
        let copy_count = kind_len(kind);
        for k in 0..copy_count {
            // Cuts write B copies first, then C copies (see `cut`).
            let from = if k == 0 && kind != KIND_C {
                i - 1
            } else {
                i + len
            };
            let id = (self.tokens.death.len()) as u32;
            self.tokens.copies.push((self.values[from], self.death));
            self.tokens.death.push(NEVER);
            self.tokens.next.push(after_run);
            self.tokens.next[link as usize] = id;
            link = id;
            at[i + k] = id;
        }
        at.copy_within(i + len..live, i + copy_count);
        cut(&mut self.values[..live], i, len, kind)
    }
}

/// Cuts the unneeded runs of the strip `region[..live]` right to left,
/// appending one record per cut; returns the new live length and the count.
/// Records name the strip by its rewrite group in this step (`group`): a
/// strip is only reduced where the step rewrote it, and the index is smaller.
pub(super) fn reduce(
    mut region: Region,
    live: usize,
    group: u32,
    needed: &mut Vec<bool>,
    out: &mut Vec<u8>,
) -> (usize, u32) {
    needed.clear();
    needed.resize(live, false);
    for k in 0..live.saturating_sub(2) {
        if !degenerate(region.values[k], region.values[k + 1], region.values[k + 2]) {
            needed[k..k + 3].fill(true);
        }
    }
    let mut current = live;
    let mut count = 0;
    let mut j = live;
    while j > 0 {
        if needed[j - 1] {
            j -= 1;
            continue;
        }
        let mut i = j;
        while i > 0 && !needed[i - 1] {
            i -= 1;
        }
        let cut_at = if j == current {
            Some((i, j - i, KIND_NONE))
        } else if i == 0 {
            let len = j & !1;
            (len > 0).then_some((0, len, KIND_NONE))
        } else {
            junction(&region.values[..current], i, j).map(|kind| (i, j - i, kind))
        };
        if let Some((at, len, kind)) = cut_at {
            let values = &region.values[..current];
            push_resize(out, group, at as u32, kind, ResizeRun::new(values, at, len));
            current = region.cut(current, at, len, kind);
            count += 1;
        }
        j = i;
    }
    (current, count)
}

/// The shortest replacement for the interior run `strip[i..j]` that keeps
/// length parity and leaves every junction window degenerate, if shorter.
fn junction(strip: &[u32], i: usize, j: usize) -> Option<u16> {
    let len = j - i;
    let b = strip[i - 1];
    let c = strip[j];
    let a = i.checked_sub(2).map(|k| strip[k]);
    let d = strip.get(j + 1).copied();
    let candidates: &[u16] = if len.is_multiple_of(2) {
        &[KIND_NONE, KIND_BC]
    } else {
        &[KIND_B, KIND_C, KIND_BCC]
    };
    candidates.iter().copied().find(|&kind| {
        if kind_len(kind) >= len {
            return false;
        }
        let mut seq = [0u32; 7];
        let mut n = 0;
        let mut put = |v: u32| {
            seq[n] = v;
            n += 1;
        };
        if let Some(a) = a {
            put(a);
        }
        put(b);
        match kind {
            KIND_B => put(b),
            KIND_C => put(c),
            KIND_BC => {
                put(b);
                put(c);
            }
            KIND_BCC => {
                put(b);
                put(c);
                put(c);
            }
            _ => {}
        }
        put(c);
        if let Some(d) = d {
            put(d);
        }
        seq[..n].windows(3).all(|w| degenerate(w[0], w[1], w[2]))
    })
}
