//! A strictly increasing sequence of `u32` (a frame's LODs where the error grows, and the
//! error keys there) in the smaller of two forms: a [`Narrow`] array, or a bitmap over the
//! sequence's range with one bit per possible value, the count of the set bits before each
//! word and the bit of every [`PICK_VALUES`]th value. Where the values are dense in their
//! range (a frame's error table: a growth every ~3 LODs, keys a few thousand bfloat16 steps
//! apart at most) that takes 3–5 bits per value against 16 or 32.
//!
//! Both questions the error lookup asks cost a few loads, whatever the sequence's length:
//! how many values are at most `x` (the count before `x`'s word and the set bits of one word)
//! and the `i`-th value (the kept bit of value `i - i % PICK_VALUES`, then the set bits of
//! the few words from there). A crowd asks once per instance per frame, mostly of tables the
//! frame's other work has pushed out of the cache: each question reads two of them, the
//! counts or the kept bits and then the words (without the `popcnt` instruction, not in the
//! baseline x86-64 target, a word's bit count is a dozen instructions, cheaper than a miss).

use super::packed::Narrow;

/// Values per kept bit: value `i` is found from the bit of value `i - i % PICK_VALUES`, a
/// few words before it where the values are dense.
const PICK_VALUES: usize = 32;

/// See the module docs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Increasing {
    Plain(Narrow),
    Bits {
        /// The value of bit 0 (the sequence's first value).
        base: u32,
        /// Bit `x` set where `base + x` is in the sequence.
        words: Box<[u64]>,
        /// `ranks[w]`: the set bits in `words[..w]` (`words.len() + 1` entries, the last the
        /// sequence's length).
        ranks: Narrow,
        /// `picks[j]`: the bit of value `j * PICK_VALUES`.
        picks: Narrow,
    },
}

impl Default for Increasing {
    fn default() -> Self {
        Increasing::Plain(Narrow::default())
    }
}

impl Increasing {
    /// `values`, strictly increasing, in whichever form takes fewer bytes.
    pub(crate) fn new(values: &[u32]) -> Increasing {
        debug_assert!(values.windows(2).all(|w| w[0] < w[1]));
        let plain = Narrow::new(values.last().copied().unwrap_or(0), values.iter().copied());
        let (Some(&base), Some(&last)) = (values.first(), values.last()) else {
            return Increasing::Plain(plain);
        };
        // Bits `0..=span` (no overflow where the values span all of `u32`).
        let span = last - base;
        let words = span as usize / 64 + 1;
        let picks = Narrow::new(span, values.iter().step_by(PICK_VALUES).map(|&v| v - base));
        // The counts' width follows the largest, the length (as `Narrow` picks it).
        let count_bytes = if u16::try_from(values.len()).is_ok() {
            2
        } else {
            4
        };
        if words * 8 + (words + 1) * count_bytes + picks.byte_size() >= plain.byte_size() {
            return Increasing::Plain(plain);
        }
        let mut map = vec![0u64; words];
        for &v in values {
            let x = (v - base) as usize;
            map[x / 64] |= 1 << (x % 64);
        }
        let mut ranks = Vec::with_capacity(words + 1);
        let mut ones = 0;
        for word in &map {
            ranks.push(ones);
            ones += word.count_ones();
        }
        ranks.push(ones);
        Increasing::Bits {
            base,
            words: map.into(),
            ranks: Narrow::new(ones, ranks),
            picks,
        }
    }

    pub(crate) fn len(&self) -> usize {
        match self {
            Increasing::Plain(v) => v.len(),
            Increasing::Bits { ranks, .. } => ranks.get(ranks.len() - 1) as usize,
        }
    }

    /// Value `i` (`i < len()`).
    pub(crate) fn get(&self, i: usize) -> u32 {
        let (base, words, picks) = match self {
            Increasing::Plain(v) => return v.get(i),
            Increasing::Bits {
                base, words, picks, ..
            } => (*base, words, picks),
        };
        debug_assert!(i < self.len());
        // From the kept value's bit, the words on to the one that holds value `i`: their
        // bits counted, not the counts per word read (one cache miss fewer on a cold table).
        let from = picks.get(i / PICK_VALUES) as usize;
        let mut left = (i % PICK_VALUES) as u32;
        let mut w = from / 64;
        let mut word = words[w] & (u64::MAX << (from % 64));
        loop {
            let ones = word.count_ones();
            if left < ones {
                return base + (w * 64) as u32 + select(word, left);
            }
            left -= ones;
            w += 1;
            word = words[w];
        }
    }

    /// The number of values at most `x`.
    pub(crate) fn count_at_most(&self, x: u32) -> usize {
        let (base, words, ranks) = match self {
            Increasing::Plain(v) => return v.partition_point(|v| v <= x),
            Increasing::Bits {
                base, words, ranks, ..
            } => (*base, words, ranks),
        };
        if x < base {
            return 0;
        }
        // Bits `..end` are the values at most `x`.
        let end = ((x - base) as usize + 1).min(words.len() * 64);
        let (w, bit) = (end / 64, end % 64);
        let mut ones = ranks.get(w);
        if bit > 0 {
            ones += (words[w] << (64 - bit)).count_ones();
        }
        ones as usize
    }

    /// Heap bytes.
    pub(crate) fn byte_size(&self) -> usize {
        match self {
            Increasing::Plain(v) => v.byte_size(),
            Increasing::Bits {
                words,
                ranks,
                picks,
                ..
            } => words.len() * 8 + ranks.byte_size() + picks.byte_size(),
        }
    }
}

