//! Helpers shared by the oracle tests (tests/suite/oracle.rs, tests/suite/oracle_deform.rs):
//! a seeded RNG, random collapse sequences, the reference multiset hash of
//! every LOD in one pass, and a GPU mirror updated only through the dirty log;
//! and by the quality tables (tests/suite/simplify_quality.rs, tests/suite/deform_quality.rs):
//! the peer simplifier, meshopt, run the same way for both, and the LOD search; and by the
//! asset-file tests (tests/suite/asset_file.rs, tests/asset_alloc.rs): the grid morph fixture and
//! the header repair; and by every GPU test (`gpu`: one device set-up, buffer read-back and the
//! decoding of what an indirect multi-draw draws).
//!
//! `strip_draw` decodes strips the way the GPU assembles them (Vulkan's triangle-strip rules,
//! written here from the specification, not from `morphlod::strip`), so a parity rule flipped in
//! both the stripifier and the library's own decoder still fails the oracles.
//!
//! The suite (tests/suite/main.rs) and the binaries that measure the whole process (tests/*.rs)
//! compile this module; each uses a subset of it.
#![allow(dead_code)]

#[cfg(feature = "gpu")]
pub mod gpu;
pub mod skinned;
pub mod validator;

use morphlod::asset::HEADER_LEN;
use morphlod::collapse::{canonical, Collapse, CollapseSequence};
use morphlod::lodstrips::{Dirty, Indices};
use morphlod::metrics::{directed_error, sample_surface, symmetric, ErrorStats, SurfaceIndex};
use morphlod::morph::Morph;

/// A fresh, empty directory for one test's files, `<area>_<name>` under cargo's scratch
/// directory for integration tests (`CARGO_TARGET_TMPDIR`): the suite is one process, so the
/// area (the test module) keeps two modules' names apart.
pub fn scratch_dir(area: &str, name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{area}_{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The one skip rule of every test that needs what a machine may lack (a GPU adapter, node
/// and the pinned npm packages): under CI ([`morphlod::ci::is_ci`]) the missing piece is a
/// failure and this panics with `why`; elsewhere it prints `why` and the caller returns early.
pub fn skip_outside_ci(why: &str) {
    assert!(
        !morphlod::ci::is_ci(),
        "{why} (CI is set: a CI run must not skip this test)"
    );
    // Written to the stderr handle, not with eprintln!, which the test harness captures: a
    // skip must be visible in a normal `cargo test` run.
    use std::io::Write as _;
    let _ = writeln!(
        std::io::stderr(),
        "skipping (set CI=1 to make this an error): {why}"
    );
}

/// A mesh of `assets/` (any format `load_mesh` reads), cleaned with the default options.
pub fn load_asset_mesh(name: &str) -> morphlod::IndexedMesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name);
    morphlod::io::load_mesh(&path, &morphlod::io::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// SplitMix64: small, seedable, good enough to drive random walks.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix(self.0)
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// The next LOD of a random walk from `l` over `0..=max`: a jump to either end (1/16
    /// each) or anywhere (1/8), else 1–3 steps coarser (3/8) or finer (3/8).
    pub fn walk_lod(&mut self, l: usize, max: usize) -> usize {
        match self.below(16) {
            0 => 0,
            1 => max,
            2 | 3 => self.below(max + 1),
            4..=9 => (l + 1 + self.below(3)).min(max),
            _ => l.saturating_sub(1 + self.below(3)),
        }
    }
}

pub fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of an oriented triangle, equal for its three rotations; a multiset
/// hashes to the wrapping sum of its members.
pub fn tri_hash(t: [u32; 3]) -> u64 {
    let c = canonical(t);
    mix(mix(mix(u64::from(c[0]) + 1) ^ u64::from(c[1])) ^ (u64::from(c[2]) << 1))
}

pub fn degenerate(t: [u32; 3]) -> bool {
    t[0] == t[1] || t[1] == t[2] || t[0] == t[2]
}

/// A random valid sequence: half-edge collapses along current edges of the
/// mapped mesh, in random direction, until `steps` or no triangle is left.
pub fn random_sequence(
    tris: &[[u32; 3]],
    n: usize,
    steps: usize,
    rng: &mut Rng,
) -> CollapseSequence {
    let mut mapped = tris.to_vec();
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            incident[v as usize].push(t as u32);
        }
    }
    let mut live: Vec<u32> = (0..tris.len() as u32)
        .filter(|&t| !degenerate(tris[t as usize]))
        .collect();
    let mut collapses = Vec::new();
    while collapses.len() < steps && !live.is_empty() {
        let k = rng.below(live.len());
        let t = live[k] as usize;
        if degenerate(mapped[t]) {
            live.swap_remove(k);
            continue;
        }
        let c = rng.below(3);
        let (mut u, mut w) = (mapped[t][c], mapped[t][(c + 1) % 3]);
        if rng.next() & 1 == 0 {
            std::mem::swap(&mut u, &mut w);
        }
        let moved = std::mem::take(&mut incident[u as usize]);
        for &m in &moved {
            for v in mapped[m as usize].iter_mut() {
                if *v == u {
                    *v = w;
                }
            }
        }
        incident[w as usize].extend(moved);
        // Errors grow along the sequence in plateaus of three equal values,
        // so maximum-error LODs meet ties.
        let error = (collapses.len() / 3) as f32 * 0.01;
        collapses.push(Collapse { u, w, error });
    }
    let seq = CollapseSequence {
        vertex_count: n as u32,
        collapses,
    };
    seq.validate().expect("generated sequence is valid");
    seq
}

