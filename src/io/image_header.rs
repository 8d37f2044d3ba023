//! The format and pixel size of an encoded texture, read from its header without decoding it
//! (the `image` crate is only in the `gpu` feature): enough to refuse a file that is not a PNG
//! or JPEG image at load time, and for `morphlod info` to report its dimensions.

use crate::morph::ImageFormat;

/// Width and height in pixels of an encoded image, by its magic bytes: PNG (the `IHDR`
/// chunk that must come first) or JPEG (the first start-of-frame segment). `Err` says what
/// is wrong when the bytes are neither, or the header is cut short or names no pixels.
pub fn image_size(bytes: &[u8]) -> Result<(ImageFormat, u32, u32), String> {
    const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";
    if bytes.starts_with(PNG) {
        return png_size(bytes).map(|(w, h)| (ImageFormat::Png, w, h));
    }
    if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return jpeg_size(bytes).map(|(w, h)| (ImageFormat::Jpeg, w, h));
    }
    let head: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02X}")).collect();
    Err(format!(
        "is neither a PNG nor a JPEG image (it starts with the bytes [{}]); glTF base-colour textures must be image/png or image/jpeg",
        head.join(" ")
    ))
}

fn nonzero(width: u32, height: u32, what: &str) -> Result<(u32, u32), String> {
    if width == 0 || height == 0 {
        return Err(format!("{what} image of {width} x {height} pixels"));
    }
    Ok((width, height))
}

/// PNG: signature, then the IHDR chunk (length 13, type, width, height, big-endian).
fn png_size(bytes: &[u8]) -> Result<(u32, u32), String> {
    let be = |at: usize| {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    };
    match (bytes.get(12..16), be(16), be(20)) {
        (Some(b"IHDR"), Some(w), Some(h)) => nonzero(w, h, "a PNG"),
        (Some(_), Some(_), Some(_)) => {
            Err("is a PNG whose first chunk is not IHDR (corrupt)".to_string())
        }
        _ => Err(format!(
            "is a PNG cut short ({} bytes) before the end of its header",
            bytes.len()
        )),
    }
}

/// JPEG: walks the marker segments from SOI to the first SOFn (baseline, progressive,
/// lossless, arithmetic: `C0..=CF` except `C4` DHT, `C8` JPG, `CC` DAC), whose payload holds
/// the precision byte, then height and width (big-endian).
fn jpeg_size(bytes: &[u8]) -> Result<(u32, u32), String> {
    let mut at = 2;
    loop {
        // Markers may be preceded by any number of 0xFF fill bytes.
        while bytes.get(at) == Some(&0xFF) && bytes.get(at + 1) == Some(&0xFF) {
            at += 1;
        }
        let (Some(&0xFF), Some(&marker)) = (bytes.get(at), bytes.get(at + 1)) else {
            return Err(format!(
                "is a JPEG without a frame header (no start-of-frame marker before byte {at}): truncated or corrupt"
            ));
        };
        at += 2;
        // Standalone markers (TEMn, RSTn) carry no length.
        if marker == 0x01 || (0xD0..=0xD7).contains(&marker) {
            continue;
        }
        if marker == 0xD9 || marker == 0xDA {
            return Err(
                "is a JPEG whose image data starts before any frame header (corrupt)".to_string(),
            );
        }
        let Some(length) = bytes
            .get(at..at + 2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]) as usize)
        else {
            return Err(format!("is a JPEG cut short at byte {at}"));
        };
        if matches!(marker, 0xC0..=0xCF) && !matches!(marker, 0xC4 | 0xC8 | 0xCC) {
            let be16 = |i: usize| {
                bytes
                    .get(i..i + 2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]]) as u32)
            };
            return match (be16(at + 3), be16(at + 5)) {
                (Some(h), Some(w)) => nonzero(w, h, "a JPEG"),
                _ => Err(format!(
                    "is a JPEG cut short in its frame header at byte {at}"
                )),
            };
        }
        if length < 2 {
            return Err(format!(
                "is a JPEG with a segment length {length} at byte {at} (corrupt)"
            ));
        }
        at += length;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_png_and_jpeg_headers_and_refuses_the_rest() {
        let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR".to_vec();
        png.extend(640u32.to_be_bytes());
        png.extend(480u32.to_be_bytes());
        assert_eq!(image_size(&png), Ok((ImageFormat::Png, 640, 480)));
        assert!(image_size(&png[..18]).unwrap_err().contains("cut short"));

        // SOI, an APP0 segment of length 16, then SOF0 (length 17, precision 8, height 200,
        // width 300).
        let mut jpeg = vec![0xFF, 0xD8, 0xFF, 0xE0, 0, 16];
        jpeg.extend([0u8; 14]);
        let sof = jpeg.len();
        jpeg.extend([0xFF, 0xC0, 0, 17, 8, 0, 200, 0x01, 0x2C]);
        assert_eq!(image_size(&jpeg), Ok((ImageFormat::Jpeg, 300, 200)));
        assert!(image_size(&jpeg[..sof + 5]).is_err());
        assert!(image_size(&[0xFF, 0xD8, 0xFF, 0xDA, 0, 2])
            .unwrap_err()
            .contains("corrupt"));

        let err = image_size(b"GIF89a....").unwrap_err();
        assert!(err.contains("neither a PNG nor a JPEG"), "{err}");
        assert!(err.contains("47 49 46"), "{err}");
    }
}
