//! The surface sections of the `.mlod` file: "SURF" (what the renderer shades with: the
//! topology map, normals, UVs, colours, material) and "TEXR" (the base-colour texture),
//! each versioned and with its own CRC-32 (so a damaged texture is told apart from damaged
//! geometry), and the checks that tie a surface to the rest of the asset.
//!
//! ```text
//! "SURF"  version u8 (1) | flags u8 (bit 0 UVs, bit 1 colours, bit 2 material name)
//!         | topology count T LEB128 | per vertex its topology vertex LEB128 (< T)
//!         | n0, n1: vertices × f32 x, y, z | normal delta count K LEB128 (the blended
//!         targets, 0 without TGTS) | K × vertices × f32 x, y, z | UVs: vertices × f32 u, v
//!         | colours: vertices × f32 r, g, b, a | base colour 4 × f32
//!         | name: byte length LEB128, UTF-8 | CRC-32 of everything before it, u32
//! "TEXR"  version u8 (1) | format u8 (0 PNG, 1 JPEG) | mag filter, min filter u32 (0: none)
//!         | wrap s, wrap t u32 | byte length LEB128 | the encoded image | CRC-32 u32
//! ```

use super::reader::Reader;
use super::{u32_at, Asset, AssetError, Surface};
use crate::collapse::CollapseSequence;
use crate::morph::{ImageFormat, Material, Sampler, Texture};
use crate::seams::{check_steps, Wedges};
use crate::varint;
use std::collections::HashSet;
use std::sync::Arc;

/// The version of both sections this build writes and the newest it reads.
pub const SURFACE_VERSION: u8 = 1;

const HAS_UVS: u8 = 1;
const HAS_COLORS: u8 = 2;
const HAS_NAME: u8 = 4;

pub(super) fn floats(out: &mut Vec<u8>, values: impl IntoIterator<Item = f32>) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Appends the CRC-32 of `out` to it.
pub(super) fn seal(mut out: Vec<u8>) -> Vec<u8> {
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

pub(super) fn encode_surface(surface: &Surface) -> Vec<u8> {
    let material = &surface.material;
    let flags = [
        (surface.uvs.is_some(), HAS_UVS),
        (surface.colors.is_some(), HAS_COLORS),
        (material.name.is_some(), HAS_NAME),
    ]
    .iter()
    .filter(|(present, _)| *present)
    .fold(0, |flags, (_, bit)| flags | bit);
    let mut out = vec![SURFACE_VERSION, flags];
    let count = surface.topology.iter().max().map_or(0, |&t| t as u64 + 1);
    varint::put(&mut out, count);
    for &t in &surface.topology {
        varint::put(&mut out, u64::from(t));
    }
    floats(
        &mut out,
        surface.n0.iter().chain(&surface.n1).flatten().copied(),
    );
    varint::put(&mut out, surface.normal_deltas.len() as u64);
    floats(
        &mut out,
        surface.normal_deltas.iter().flatten().flatten().copied(),
    );
    if let Some(uvs) = &surface.uvs {
        floats(&mut out, uvs.iter().flatten().copied());
    }
    if let Some(colors) = &surface.colors {
        floats(&mut out, colors.iter().flatten().copied());
    }
    floats(&mut out, material.base_color);
    if let Some(name) = &material.name {
        varint::put(&mut out, name.len() as u64);
        out.extend_from_slice(name.as_bytes());
    }
    seal(out)
}

pub(super) fn encode_texture(texture: &Texture) -> Vec<u8> {
    let format = match texture.format {
        ImageFormat::Png => 0,
        ImageFormat::Jpeg => 1,
    };
    let mut out = vec![SURFACE_VERSION, format];
    let s = &texture.sampler;
    for v in [
        s.mag_filter.unwrap_or(0),
        s.min_filter.unwrap_or(0),
        s.wrap_s,
        s.wrap_t,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    varint::put(&mut out, texture.bytes.len() as u64);
    out.extend_from_slice(&texture.bytes);
    seal(out)
}

/// The section's bytes without its CRC and version, after checking the CRC and that the
/// version is 1 to `newest`.
pub(super) fn unseal<'a>(
    data: &'a [u8],
    tag: &'static str,
    newest: u8,
) -> Result<&'a [u8], AssetError> {
    if data.len() < 5 {
        return Err(AssetError::Truncated {
            tag,
            what: "the version and the checksum".into(),
        });
    }
    let (content, crc) = data.split_at(data.len() - 4);
    let stored = u32_at(crc, 0);
    let computed = crc32fast::hash(content);
    if stored != computed {
        return Err(AssetError::SectionChecksum {
            tag,
            stored,
            computed,
        });
    }
    if content[0] == 0 || content[0] > newest {
        return Err(AssetError::SectionVersion {
            tag,
            found: content[0],
            newest,
        });
    }
    Ok(&content[1..])
}

/// `count` records of `N` floats, all finite.
fn read_floats<const N: usize>(
    r: &mut Reader<'_>,
    count: usize,
    attribute: &'static str,
) -> Result<Vec<[f32; N]>, AssetError> {
    let bytes = r.bytes(count * N * 4, &|| format!("the {attribute} values"))?;
    bytes
        .chunks_exact(N * 4)
        .enumerate()
        .map(|(vertex, c)| {
            let v: [f32; N] = std::array::from_fn(|i| f32::from_bits(u32_at(c, 4 * i)));
            if v.iter().all(|x| x.is_finite()) {
                Ok(v)
            } else {
                Err(AssetError::NonFiniteAttribute { attribute, vertex })
            }
        })
        .collect()
}