/// Reference multiset hash and triangle count at every LOD, in one pass.
pub fn reference_hashes(tris: &[[u32; 3]], seq: &CollapseSequence) -> Vec<(u64, usize)> {
    let n = seq.vertex_count as usize;
    let mut mapped = tris.to_vec();
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut hash = 0u64;
    let mut count = 0usize;
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            incident[v as usize].push(t as u32);
        }
        if !degenerate(*tri) {
            hash = hash.wrapping_add(tri_hash(*tri));
            count += 1;
        }
    }
    let mut out = vec![(hash, count)];
    for c in &seq.collapses {
        let moved = std::mem::take(&mut incident[c.u as usize]);
        for &m in &moved {
            let old = mapped[m as usize];
            if !old.contains(&c.u) {
                continue;
            }
            if !degenerate(old) {
                hash = hash.wrapping_sub(tri_hash(old));
                count -= 1;
            }
            let new = old.map(|v| if v == c.u { c.w } else { v });
            if !degenerate(new) {
                hash = hash.wrapping_add(tri_hash(new));
                count += 1;
            }
            mapped[m as usize] = new;
        }
        incident[c.w as usize].extend(moved);
        out.push((hash, count));
    }
    out
}

/// The primitive-restart index of a `Uint32` index buffer.
pub const RESTART: u32 = 0xFFFF_FFFF;

/// The triangles a GPU draws from `indices` read as a triangle strip with primitive restart,
/// in draw order, each in the winding the rasterizer sees (Vulkan spec, "Triangle Strips"):
/// for the `i`-th vertex triple since the last restart, triangle `i` is
/// `(v[i], v[i+1], v[i+2])` when `i` is even and `(v[i], v[i+2], v[i+1])` when `i` is odd
/// (provoking vertex first). The restart index ends the strip; the next vertex starts a new one
/// at `i = 0`. A triangle that names one vertex twice has no area and draws nothing.
///
/// Written from the GPU's rules on purpose: it must not share a mistake with
/// `morphlod::strip::strip_triangles` (which writes odd triangles as `(v[i+1], v[i], v[i+2])`,
/// the same oriented triangle rotated). Compare results with `canonical`.
pub fn strip_draw<'a>(indices: impl Into<Indices<'a>>) -> Vec<[u32; 3]> {
    let indices = indices.into().to_vec();
    let mut out = Vec::new();
    // Vertices since the last restart: the last two, and how many.
    let (mut a, mut b, mut count) = (0u32, 0u32, 0usize);
    for &v in &indices {
        if v == RESTART {
            count = 0;
            continue;
        }
        if count >= 2 {
            let i = count - 2;
            let triangle = if i % 2 == 0 { [a, b, v] } else { [a, v, b] };
            if a != b && b != v && a != v {
                out.push(triangle);
            }
        }
        (a, b) = (b, v);
        count += 1;
    }
    out
}

/// Every triangle drawn by a set of strips (no restart inside), e.g. `S0`.
pub fn strips_draw(strips: &morphlod::strip::Strips) -> Vec<[u32; 3]> {
    (0..strips.len())
        .flat_map(|i| strip_draw(strips.strip(i).unwrap_or(&[])))
        .collect()
}

/// Multiset hash of a triangle list.
pub fn multiset_hash(tris: &[[u32; 3]]) -> u64 {
    tris.iter().fold(0u64, |h, &t| h.wrapping_add(tri_hash(t)))
}

/// The GPU's view of the index buffer, updated only from the dirty log, with
/// the multiset hash and count of what it draws kept per strip.
pub struct Mirror {
    region_offsets: Vec<u32>,
    pub indices: Vec<u32>,
    pub lens: Vec<u32>,
    strip_hash: Vec<u64>,
    strip_count: Vec<usize>,
    pub hash: u64,
    pub count: usize,
}

