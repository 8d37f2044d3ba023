//! The bit-level coder of one frame's collapse sequence (the format is in the module docs
//! of [`asset`](super), "Frame coding"). Encoder and decoder sit side by side; the
//! constants that fix the format come first: changing any of them changes the file format
//! and needs a new [`VERSION`](super::VERSION).

use super::reader::Reader;
use super::AssetError;
use crate::collapse::{Collapse, CollapseSequence, SequenceError, NEVER};
use crate::strip::Strips;
use crate::varint;

/// Frame mode byte: the same sequence as the previous frame.
pub(super) const FRAME_REPEAT: u8 = 0;
/// Frame mode byte: a coded sequence follows.
pub(super) const FRAME_CODED: u8 = 1;
/// Exp-Golomb prefixes longer than this cannot encode a value the format uses.
const MAX_PREFIX: u32 = 40;
/// Largest exp-Golomb orders tried for the two symbol streams.
const MAX_ORDER_W: u32 = 8;
const MAX_ORDER_ERROR: u32 = 16;

fn best_order(values: &[u64], max: u32) -> u32 {
    (0..=max)
        .min_by_key(|&k| values.iter().map(|&x| exp_golomb_len(x, k)).sum::<u64>())
        .unwrap_or(0)
}

/// Rounds a collapse error to what the file keeps: bfloat16 (round to
/// nearest even), clamped to `[0, largest finite]`; NaN reads as 0. The
/// builder applies it so a built asset survives its file unchanged.
pub fn quantize_error(error: f32) -> f32 {
    let e = error.max(0.0);
    let bits = e.to_bits();
    let rounded = bits.wrapping_add(0x7FFF + ((bits >> 16) & 1)) & 0xFFFF_0000;
    let q = f32::from_bits(rounded);
    if q.is_finite() {
        q
    } else {
        f32::from_bits(0x7F7F_0000)
    }
}

/// Each vertex's neighbours in the triangles `S0` draws, sorted, in CSR
/// form: the alphabet of the `w` symbols. Encoder and decoder build it from
/// the same strips, so it only has to be deterministic, not "the" mesh adjacency.
pub(super) struct Neighbours {
    offsets: Vec<u32>,
    list: Vec<u32>,
}

