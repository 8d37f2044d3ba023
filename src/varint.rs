//! LEB128 variable-length integers and zigzag signed-to-unsigned mapping: the one
//! implementation shared by the `.mlod` file sections ([`asset`](crate::asset)) and the
//! LodStrips change streams ([`lodstrips`](crate::lodstrips)).
//!
//! LEB128: 7 bits per byte, low group first, the top bit set on every byte but the last.
//! Zigzag: `0, -1, 1, -2, 2, …` → `0, 1, 2, 3, 4, …`, so small differences of either sign
//! take one byte.

/// Appends `value` as LEB128 (1 to 10 bytes).
#[inline]
pub(crate) fn put(out: &mut Vec<u8>, mut value: u64) {
    while value >= 0x80 {
        out.push(value as u8 | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}

/// Appends a 32-bit `value` as LEB128 (1 to 5 bytes; the same bytes as [`put`]).
#[inline]
pub(crate) fn put_u32(out: &mut Vec<u8>, value: u32) {
    put(out, u64::from(value));
}

/// Bytes [`put_u32`] takes for `value` (1 for 0).
#[inline]
pub(crate) fn len_u32(value: u32) -> usize {
    (32 - (value | 1).leading_zeros() as usize).div_ceil(7)
}

/// Reads a number written by [`put_u32`] at `*at`, advancing `*at`. For streams this
/// program wrote itself (the change lists): no bounds or overflow checks beyond slice
/// indexing. Untrusted bytes go through [`read`].
#[inline]
pub(crate) fn read_u32(stream: &[u8], at: &mut usize) -> u32 {
    let mut v = 0u32;
    let mut shift = 0;
    loop {
        let b = stream[*at];
        *at += 1;
        v |= u32::from(b & 0x7F) << shift;
        if b & 0x80 == 0 {
            return v;
        }
        shift += 7;
    }
}

/// Why [`read`] refused the bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Malformed {
    /// The bytes end inside the number.
    Truncated,
    /// More than 64 bits.
    Overflow,
}

/// Reads a LEB128 number from untrusted bytes at `*pos`, advancing `*pos` past the bytes
/// consumed.
pub(crate) fn read(data: &[u8], pos: &mut usize) -> Result<u64, Malformed> {
    let mut value = 0u64;
    for shift in (0..64).step_by(7) {
        let Some(&byte) = data.get(*pos) else {
            return Err(Malformed::Truncated);
        };
        *pos += 1;
        let bits = u64::from(byte & 0x7F);
        if shift == 63 && bits > 1 {
            break;
        }
        value |= bits << shift;
        if byte < 0x80 {
            return Ok(value);
        }
    }
    Err(Malformed::Overflow)
}

/// Zigzag of a signed 64-bit difference.
#[inline]
pub(crate) fn zigzag(delta: i64) -> u64 {
    ((delta << 1) ^ (delta >> 63)) as u64
}

/// Inverse of [`zigzag`].
#[inline]
pub(crate) fn unzigzag(value: u64) -> i64 {
    (value >> 1) as i64 ^ -((value & 1) as i64)
}

/// Zigzag of a signed 32-bit difference.
#[inline]
pub(crate) fn zigzag32(delta: i32) -> u32 {
    ((delta << 1) ^ (delta >> 31)) as u32
}

/// Inverse of [`zigzag32`].
#[inline]
pub(crate) fn unzigzag32(value: u32) -> i32 {
    ((value >> 1) as i32) ^ -((value & 1) as i32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for v in [0u64, 1, 127, 128, 300, u64::from(u32::MAX), u64::MAX] {
            let mut out = Vec::new();
            put(&mut out, v);
            let mut pos = 0;
            assert_eq!(read(&out, &mut pos), Ok(v));
            assert_eq!(pos, out.len());
            if let Ok(v32) = u32::try_from(v) {
                let mut at = 0;
                assert_eq!(read_u32(&out, &mut at), v32);
                assert_eq!(len_u32(v32), out.len());
            }
        }
        for d in [0i64, -1, 1, -2, i64::MIN, i64::MAX] {
            assert_eq!(unzigzag(zigzag(d)), d);
        }
        for d in [0i32, -1, 1, i32::MIN, i32::MAX] {
            assert_eq!(unzigzag32(zigzag32(d)), d);
        }
        assert_eq!(read(&[0x80], &mut 0), Err(Malformed::Truncated));
        assert_eq!(read(&[0xFF; 10], &mut 0), Err(Malformed::Overflow));
    }
}