impl Mirror {
    /// A mirror of a state's buffer as first uploaded whole.
    pub fn new(region_offsets: &[u32], indices: Indices, lengths: &[u32]) -> Mirror {
        let strips = region_offsets.len() - 1;
        let mut m = Mirror {
            region_offsets: region_offsets.to_vec(),
            indices: indices.to_vec(),
            lens: lengths.to_vec(),
            strip_hash: vec![0; strips],
            strip_count: vec![0; strips],
            hash: 0,
            count: 0,
        };
        for s in 0..strips {
            m.rehash(s);
        }
        m
    }

    pub fn strip_count(&self) -> usize {
        self.region_offsets.len() - 1
    }

    pub fn strip(&self, s: usize) -> &[u32] {
        let base = self.region_offsets[s] as usize;
        &self.indices[base..base + self.lens[s] as usize]
    }

    fn rehash(&mut self, s: usize) {
        let (mut h, mut c) = (0u64, 0usize);
        for t in strip_draw(self.strip(s)) {
            h = h.wrapping_add(tri_hash(t));
            c += 1;
        }
        self.hash = self.hash.wrapping_sub(self.strip_hash[s]).wrapping_add(h);
        self.count = self.count - self.strip_count[s] + c;
        self.strip_hash[s] = h;
        self.strip_count[s] = c;
    }

    /// Copies exactly the ranges and lengths the dirty log names.
    pub fn upload(&mut self, dirty: &Dirty, indices: Indices, lengths: &[u32]) {
        let mut touched: Vec<usize> = Vec::new();
        for r in &dirty.ranges {
            let base = self.region_offsets[r.strip as usize] as usize;
            let (a, b) = (base + r.start as usize, base + r.end as usize);
            assert!(
                b <= self.region_offsets[r.strip as usize + 1] as usize,
                "dirty range {r:?} leaves its region"
            );
            indices.slice(a..b).copy_to(&mut self.indices[a..b]);
            touched.push(r.strip as usize);
        }
        for &s in &dirty.lengths {
            self.lens[s as usize] = lengths[s as usize];
            touched.push(s as usize);
        }
        touched.sort_unstable();
        touched.dedup();
        for s in touched {
            self.rehash(s);
        }
    }

    pub fn triangles(&self) -> Vec<[u32; 3]> {
        (0..self.strip_count())
            .flat_map(|s| strip_draw(self.strip(s)))
            .collect()
    }
}

/// `meshopt::simplify` to `target` triangles. The error limit is the whole extent, so only
/// the triangle count stops it.
pub fn meshopt_simplify(positions: &[[f32; 3]], tris: &[[u32; 3]], target: usize) -> Vec<[u32; 3]> {
    meshopt_simplify_with(positions, tris, target, meshopt::SimplifyOptions::None)
}

/// [`meshopt_simplify`] with meshoptimizer's option flags (e.g. `Regularize`, what gltfpack
/// uses for meshes with morph targets).
pub fn meshopt_simplify_with(
    positions: &[[f32; 3]],
    tris: &[[u32; 3]],
    target: usize,
    options: meshopt::SimplifyOptions,
) -> Vec<[u32; 3]> {
    let indices: Vec<u32> = tris.iter().flatten().copied().collect();
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(positions), 12, 0)
        .expect("tightly packed positions");
    let out = meshopt::simplify(&indices, &adapter, target * 3, 1.0, options, None);
    out.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
}

/// The weight animation `animation` of the shipped asset `file`, built with `frames` frames.
pub fn animated_asset(file: &str, animation: &str, frames: usize) -> morphlod::Asset {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(file);
    let source = morphlod::io::MorphSource::Animation(animation.into());
    let morph = morphlod::io::load_morph(&path, &morphlod::io::LoadOptions::default(), &source)
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    let asset = morphlod::Builder::new(&morph)
        .frames(frames)
        .build()
        .unwrap_or_else(|e| panic!("{file} builds: {e}"))
        .0;
    assert!(asset.blend.is_some(), "{file} keeps its targets");
    asset
}

/// The morph of `assets/<name>` over cleaned connectivity (no repeated-vertex or duplicate
/// triangle, no unused vertex), as the asset builder simplifies it.
pub fn load_asset_morph(name: &str, source: morphlod::io::MorphSource) -> Morph {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name);
    let morph = morphlod::io::load_morph(&path, &morphlod::io::LoadOptions::default(), &source)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let base = morphlod::IndexedMesh {
        positions: morph.v0(),
        triangles: morph.triangles().to_vec(),
    };
    let cleaned = morphlod::mesh::clean::clean(&base, &Default::default()).expect("a valid mesh");
    morph
        .select(&cleaned.vertex_map, cleaned.mesh.triangles)
        .expect("clean's vertex map is in range")
}