/// Bytes whose high bit is the comparison's result (the broadword tricks of `select`).
const HIGH: u64 = 0x8080_8080_8080_8080;
const ONES: u64 = 0x0101_0101_0101_0101;

/// `SELECT_IN_BYTE[b][k]`: the bit of the `k`-th set bit of byte `b` (8 where none).
const SELECT_IN_BYTE: [[u8; 8]; 256] = {
    let mut table = [[8u8; 8]; 256];
    let mut b = 0;
    while b < 256 {
        let (mut bit, mut k) = (0, 0);
        while bit < 8 {
            if b >> bit & 1 == 1 {
                table[b][k] = bit as u8;
                k += 1;
            }
            bit += 1;
        }
        b += 1;
    }
    table
};

/// The bit of the `k`-th set bit of `word` (`k < word.count_ones()`), without a loop or a bit
/// count instruction: the running counts of the word's bytes side by side in one `u64`, the
/// byte where the count passes `k` from a comparison of all eight at once, then a table for
/// the bit within that byte (Vigna, "Broadword implementation of rank/select queries", 2008).
#[inline]
fn select(word: u64, k: u32) -> u32 {
    // Ones per byte, then per byte the ones up to and including it.
    let mut s = word - ((word >> 1) & 0x5555_5555_5555_5555);
    s = (s & 0x3333_3333_3333_3333) + ((s >> 2) & 0x3333_3333_3333_3333);
    s = (s + (s >> 4)) & 0x0F0F_0F0F_0F0F_0F0F;
    let running = s.wrapping_mul(ONES);
    // High bit of byte `j` set where the running count there is at most `k` (counts ≤ 64,
    // so no byte borrows from the next): that many bytes lie wholly before the bit.
    let at_most = (((u64::from(k) * ONES) | HIGH) - running) & HIGH;
    let byte = ((at_most >> 7).wrapping_mul(ONES) >> 56) as u32;
    let before = if byte == 0 {
        0
    } else {
        ((running >> (8 * byte - 8)) & 0xFF) as u32
    };
    let in_byte = ((word >> (8 * byte)) & 0xFF) as usize;
    8 * byte + u32::from(SELECT_IN_BYTE[in_byte][(k - before) as usize])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `values` in both forms, whichever `new` picks first.
    fn both(values: &[u32]) -> [Increasing; 2] {
        let picked = Increasing::new(values);
        let plain = Increasing::Plain(Narrow::new(
            values.last().copied().unwrap_or(0),
            values.iter().copied(),
        ));
        [picked, plain]
    }

    proptest! {
        /// Both forms give every value and every threshold count of the plain sequence.
        #[test]
        fn answers_as_the_sorted_values(
            mut values in prop::collection::vec(0u32..5000, 0..400),
            base in prop_oneof![Just(0u32), Just(70_000u32), Just(u32::MAX - 6000)],
            probes in prop::collection::vec(0u32..5100, 1..20),
        ) {
            values.sort_unstable();
            values.dedup();
            let values: Vec<u32> = values.iter().map(|v| v + base).collect();
            for seq in both(&values) {
                prop_assert_eq!(seq.len(), values.len());
                for (i, &v) in values.iter().enumerate() {
                    prop_assert_eq!(seq.get(i), v);
                }
                for &p in &probes {
                    let x = base.saturating_add(p);
                    prop_assert_eq!(seq.count_at_most(x), values.partition_point(|&v| v <= x));
                }
                prop_assert_eq!(seq.count_at_most(u32::MAX), values.len());
                prop_assert_eq!(seq.count_at_most(0), usize::from(values.first() == Some(&0)));
            }
        }
    }

    /// The `k`-th set bit of a word, against clearing the lowest bits one by one.
    #[test]
    fn select_finds_every_set_bit() {
        let mut state = 7;
        for word in [1u64, u64::MAX, 1 << 63, 0x8000_0001]
            .into_iter()
            .chain((0..200).map(|_| crate::random::next_random(&mut state)))
        {
            let mut rest = word;
            for k in 0..word.count_ones() {
                assert_eq!(select(word, k), rest.trailing_zeros(), "{word:#x} {k}");
                rest &= rest - 1;
            }
        }
    }

    /// Dense values take the bitmap (at most 5 bits each at one value in three); sparse ones
    /// the array.
    #[test]
    fn picks_the_smaller_form() {
        let dense: Vec<u32> = (0..1000).map(|i| 3 * i + 1).collect();
        let seq = Increasing::new(&dense);
        assert!(matches!(seq, Increasing::Bits { .. }));
        assert!(
            seq.byte_size() * 8 <= dense.len() * 5,
            "{}",
            seq.byte_size()
        );
        let sparse: Vec<u32> = (0..100).map(|i| 1000 * i).collect();
        assert!(matches!(Increasing::new(&sparse), Increasing::Plain(_)));
        // Values across all of `u32`: no overflow, the array.
        let wide = Increasing::new(&[0, 5, u32::MAX]);
        assert!(matches!(wide, Increasing::Plain(_)));
        assert_eq!((wide.count_at_most(u32::MAX), wide.get(2)), (3, u32::MAX));
        assert_eq!(Increasing::new(&[]).len(), 0);
        assert_eq!(Increasing::new(&[]).count_at_most(u32::MAX), 0);
    }
}