/// Reads "SURF" for an asset of `n` vertices blending `targets` targets on the GPU (0 for a
/// two-pose asset). The material's texture is read from "TEXR" by [`decode_texture`].
pub(super) fn decode_surface(data: &[u8], n: usize, targets: usize) -> Result<Surface, AssetError> {
    let content = unseal(data, "SURF", SURFACE_VERSION)?;
    let mut r = Reader::new(content, "SURF");
    let flags = r.byte(&|| "the flags".into())?;
    if flags & !(HAS_UVS | HAS_COLORS | HAS_NAME) != 0 {
        return Err(AssetError::SurfaceFlags { flags });
    }
    let count = r.count(&|| "the topology vertex count".into(), n)?;
    if r.remaining() < n {
        return Err(AssetError::Truncated {
            tag: "SURF",
            what: format!("the topology map of {n} vertices"),
        });
    }
    let mut topology = Vec::with_capacity(n);
    for vertex in 0..n {
        let t = r.varint(&|| format!("vertex {vertex}'s topology vertex"))?;
        if t >= count as u64 {
            return Err(AssetError::SurfaceTopology {
                vertex,
                topology: t,
                count,
            });
        }
        topology.push(t as u32);
    }
    let n0 = read_floats::<3>(&mut r, n, "n0")?;
    let n1 = read_floats::<3>(&mut r, n, "n1")?;
    let deltas = r.count(
        &|| "the normal delta count".into(),
        crate::asset::MAX_TARGETS,
    )?;
    if deltas != targets {
        return Err(AssetError::NormalDeltaCount {
            found: deltas,
            targets,
        });
    }
    // Checked in full before allocating: `deltas` ≤ 64 and the bytes bound `n`.
    if (r.remaining() as u64) < deltas as u64 * n as u64 * 12 {
        return Err(AssetError::Truncated {
            tag: "SURF",
            what: format!("{deltas} targets' normal deltas"),
        });
    }
    let normal_deltas = (0..deltas)
        .map(|_| read_floats::<3>(&mut r, n, "normal delta"))
        .collect::<Result<Vec<_>, _>>()?;
    let uvs = match flags & HAS_UVS {
        0 => None,
        _ => Some(read_floats::<2>(&mut r, n, "UV")?),
    };
    let colors = match flags & HAS_COLORS {
        0 => None,
        _ => Some(read_floats::<4>(&mut r, n, "colour")?),
    };
    let base_color = read_floats::<4>(&mut r, 1, "base colour")?[0];
    let name = match flags & HAS_NAME {
        0 => None,
        _ => {
            let len = r.count(&|| "the material name's length".into(), r.remaining())?;
            let bytes = r.bytes(len, &|| "the material name".into())?;
            Some(String::from_utf8(bytes.to_vec()).map_err(|_| AssetError::MaterialName)?)
        }
    };
    r.finish()?;
    Ok(Surface {
        topology,
        n0,
        n1,
        normal_deltas,
        uvs,
        colors,
        material: Material {
            name,
            base_color,
            texture: None,
        },
    })
}

pub(super) fn decode_texture(data: &[u8]) -> Result<Texture, AssetError> {
    let content = unseal(data, "TEXR", SURFACE_VERSION)?;
    let mut r = Reader::new(content, "TEXR");
    let format = match r.byte(&|| "the image format".into())? {
        0 => ImageFormat::Png,
        1 => ImageFormat::Jpeg,
        code => return Err(AssetError::TextureFormat { code }),
    };
    let fixed = r.bytes(16, &|| "the sampler".into())?;
    let [mag, min, wrap_s, wrap_t] = [0, 4, 8, 12].map(|at| u32_at(fixed, at));
    let filter = |code: u32| (code != 0).then_some(code);
    let len = r.count(&|| "the image's length".into(), r.remaining())?;
    let bytes = r.bytes(len, &|| "the image".into())?.to_vec();
    r.finish()?;
    Ok(Texture {
        format,
        bytes,
        sampler: Sampler {
            mag_filter: filter(mag),
            min_filter: filter(min),
            wrap_s,
            wrap_t,
        },
    })
}

/// The checks that tie a decoded surface to the asset: copies of one topology vertex sit
/// at one position in both poses and move alike in every blended target (else a seam would
/// open while drawing), and every distinct frame moves whole topology vertices
/// ([`check_steps`]).
pub(super) fn check_surface(asset: &Asset, surface: &Surface) -> Result<(), AssetError> {
    let count = surface.topology.iter().max().map_or(0, |&t| t as usize + 1);
    let mut first = vec![u32::MAX; count];
    let bits = |p: &[f32; 3]| p.map(f32::to_bits);
    for (v, &t) in surface.topology.iter().enumerate() {
        let f = &mut first[t as usize];
        if *f == u32::MAX {
            *f = v as u32;
            continue;
        }
        let f = *f as usize;
        let apart = bits(&asset.v0[v]) != bits(&asset.v0[f])
            || bits(&asset.v1[v]) != bits(&asset.v1[f])
            || asset
                .blend
                .iter()
                .flat_map(|b| &b.deltas)
                .any(|d| bits(&d[v]) != bits(&d[f]));
        if apart {
            return Err(AssetError::SurfaceWeld {
                vertex: v,
                first: f,
            });
        }
    }
    let wedges = Wedges::new(&surface.topology);
    let mut checked: HashSet<*const CollapseSequence> = HashSet::new();
    for (frame, seq) in asset.frames.iter().enumerate() {
        if !checked.insert(Arc::as_ptr(seq)) {
            continue;
        }
        check_steps(seq, &wedges, &surface.topology)
            .map_err(|source| AssetError::SurfaceSteps { frame, source })?;
    }
    Ok(())
}