impl Neighbours {
    pub(super) fn new(s0: &Strips, n: usize) -> Self {
        let triangles: Vec<[u32; 3]> = s0
            .triangles()
            .into_iter()
            .filter(|t| t.iter().all(|&v| (v as usize) < n))
            .collect();
        let mut start = vec![0usize; n + 1];
        for t in &triangles {
            for &v in t {
                start[v as usize + 1] += 2;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut all = vec![0u32; start[n]];
        for t in &triangles {
            for c in 0..3 {
                let v = t[c] as usize;
                all[fill[v]] = t[(c + 1) % 3];
                all[fill[v] + 1] = t[(c + 2) % 3];
                fill[v] += 2;
            }
        }
        let mut offsets = Vec::with_capacity(n + 1);
        let mut list = Vec::with_capacity(all.len());
        offsets.push(0);
        for v in 0..n {
            let fan = &mut all[start[v]..start[v + 1]];
            fan.sort_unstable();
            let from = list.len();
            list.extend_from_slice(fan);
            let mut kept = from;
            for i in from..list.len() {
                if i == from || list[i] != list[kept - 1] {
                    list[kept] = list[i];
                    kept += 1;
                }
            }
            list.truncate(kept);
            offsets.push(list.len() as u32);
        }
        Self { offsets, list }
    }

    /// Neighbours of `v`; empty for a vertex out of range.
    fn of(&self, v: u32) -> &[u32] {
        let v = v as usize;
        match (self.offsets.get(v), self.offsets.get(v + 1)) {
            (Some(&a), Some(&b)) => &self.list[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// The survivor of `x`: union-find root with path halving. Every link goes
/// from a vertex that collapses to one still alive, so the forest has no cycle.
fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let grand = parent[parent[x as usize] as usize];
        parent[x as usize] = grand;
        x = grand;
    }
    x
}

/// A coded frame (see the module docs). Replays the survivors so that `w`
/// can be named by a neighbour of `u`; collapses that break the sequence
/// rules are written with escapes and left for the decoder to refuse.
pub(super) fn encode_frame(seq: &CollapseSequence, n: usize, neighbours: &Neighbours) -> Vec<u8> {
    let largest = seq
        .collapses
        .iter()
        .map(|c| c.u.max(c.w))
        .chain([n.saturating_sub(1) as u32])
        .max()
        .unwrap_or(0);
    let width = (32 - largest.leading_zeros()).max(1);
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut symbols = Vec::with_capacity(seq.len());
    let mut errors = Vec::with_capacity(seq.len());
    let mut prev_error = 0i64;
    for c in &seq.collapses {
        let fan = neighbours.of(c.u);
        let valid = (c.u as usize) < n
            && (c.w as usize) < n
            && c.u != c.w
            && parent[c.u as usize] == c.u
            && parent[c.w as usize] == c.w;
        let symbol = if valid {
            fan.iter()
                .position(|&y| find(&mut parent, y) == c.w)
                .unwrap_or(fan.len())
        } else {
            fan.len()
        };
        if valid {
            parent[c.u as usize] = c.w;
        }
        symbols.push(symbol as u64);
        let bits = i64::from(quantize_error(c.error).to_bits() >> 16);
        errors.push(varint::zigzag(bits - prev_error));
        prev_error = bits;
    }
    let order_w = best_order(&symbols, MAX_ORDER_W);
    let order_error = best_order(&errors, MAX_ORDER_ERROR);
    let mut head = vec![FRAME_CODED, width as u8, order_w as u8, order_error as u8];
    varint::put(&mut head, seq.len() as u64);
    let mut w = BitWriter {
        out: head,
        acc: 0,
        bits: 0,
    };
    for ((c, &symbol), &error) in seq.collapses.iter().zip(&symbols).zip(&errors) {
        w.put(u64::from(c.u), width);
        w.exp_golomb(symbol, order_w);
        if symbol as usize == neighbours.of(c.u).len() {
            w.put(u64::from(c.w), width);
        }
        w.exp_golomb(error, order_error);
    }
    w.finish()
}

pub(super) fn decode_frame(
    data: &[u8],
    frame: usize,
    n: usize,
    neighbours: &Neighbours,
) -> Result<CollapseSequence, AssetError> {
    let mut r = Reader::new(data, "FRMS");
    let header = |name: &'static str| move || format!("frame {frame}'s {name}");
    let width = u32::from(r.byte(&header("index width"))?);
    let order_w = u32::from(r.byte(&header("neighbour code order"))?);
    let order_error = u32::from(r.byte(&header("error code order"))?);
    // (value, smallest, largest, name): a zero index width could not name a vertex.
    for (value, min, limit, name) in [
        (width, 1, 32, "index width"),
        (order_w, 0, MAX_ORDER_W, "neighbour code order"),
        (order_error, 0, MAX_ORDER_ERROR, "error code order"),
    ] {
        if value > limit || value < min {
            return Err(AssetError::CountTooLarge {
                tag: "FRMS",
                what: header(name)(),
                count: u64::from(value),
                limit: u64::from(limit),
            });
        }
    }
    // Each vertex collapses at most once, and each collapse takes at least
    // `width` bits for `u` and one bit for each of its two codes.
    let count = r.varint(&header("collapse count"))?;
    let limit = n.min(r.remaining() * 8 / (width as usize + 2));
    if count > limit as u64 {
        return Err(AssetError::CountTooLarge {
            tag: "FRMS",
            what: header("collapse count")(),
            count,
            limit: limit as u64,
        });
    }
    let count = count as usize;
    let sequence_error = |source| AssetError::Sequence { frame, source };
    let mut bits = BitReader {
        data: &data[r.pos..],
        pos: 0,
        acc: 0,
        bits: 0,
        frame,
    };
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut rank = vec![NEVER; n];
    let mut collapses = Vec::with_capacity(count);
    let mut prev_error = 0i64;
    for step in 0..count {
        // Both ends of an explicit collapse must name a vertex that is still alive: the
        // union-find below indexes with them.
        let live = |vertex: u32, rank: &[u32]| match rank.get(vertex as usize) {
            None => Err(sequence_error(SequenceError::VertexOutOfRange {
                step,
                vertex,
                vertices: n,
            })),
            Some(&r) if r != NEVER => Err(sequence_error(SequenceError::AlreadyCollapsed {
                step,
                vertex,
                earlier: r as usize,
            })),
            Some(_) => Ok(vertex),
        };
        let u = live(bits.get(width)? as u32, &rank)?;
        let fan = neighbours.of(u);
        let symbol = bits.exp_golomb(order_w)?;
        let w = match fan.get(symbol as usize) {
            Some(&y) => find(&mut parent, y),
            None if symbol as usize == fan.len() => live(bits.get(width)? as u32, &rank)?,
            None => {
                return Err(AssetError::NeighbourSymbol {
                    frame,
                    step,
                    vertex: u,
                    symbol,
                    neighbours: fan.len(),
                })
            }
        };
        if w == u {
            return Err(sequence_error(SequenceError::SelfCollapse {
                step,
                vertex: u,
            }));
        }
        let error_bits = prev_error.wrapping_add(varint::unzigzag(bits.exp_golomb(order_error)?));
        // 0x7F7F is the largest finite bfloat16 with the sign bit clear.
        if !(0..=0x7F7F).contains(&error_bits) {
            return Err(AssetError::BadError {
                frame,
                step,
                value: f32::from_bits((error_bits as u32) << 16),
            });
        }
        prev_error = error_bits;
        parent[u as usize] = w;
        rank[u as usize] = step as u32;
        collapses.push(Collapse {
            u,
            w,
            error: f32::from_bits((error_bits as u32) << 16),
        });
    }
    let used = r.pos + bits.pos;
    if used != data.len() {
        return Err(AssetError::FrameLength {
            frame,
            declared: data.len(),
            used,
        });
    }
    Ok(CollapseSequence {
        vertex_count: n as u32,
        collapses,
    })
}

struct BitWriter {
    out: Vec<u8>,
    acc: u64,
    bits: u32,
}

impl BitWriter {
    /// Appends the low `count` bits of `value`, `count <= 56`.
    fn put(&mut self, value: u64, count: u32) {
        self.acc |= (value & ((1u64 << count) - 1)) << self.bits;
        self.bits += count;
        while self.bits >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.bits -= 8;
        }
    }

    /// Exp-Golomb of order `k`: `x + 2^k` in binary, after as many zero bits
    /// as it has digits beyond `k + 1`.
    fn exp_golomb(&mut self, x: u64, k: u32) {
        let v = x + (1u64 << k);
        let digits = 64 - v.leading_zeros();
        let zeros = digits - 1 - k;
        self.put(1u64 << zeros, zeros + 1);
        self.put(v, digits - 1);
    }

    fn finish(mut self) -> Vec<u8> {
        if self.bits > 0 {
            self.out.push(self.acc as u8);
        }
        self.out
    }
}

fn exp_golomb_len(x: u64, k: u32) -> u64 {
    let digits = u64::from(64 - (x + (1u64 << k)).leading_zeros());
    2 * digits - 1 - u64::from(k)
}

struct BitReader<'a> {
    data: &'a [u8],
    pos: usize,
    acc: u64,
    bits: u32,
    frame: usize,
}

impl BitReader<'_> {
    fn truncated(&self) -> AssetError {
        AssetError::Truncated {
            tag: "FRMS",
            what: format!("frame {}'s collapses", self.frame),
        }
    }

    /// The next `count <= 56` bits.
    fn get(&mut self, count: u32) -> Result<u64, AssetError> {
        while self.bits < count {
            let Some(&byte) = self.data.get(self.pos) else {
                return Err(self.truncated());
            };
            self.acc |= u64::from(byte) << self.bits;
            self.pos += 1;
            self.bits += 8;
        }
        let value = self.acc & ((1u64 << count) - 1);
        self.acc >>= count;
        self.bits -= count;
        Ok(value)
    }

    fn exp_golomb(&mut self, k: u32) -> Result<u64, AssetError> {
        let mut zeros = 0;
        while self.get(1)? == 0 {
            zeros += 1;
            if zeros > MAX_PREFIX {
                return Err(AssetError::BadNumber {
                    tag: "FRMS",
                    what: format!("a number in frame {}", self.frame),
                });
            }
        }
        let rest = self.get(zeros + k)?;
        Ok(((1u64 << (zeros + k)) | rest) - (1u64 << k))
    }
}