/// The length of the bounding-box diagonal of `positions` (the unit the quality tests report
/// errors in), in `f64`.
pub fn diagonal(positions: &[[f32; 3]]) -> f64 {
    let (lo, hi) = morphlod::mesh::bounds(positions).expect("a non-empty mesh");
    (0..3)
        .map(|a| ((hi[a] - lo[a]) as f64).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The first LOD with at most `target` triangles (every collapse removes at
/// least one, so counts strictly fall along a sequence).
pub fn lod_for(seq: &CollapseSequence, tris: &[[u32; 3]], target: usize) -> usize {
    let (mut lo, mut hi) = (0, seq.len());
    while lo < hi {
        let mid = (lo + hi) / 2;
        if seq.reference_mesh(tris, mid).len() <= target {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// The full mesh at one pose, indexed and sampled once, for measuring many LODs against it.
pub struct FullSurface<'a> {
    positions: &'a [[f32; 3]],
    index: SurfaceIndex,
    samples: Vec<glam::DVec3>,
    /// The sample count asked for (`sample_surface` adds the surface's vertices to it).
    count: usize,
}

impl<'a> FullSurface<'a> {
    /// `samples` points on `triangles` over `positions` (seed 1).
    pub fn new(positions: &'a [[f32; 3]], triangles: &[[u32; 3]], samples: usize) -> Self {
        FullSurface {
            positions,
            index: SurfaceIndex::new(positions, triangles).expect("indices in range"),
            samples: sample_surface(positions, triangles, samples, 1).expect("indices in range"),
            count: samples,
        }
    }

    /// Symmetric Hausdorff and RMS distance between `lod` (over the same positions) and the
    /// full mesh: as many samples on the LOD (seed 2) as on the full mesh, each set measured
    /// against the other surface.
    pub fn error(&self, lod: &[[u32; 3]]) -> ErrorStats {
        let index = SurfaceIndex::new(self.positions, lod).expect("indices in range");
        let samples = sample_surface(self.positions, lod, self.count, 2).expect("indices in range");
        symmetric(
            directed_error(&samples, &self.index),
            directed_error(&self.samples, &index),
        )
    }
}

/// A `side × side` vertex grid in the xy plane (`V(0)`) whose vertex `(x, y)` rises to
/// `height(x, y)` in `V(1)`; two triangles per cell.
pub fn grid_morph(side: u32, height: impl Fn(u32, u32) -> f32) -> Morph {
    let mut v0 = Vec::new();
    let mut v1 = Vec::new();
    for y in 0..side {
        for x in 0..side {
            v0.push([x as f32, y as f32, 0.0]);
            v1.push([x as f32, y as f32, height(x, y)]);
        }
    }
    let mut tris = Vec::new();
    for y in 0..side - 1 {
        for x in 0..side - 1 {
            let a = y * side + x;
            tris.push([a, a + 1, a + side + 1]);
            tris.push([a, a + side + 1, a + side]);
        }
    }
    Morph::from_poses(tris, v0, v1).expect("a grid is a valid morph")
}

/// Rewrites a `.mlod` header's body length and CRC to match the body as it is now, so a
/// mutation reaches the decoders behind the checksum.
pub fn fix_header(bytes: &mut [u8]) {
    if bytes.len() < HEADER_LEN {
        return;
    }
    let body_len = (bytes.len() - HEADER_LEN) as u64;
    bytes[16..24].copy_from_slice(&body_len.to_le_bytes());
    let crc = crc32fast::hash(&bytes[HEADER_LEN..]);
    bytes[24..28].copy_from_slice(&crc.to_le_bytes());
}

/// Attribute vertices made from keys: each distinct key gets the next index (first use order).
struct Keyed<K> {
    index: std::collections::HashMap<K, u32>,
    keys: Vec<K>,
}

impl<K: std::hash::Hash + Eq + Copy> Keyed<K> {
    fn new() -> Self {
        Keyed {
            index: std::collections::HashMap::new(),
            keys: Vec::new(),
        }
    }
    fn get(&mut self, key: K) -> u32 {
        let next = self.keys.len() as u32;
        *self.index.entry(key).or_insert_with(|| {
            self.keys.push(key);
            next
        })
    }
}

/// A UV-mapped sphere split the way DCC tools split one: a longitude seam (the first column
/// repeated at `u = 1`), one pole copy per slice, and the equator cut between a northern and a
/// southern UV island (the south mirrored in `u`, so its UV triangles turn the other way). It
/// morphs into a lumpy, stretched pose. Copies of a position get it from the same grid
/// coordinates, so they weld bit for bit.
pub fn seamed_sphere(stacks: u32, slices: u32) -> Morph {
    assert!(stacks >= 4 && stacks.is_multiple_of(2) && slices >= 3);
    let half = stacks / 2;
    // Key: (ring i, column j in 0..=slices, island 0 north / 1 south); a pole's column is
    // the slice it serves.
    let mut keyed = Keyed::<(u32, u32, u32)>::new();
    let mut tris = Vec::new();
    for i in 0..stacks {
        let island = u32::from(i >= half);
        for j in 0..slices {
            let mut v = |ii: u32, jj: u32| {
                let column = if ii == 0 || ii == stacks { j } else { jj };
                keyed.get((ii, column, island))
            };
            let (a, b, c, d) = (v(i, j), v(i, j + 1), v(i + 1, j), v(i + 1, j + 1));
            if i == 0 {
                tris.push([a, c, d]);
            } else if i + 1 == stacks {
                tris.push([c, b, a]);
            } else {
                tris.push([a, c, d]);
                tris.push([a, d, b]);
            }
        }
    }
    let keys = keyed.keys;
    let position = |i: u32, j: u32, bumpy: bool| -> [f32; 3] {
        if i == 0 {
            return [0.0, 0.0, if bumpy { 1.4 } else { 1.0 }];
        }
        if i == stacks {
            return [0.0, 0.0, -1.0];
        }
        let theta = std::f32::consts::PI * i as f32 / stacks as f32;
        let phi = 2.0 * std::f32::consts::PI * (j % slices) as f32 / slices as f32;
        let r = if bumpy {
            1.0 + 0.25 * (3.0 * phi).sin() * theta.sin()
        } else {
            1.0
        };
        [
            r * theta.sin() * phi.cos(),
            r * theta.sin() * phi.sin(),
            r * theta.cos(),
        ]
    };
    let v0: Vec<[f32; 3]> = keys
        .iter()
        .map(|&(i, j, _)| position(i, j, false))
        .collect();
    let v1: Vec<[f32; 3]> = keys.iter().map(|&(i, j, _)| position(i, j, true)).collect();
    let uvs: Vec<[f32; 2]> = keys
        .iter()
        .map(|&(i, j, island)| {
            let pole = i == 0 || i == stacks;
            let u = (j as f32 + if pole { 0.5 } else { 0.0 }) / slices as f32;
            let v = i as f32 / stacks as f32;
            if island == 0 {
                [u, v]
            } else {
                [1.0 - u, v + 0.1]
            }
        })
        .collect();
    let attributes = morphlod::morph::Attributes {
        uvs: Some(uvs),
        ..Default::default()
    };
    Morph::from_poses(tris, v0, v1)
        .and_then(|m| m.with_attributes(attributes))
        .expect("a seamed sphere is a valid morph")
}

/// A `side × side` grid morph (as [`grid_morph`], heights `0.3 sin(x) cos(y)` in `V(1)`) cut
/// by a UV seam up column `side / 2` from the bottom border to the middle: the vertices on
/// the cut below its end have a left and a right copy (the right island shifted in UV), the
/// cut's end has one.
pub fn cut_grid(side: u32) -> Morph {
    let cut = side / 2;
    let end = side / 2;
    let mut keyed = Keyed::<(u32, u32, u32)>::new();
    let mut tris = Vec::new();
    for y in 0..side - 1 {
        for x in 0..side - 1 {
            let right = u32::from(x >= cut);
            let mut v = |xx: u32, yy: u32| {
                let copy = if xx == cut && yy < end { right } else { 0 };
                keyed.get((xx, yy, copy))
            };
            let (a, b, c, d) = (v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    let height = |x: u32, y: u32| 0.3 * (x as f32).sin() * (y as f32).cos();
    let v0: Vec<[f32; 3]> = keyed
        .keys
        .iter()
        .map(|&(x, y, _)| [x as f32, y as f32, 0.0])
        .collect();
    let v1: Vec<[f32; 3]> = keyed
        .keys
        .iter()
        .map(|&(x, y, _)| [x as f32, y as f32, height(x, y)])
        .collect();
    let uvs: Vec<[f32; 2]> = keyed
        .keys
        .iter()
        .map(|&(x, y, copy)| {
            let (u, v) = (x as f32 / side as f32, y as f32 / side as f32);
            let island = if x > cut || (x == cut && copy == 1) {
                0.1
            } else {
                0.0
            };
            [u + island, v]
        })
        .collect();
    let attributes = morphlod::morph::Attributes {
        uvs: Some(uvs),
        ..Default::default()
    };
    Morph::from_poses(tris, v0, v1)
        .and_then(|m| m.with_attributes(attributes))
        .expect("a cut grid is a valid morph")
}

/// The AnimatedMorphCube sample (its node given a translation) re-parented under a named TRS
/// node "rig" (translation, rotation, scale) under a named matrix node "root", written to
/// `dir/rigged.gltf` beside a copy of its buffer: a source with a real node hierarchy. Its
/// animation also moves "rig" (LINEAR translation) and turns the cube's node (STEP rotation).
pub fn rigged_cube(dir: &std::path::Path) -> std::path::PathBuf {
    use serde_json::{json, Value};
    let assets =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/AnimatedMorphCube-glTF");
    let mut gltf: Value =
        serde_json::from_slice(&std::fs::read(assets.join("AnimatedMorphCube.gltf")).unwrap())
            .unwrap();
    gltf["nodes"][0]["translation"] = json!([0.25, -1.5, 3.0]);
    let nodes = gltf["nodes"].as_array_mut().unwrap();
    nodes.push(
        json!({"name": "rig", "children": [0], "translation": [1.0, 2.0, -0.5],
        "rotation": [0.0, 0.38268343, 0.0, 0.9238795], "scale": [2.0, 2.0, 2.0]}),
    );
    nodes.push(json!({"name": "root", "children": [1],
        "matrix": [0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 10, 0, -4, 1]}));
    gltf["scenes"][0]["nodes"] = json!([2]);
    // The weight animation also moves "rig" (LINEAR translation) and turns the cube node
    // (STEP rotation): keys and values appended to a copy of the buffer.
    let mut bin = std::fs::read(assets.join("AnimatedMorphCube.bin")).unwrap();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let offset = bin.len();
    let floats: [f32; 24] = [
        0.0, 0.75, 1.5, // times
        1.0, 2.0, -0.5, 1.5, 2.0, -0.25, 0.5, 2.5, -0.5, // translations
        0.0, 0.0, 0.0, 1.0, 0.0, 0.70710677, 0.0, 0.70710677, 0.0, 1.0, 0.0, 0.0, // rotations
    ];
    for f in floats {
        bin.extend_from_slice(&f.to_le_bytes());
    }
    gltf["buffers"][0]["byteLength"] = json!(bin.len());
    let view = gltf["bufferViews"].as_array().unwrap().len();
    gltf["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": 4 * floats.len()}));
    let first = gltf["accessors"].as_array().unwrap().len();
    let accessors = gltf["accessors"].as_array_mut().unwrap();
    accessors.push(
        json!({"bufferView": view, "byteOffset": 0, "componentType": 5126,
        "count": 3, "type": "SCALAR", "min": [0.0], "max": [1.5]}),
    );
    accessors.push(
        json!({"bufferView": view, "byteOffset": 12, "componentType": 5126,
        "count": 3, "type": "VEC3"}),
    );
    accessors.push(
        json!({"bufferView": view, "byteOffset": 48, "componentType": 5126,
        "count": 3, "type": "VEC4"}),
    );
    let animation = &mut gltf["animations"][0];
    let sampler = animation["samplers"].as_array().unwrap().len();
    let samplers = animation["samplers"].as_array_mut().unwrap();
    samplers.push(json!({"input": first, "output": first + 1, "interpolation": "LINEAR"}));
    samplers.push(json!({"input": first, "output": first + 2, "interpolation": "STEP"}));
    let channels = animation["channels"].as_array_mut().unwrap();
    channels.push(json!({"sampler": sampler, "target": {"node": 1, "path": "translation"}}));
    channels.push(json!({"sampler": sampler + 1, "target": {"node": 0, "path": "rotation"}}));
    let input = dir.join("rigged.gltf");
    std::fs::write(&input, serde_json::to_vec(&gltf).unwrap()).unwrap();
    std::fs::write(dir.join("AnimatedMorphCube.bin"), bin).unwrap();
    input
}

/// makehuman_face.glb as a skinned character, written to `dir/skinned.gltf` beside its
/// buffer `skinned.bin`: its node bound by the skin "armature" to two joints, "hips" (a scene
/// root) and its child "spine", with inverse bind matrices; per vertex JOINTS_0
/// (UNSIGNED_BYTE), WEIGHTS_0 (normalized UNSIGNED_BYTE, summing to 1), TEXCOORD_1 (normalized
/// UNSIGNED_BYTE, 2 bytes per vertex in a 4-byte stride), TANGENT (FLOAT VEC4) and an
/// application-specific `_ID` (FLOAT); TANGENT deltas on its first two targets; a rotation
/// channel on "spine" in the `expressions` animation; and a material that also has a normal
/// map on TEXCOORD_1, an occlusion map with `KHR_texture_transform`, an emissive factor and
/// `KHR_materials_emissive_strength`. The values differ from vertex
/// to vertex.
pub fn skinned_face(dir: &std::path::Path) -> (std::path::PathBuf, SkinnedFace) {
    use serde_json::{json, Value};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/makehuman_face.glb");
    let bytes = std::fs::read(path).unwrap();
    let glb = gltf::Glb::from_slice(&bytes).unwrap();
    let mut gltf: Value = serde_json::from_slice(&glb.json).unwrap();
    let mut bin = glb.bin.unwrap().into_owned();
    let vertices = gltf["accessors"][0]["count"].as_u64().unwrap() as usize;
    gltf["buffers"][0]["uri"] = json!("skinned.bin");
    gltf["nodes"][0]["skin"] = json!(0);
    let nodes = gltf["nodes"].as_array_mut().unwrap();
    let hips = nodes.len();
    nodes.push(json!({"name": "hips", "translation": [0.0, 0.5, 0.0], "children": [hips + 1]}));
    nodes.push(json!({"name": "spine", "translation": [0.0, 0.25, 0.0]}));
    gltf["scenes"][0]["nodes"] = json!([0, hips]);
    // The material also has a normal map on TEXCOORD_1, an occlusion map with a texture
    // transform, and an emissive strength (both extensions the validator knows).
    let material = &mut gltf["materials"][0];
    material["normalTexture"] = json!({"index": 0, "texCoord": 1, "scale": 0.5});
    material["occlusionTexture"] = json!({"index": 0, "strength": 0.75,
        "extensions": {"KHR_texture_transform": {"scale": [2.0, 2.0]}}});
    material["emissiveFactor"] = json!([0.1, 0.05, 0.0]);
    material["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}});
    gltf["extensionsUsed"] = json!(["KHR_texture_transform", "KHR_materials_emissive_strength"]);
    let floats =
        |values: Vec<f32>| -> Vec<u8> { values.iter().flat_map(|f| f.to_le_bytes()).collect() };
    let joints: Vec<u8> = (0..vertices).flat_map(|_| [0, 1, 0, 0]).collect();
    let weights: Vec<u8> = (0..vertices)
        .flat_map(|v| {
            let w = 1 + (v % 254) as u8;
            [w, 255 - w, 0, 0]
        })
        .collect();
    let uv1: Vec<u8> = (0..vertices)
        .flat_map(|v| [(v % 251) as u8, (v / 251) as u8, 0, 0])
        .collect();
    let tangents: Vec<f32> = (0..vertices)
        .flat_map(|v| {
            let a = v as f32 * 0.01;
            [a.cos(), a.sin(), 0.0, if v % 2 == 0 { 1.0 } else { -1.0 }]
        })
        .collect();
    let tangent_deltas = |k: usize| -> Vec<f32> {
        (0..vertices)
            .flat_map(|v| [0.001 * ((v + k) % 7) as f32, 0.0, -0.002 * (v % 3) as f32])
            .collect()
    };
    let ids: Vec<f32> = (0..vertices).map(|v| 1000.0 + v as f32).collect();
    let ibm: Vec<f32> = [-0.5f32, -0.75]
        .iter()
        .flat_map(|&y| {
            [
                1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, y, 0.0, 1.0,
            ]
        })
        .collect();
    let keys: Vec<f32> = vec![
        0.0, 1.0, 2.0, // times
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.38268343, 0.9238795, 0.0, 0.0, 0.0, 1.0, // rotations
    ];
    let elements = |bytes: &[u8], size: usize, stride: usize| -> Vec<Vec<u8>> {
        bytes
            .chunks_exact(stride)
            .map(|e| e[..size].to_vec())
            .collect()
    };
    let written = SkinnedFace {
        attributes: vec![
            ("JOINTS_0", elements(&joints, 4, 4)),
            ("WEIGHTS_0", elements(&weights, 4, 4)),
            ("TEXCOORD_1", elements(&uv1, 2, 4)),
            ("TANGENT", elements(&floats(tangents.clone()), 16, 16)),
            ("_ID", elements(&floats(ids.clone()), 4, 4)),
        ],
        tangent_deltas: [0, 1].map(|k| {
            tangent_deltas(k)
                .chunks_exact(3)
                .map(|d| [d[0], d[1], d[2]])
                .collect()
        }),
        inverse_bind_matrices: ibm
            .chunks_exact(16)
            .map(|m| std::array::from_fn(|i| m[i]))
            .collect(),
        spine_rotation: (
            keys[..3].to_vec(),
            keys[3..]
                .chunks_exact(4)
                .map(|q| [q[0], q[1], q[2], q[3]])
                .collect(),
        ),
    };
    // Appends `bytes` as a buffer view (4-byte aligned) and returns its index.
    let mut view = |gltf: &mut Value, bytes: Vec<u8>, stride: Option<usize>, vertex: bool| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()});
        if let Some(stride) = stride {
            v["byteStride"] = json!(stride);
        }
        if vertex {
            v["target"] = json!(34962);
        }
        bin.extend(bytes);
        let views = gltf["bufferViews"].as_array_mut().unwrap();
        views.push(v);
        views.len() - 1
    };
    let views = [
        view(&mut gltf, joints, None, true),
        view(&mut gltf, weights, None, true),
        view(&mut gltf, uv1, Some(4), true),
        view(&mut gltf, floats(tangents), None, true),
        view(&mut gltf, floats(ids), None, true),
        view(&mut gltf, floats(tangent_deltas(0)), None, true),
        view(&mut gltf, floats(tangent_deltas(1)), None, true),
        view(&mut gltf, floats(ibm), None, false),
        view(&mut gltf, floats(keys), None, false),
    ];
    gltf["buffers"][0]["byteLength"] = json!(bin.len());
    let first = gltf["accessors"].as_array().unwrap().len();
    let accessors = gltf["accessors"].as_array_mut().unwrap();
    for a in [
        json!({"bufferView": views[0], "componentType": 5121, "count": vertices, "type": "VEC4"}),
        json!({"bufferView": views[1], "componentType": 5121, "normalized": true, "count": vertices, "type": "VEC4"}),
        json!({"bufferView": views[2], "componentType": 5121, "normalized": true, "count": vertices, "type": "VEC2"}),
        json!({"bufferView": views[3], "componentType": 5126, "count": vertices, "type": "VEC4"}),
        json!({"bufferView": views[4], "componentType": 5126, "count": vertices, "type": "SCALAR"}),
        json!({"bufferView": views[5], "componentType": 5126, "count": vertices, "type": "VEC3",
            "min": [0.0, 0.0, -0.004], "max": [0.006, 0.0, 0.0]}),
        json!({"bufferView": views[6], "componentType": 5126, "count": vertices, "type": "VEC3",
            "min": [0.0, 0.0, -0.004], "max": [0.006, 0.0, 0.0]}),
        json!({"bufferView": views[7], "componentType": 5126, "count": 2, "type": "MAT4"}),
        json!({"bufferView": views[8], "componentType": 5126, "count": 3, "type": "SCALAR", "min": [0.0], "max": [2.0]}),
        json!({"bufferView": views[8], "byteOffset": 12, "componentType": 5126, "count": 3, "type": "VEC4"}),
    ] {
        accessors.push(a);
    }
    let primitive = &mut gltf["meshes"][0]["primitives"][0];
    for (k, semantic) in ["JOINTS_0", "WEIGHTS_0", "TEXCOORD_1", "TANGENT", "_ID"]
        .iter()
        .enumerate()
    {
        primitive["attributes"][*semantic] = json!(first + k);
    }
    for k in 0..2 {
        primitive["targets"][k]["TANGENT"] = json!(first + 5 + k);
    }
    gltf["skins"] = json!([{"name": "armature", "joints": [hips, hips + 1], "skeleton": hips,
        "inverseBindMatrices": first + 7}]);
    let animation = &mut gltf["animations"][0];
    let sampler = animation["samplers"].as_array().unwrap().len();
    animation["samplers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"input": first + 8, "output": first + 9, "interpolation": "LINEAR"}));
    animation["channels"]
        .as_array_mut()
        .unwrap()
        .push(json!({"sampler": sampler, "target": {"node": hips + 1, "path": "rotation"}}));
    let input = dir.join("skinned.gltf");
    std::fs::write(&input, serde_json::to_vec(&gltf).unwrap()).unwrap();
    std::fs::write(dir.join("skinned.bin"), bin).unwrap();
    (input, written)
}

/// What [`skinned_face`] wrote, to check an export against.
pub struct SkinnedFace {
    /// Per added vertex attribute, its name and each vertex's element bytes (without the
    /// stride's padding).
    pub attributes: Vec<(&'static str, Vec<Vec<u8>>)>,
    /// The TANGENT deltas of targets 0 and 1.
    pub tangent_deltas: [Vec<[f32; 3]>; 2],
    /// The two inverse bind matrices, column-major.
    pub inverse_bind_matrices: Vec<[f32; 16]>,
    /// The key times and rotations of the channel on "spine".
    pub spine_rotation: (Vec<f32>, Vec<[f32; 4]>),
}
