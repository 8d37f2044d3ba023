//! What every instance of one asset shares on the GPU, uploaded once: the poses `V(0)` and
//! `V(1)`, the surface (normals, UVs, colours, the base-colour texture) and the morph targets'
//! position and normal deltas. [`Object`](super::Object)s and a [`Crowd`](super::Crowd) hold it
//! through an [`Arc`], so N instances of a body cost one copy of its vertex data, and only their
//! index slots, draw records and per-instance data are theirs.
//!
//! The buffers are made for both ways of drawing: the poses and the surface are vertex buffers
//! (an [`Object`](super::Object) reads them as attributes) and storage buffers (a crowd pulls
//! vertices by index, see `shaders/crowd.wgsl`); the target deltas are a storage buffer the
//! crowd's vertex stage reads, and their CPU copy is what an [`Object`](super::Object) sums
//! with its weights.

use std::sync::Arc;

use glam::{Mat3, Vec3};
use wgpu::util::{BufferInitDescriptor, DeviceExt};

use super::checks::check_size;
use super::skin::GpuSkin;
use super::surface::GpuSurface;
use super::GpuError;
use crate::asset::{Asset, Surface, MAX_TARGETS};
use crate::morph::WeightTrack;
use crate::skin::{BakedClip, Skinning};

/// One asset's vertex data on one device, shared by every object and crowd instance drawing it.
pub struct GpuAsset {
    /// The device the buffers live on (an instance on another device is refused).
    device: wgpu::Device,
    vertex_count: u32,
    v0: wgpu::Buffer,
    v1: wgpu::Buffer,
    surface: Option<GpuSurface>,
    targets: Option<Arc<TargetDeltas>>,
    /// The weight animation of an asset made from one (its targets' weights over time).
    track: Option<WeightTrack>,
    /// A skinned asset's baked clip and vertex skin.
    skin: Option<GpuSkin>,
    /// A sphere holding both poses (and so every blend of them; a skinned asset's: at every
    /// baked key): centre and radius, object space. A crowd culls by it
    /// ([`super::Crowd::set_culling`]).
    bound: ([f32; 3], f32),
    /// The most the vertex stage stretches a target delta: 1, or a skinned asset's
    /// [`skinned_bound`] stretch.
    stretch: f32,
}

/// The morph targets of an asset: CPU deltas (what an object sums on the CPU) and the same
/// deltas on the GPU (what the crowd's vertex stage sums).
pub(super) struct TargetDeltas {
    pub(super) count: usize,
    /// Target k's delta for vertex i at `positions[k n + i]`.
    pub(super) positions: Vec<[f32; 3]>,
    /// Target k's normal delta for vertex i at `normals[k n + i]` (empty without).
    pub(super) normals: Vec<[f32; 3]>,
    /// Target k's longest position delta: a vertex moves at most `|w| reach[k]` by weight w.
    pub(super) reach: Vec<f32>,
    pub(super) position_buffer: wgpu::Buffer,
    /// A 16-byte zero buffer without normal deltas.
    pub(super) normal_buffer: wgpu::Buffer,
}

impl GpuAsset {
    /// Uploads two poses (one vertex each per mesh vertex, at least 1 and fewer than
    /// `0xFFFFFFFF` vertices) and, when given, a surface (one finite entry per vertex:
    /// [`GpuError::SurfaceLength`], [`GpuError::NonFiniteAttribute`]; a texture that decodes:
    /// [`GpuError::TextureDecode`]).
    pub fn new(
        device: &wgpu::Device,
        (v0, v1): (&[[f32; 3]], &[[f32; 3]]),
        surface: Option<&Surface>,
    ) -> Result<GpuAsset, GpuError> {
        if v0.len() != v1.len() {
            return Err(GpuError::PoseSizeMismatch {
                v0: v0.len(),
                v1: v1.len(),
            });
        }
        // RESTART itself must never be a vertex number.
        let max_vertices = super::RESTART as usize;
        if v0.is_empty() || v0.len() >= max_vertices {
            return Err(GpuError::VertexCount {
                count: v0.len(),
                max: max_vertices - 1,
            });
        }
        let limits = device.limits();
        let pose_max = limits
            .max_buffer_size
            .min(limits.max_storage_buffer_binding_size);
        check_size("vertex", v0.len() as u64 * 12, pose_max)?;
        let surface = surface
            .map(|surface| GpuSurface::new(device, surface, v0.len()))
            .transpose()?;
        let pose_buffer = |label, pose: &[[f32; 3]]| {
            device.create_buffer_init(&BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(pose),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
            })
        };
        Ok(GpuAsset {
            device: device.clone(),
            vertex_count: v0.len() as u32,
            v0: pose_buffer("morphlod V(0)", v0),
            v1: pose_buffer("morphlod V(1)", v1),
            surface,
            targets: None,
            track: None,
            skin: None,
            bound: bounding_sphere(&[v0, v1]),
            stretch: 1.0,
        })
    }

    /// `asset`'s poses, surface and morph targets (position and normal deltas) with its weight
    /// track, and for a skinned asset its clip baked at uniform keys and its vertices' joints
    /// and weights (`docs/DESIGN.md`, "The GPU layout"): what [`super::LodObject`] and a crowd
    /// draw an asset with. A track that does not drive exactly the asset's targets is
    /// [`GpuError::TrackMismatch`]; a skin that cannot be drawn is [`GpuError::Skin`],
    /// [`GpuError::SkinInfluences`], [`GpuError::SkinJoints`] or [`GpuError::ClipTooLarge`].
    pub fn from_asset(device: &wgpu::Device, asset: &Asset) -> Result<Arc<GpuAsset>, GpuError> {
        let poses = (asset.v0.as_slice(), asset.v1.as_slice());
        let surface = asset.surface.as_ref();
        let mut gpu = GpuAsset::new(device, poses, surface)?;
        if let Some(blend) = &asset.blend {
            if blend.track.targets() != blend.deltas.len() {
                return Err(GpuError::TrackMismatch {
                    track: blend.track.targets(),
                    targets: blend.deltas.len(),
                });
            }
            let normals = surface.map_or(&[][..], |s| s.normal_deltas.as_slice());
            gpu.targets = Some(Arc::new(TargetDeltas::new(
                device,
                &blend.deltas,
                normals,
                gpu.vertex_count as usize,
                gpu.surface.is_some(),
            )?));
            gpu.track = Some(blend.track.clone());
        }
        if let Some(skinning) = &asset.skin {
            let (skin, baked) = GpuSkin::new(device, skinning, &asset.v0)?;
            (gpu.bound, gpu.stretch) = skinned_bound(skinning, &baked, poses);
            gpu.skin = Some(skin);
        }
        Ok(Arc::new(gpu))
    }

    /// Number of vertices of each pose.
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    /// Whether the asset has a surface (normals, UVs, material).
    pub fn has_surface(&self) -> bool {
        self.surface.is_some()
    }

    /// Number of morph targets (0 without).
    pub fn target_count(&self) -> usize {
        self.targets.as_ref().map_or(0, |t| t.count)
    }

    /// The weight track of an asset made from a weight animation.
    pub fn track(&self) -> Option<&WeightTrack> {
        self.track.as_ref()
    }

    /// Whether the asset is skinned: objects drawing it skin on the GPU.
    pub fn is_skinned(&self) -> bool {
        self.skin.is_some()
    }

    /// For a skinned asset, `N`: its clip is baked at the `N + 1` keys `t = i / N`
    /// ([`crate::skin::BakedClip::intervals_within`]).
    pub fn clip_intervals(&self) -> Option<u32> {
        self.skin.as_ref().map(|s| s.intervals)
    }

    /// For a skinned asset, the GPU bytes of its baked clip (the keys' joint rows, shared by
    /// every object drawing it).
    pub fn clip_bytes(&self) -> Option<u64> {
        self.skin.as_ref().map(|s| s.clip_bytes)
    }

    /// Whether the buffers live on `device`. wgpu numbers devices per `wgpu::Instance`, so this
    /// tells apart the devices of one instance, not devices of two instances.
    pub fn is_on(&self, device: &wgpu::Device) -> bool {
        self.device == *device
    }

    /// GPU bytes the asset holds: poses, surface buffer and texture, target deltas, baked clip
    /// and vertex skin.
    pub fn gpu_bytes(&self) -> u64 {
        let targets = self
            .targets
            .as_ref()
            .map_or(0, |t| t.position_buffer.size() + t.normal_buffer.size());
        let surface = self.surface.as_ref().map_or(0, GpuSurface::gpu_bytes);
        let skin = self.skin.as_ref().map_or(0, GpuSkin::gpu_bytes);
        self.v0.size() + self.v1.size() + surface + targets + skin
    }

    pub(super) fn v0(&self) -> &wgpu::Buffer {
        &self.v0
    }

    pub(super) fn v1(&self) -> &wgpu::Buffer {
        &self.v1
    }

    pub(super) fn surface(&self) -> Option<&GpuSurface> {
        self.surface.as_ref()
    }

    pub(super) fn skin(&self) -> Option<&GpuSkin> {
        self.skin.as_ref()
    }

    pub(super) fn targets(&self) -> Option<&Arc<TargetDeltas>> {
        self.targets.as_ref()
    }

    /// A sphere holding both poses: centre and radius, object space (NaN where a position is
    /// not finite: then nothing is outside it).
    pub(super) fn bound(&self) -> ([f32; 3], f32) {
        self.bound
    }

    /// The most a target delta of length 1 moves a vertex as drawn (1 unskinned): a crowd
    /// grows [`bound`](Self::bound) by an instance's weights times their reach times it.
    pub(super) fn stretch(&self) -> f32 {
        self.stretch
    }

    /// Uploads the texture the first time any user of the asset prepares; the bytes written
    /// (0 afterwards).
    pub(super) fn upload(&self, queue: &wgpu::Queue) -> u64 {
        self.surface.as_ref().map_or(0, |s| s.upload(queue))
    }
}

impl TargetDeltas {
    /// Checks and uploads `targets` (one delta per vertex each, finite, at most
    /// [`MAX_TARGETS`]) and `normals` (none, or one array per target on an asset with a
    /// surface).
    pub(super) fn new(
        device: &wgpu::Device,
        targets: &[Vec<[f32; 3]>],
        normals: &[Vec<[f32; 3]>],
        vertices: usize,
        has_surface: bool,
    ) -> Result<TargetDeltas, GpuError> {
        if targets.len() > MAX_TARGETS {
            return Err(GpuError::TargetCount {
                targets: targets.len(),
                max: MAX_TARGETS,
            });
        }
        if !normals.is_empty() && (normals.len() != targets.len() || !has_surface) {
            return Err(GpuError::InvalidParameter {
                what: "normal deltas",
                value: format!(
                    "{} arrays for {} targets on an object {} a surface",
                    normals.len(),
                    targets.len(),
                    if has_surface { "with" } else { "without" }
                ),
                expected: "give none, or one per target on an object with a surface",
            });
        }
        for (target, deltas) in targets.iter().chain(normals).enumerate() {
            // Normal deltas are checked like the positions and named by their target.
            let target = target % targets.len().max(1);
            if deltas.len() != vertices {
                return Err(GpuError::TargetLength {
                    target,
                    len: deltas.len(),
                    vertices,
                });
            }
            if let Some((vertex, &value)) = deltas
                .iter()
                .enumerate()
                .find(|(_, d)| !d.iter().all(|c| c.is_finite()))
            {
                return Err(GpuError::NonFiniteDelta {
                    target,
                    vertex,
                    value,
                });
            }
        }
        let bytes = (targets.len() * vertices * 12) as u64;
        let limits = device.limits();
        let max = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        check_size("morph-target", bytes, max)?;
        let positions: Vec<[f32; 3]> = targets.iter().flatten().copied().collect();
        let normals: Vec<[f32; 3]> = if targets.is_empty() {
            Vec::new()
        } else {
            normals.iter().flatten().copied().collect()
        };
        let reach = targets
            .iter()
            .map(|deltas| {
                let longest = deltas.iter().map(|&d| Vec3::from(d).as_dvec3().length());
                round_up(longest.fold(0.0, f64::max))
            })
            .collect();
        Ok(TargetDeltas {
            count: targets.len(),
            reach,
            position_buffer: storage_or_zero(device, "morphlod target deltas", &positions),
            normal_buffer: storage_or_zero(device, "morphlod target normal deltas", &normals),
            positions,
            normals,
        })
    }
}

/// A sphere holding the points of `poses`: the centre of their box ([`crate::mesh::bounds`]),
/// the radius to the farthest (in `f64`, rounded up to an `f32` that holds it). NaN where a
/// point is not finite.
fn bounding_sphere(poses: &[&[[f32; 3]]]) -> ([f32; 3], f32) {
    let (lo, hi) = poses
        .iter()
        .filter_map(|pose| crate::mesh::bounds(pose))
        .map(|(lo, hi)| (Vec3::from(lo), Vec3::from(hi)))
        .reduce(|(lo, hi), (l, h)| (lo.min(l), hi.max(h)))
        .unwrap_or_default();
    let center = sphere_center(lo, hi);
    let radius = (poses.iter()).fold(0.0, |r, pose| farthest(r, center, pose));
    (center.into(), round_up(radius))
}

/// The centre of the box `lo..hi` (in `f64`, then `f32`).
fn sphere_center(lo: Vec3, hi: Vec3) -> Vec3 {
    ((lo.as_dvec3() + hi.as_dvec3()) * 0.5).as_vec3()
}

/// The larger of `radius` and the distance from `center` to the farthest point of `pose`,
/// in `f64`; NaN where either is.
fn farthest(radius: f64, center: Vec3, pose: &[[f32; 3]]) -> f64 {
    (pose.iter())
        .map(|&p| (Vec3::from(p).as_dvec3() - center.as_dvec3()).length())
        .fold(radius, |r: f64, d| {
            if r.is_nan() || d.is_nan() {
                f64::NAN
            } else {
                r.max(d)
            }
        })
}

/// What `skinned_bound` hands each pose: its points and, skinned, its key's joint matrices.
type PoseVisit<'a> = dyn FnMut(&[[f32; 3]], Option<&[f32]>) + 'a;

/// A skinned asset's culling bound: the sphere holding `V(0)` and `V(1)` skinned at every
/// baked key (what the GPU draws between two keys is each vertex's blend of its skinned
/// positions at both, and a blend of the two poses skins to the blend of their skinned
/// positions: the sphere, convex, holds them all) and unskinned (what a renderer that does
/// not skin, `DiscreteCrowd`, draws), and the stretch, a bound on how far a skin matrix moves
/// a target delta of length 1: the largest sum of a vertex's absolute weights times the
/// largest Frobenius norm of a key's joint matrix's 3×3 part (at least 1, unskinned).
fn skinned_bound(
    skinning: &Skinning,
    baked: &BakedClip,
    (v0, v1): (&[[f32; 3]], &[[f32; 3]]),
) -> (([f32; 3], f32), f32) {
    // Every key's poses, one at a time (all at once would hold 2 (N + 1) poses: 124 MB for
    // the walker's 385 keys): `visit` sees the unskinned poses, then each key's skinned ones
    // with the key's matrices.
    let each_pose = |visit: &mut PoseVisit| {
        let (mut matrices, mut skinned) = (Vec::new(), Vec::new());
        visit(v0, None);
        visit(v1, None);
        for key in 0..=baked.intervals {
            baked.matrices_at(key as f32 / baked.intervals as f32, &mut matrices);
            for pose in [v0, v1] {
                skinning.skin.deform(&matrices, pose, &mut skinned);
                visit(&skinned, Some(&matrices));
            }
        }
    };
    // boxAndNorm: the box of every pose (the sphere's centre) and the largest joint
    // matrix's Frobenius norm.
    let mut bounds: Option<(Vec3, Vec3)> = None;
    let mut norm = 0.0f32;
    each_pose(&mut |pose, matrices| {
        if let Some((lo, hi)) = crate::mesh::bounds(pose) {
            let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
            bounds = Some(bounds.map_or((lo, hi), |(l, h)| (l.min(lo), h.max(hi))));
        }
        for m in matrices.unwrap_or_default().chunks_exact(16) {
            let linear = Mat3::from_cols_slice(&[&m[0..3], &m[4..7], &m[8..11]].concat());
            let frobenius = (linear.x_axis.length_squared()
                + linear.y_axis.length_squared()
                + linear.z_axis.length_squared())
            .sqrt();
            norm = norm.max(frobenius);
        }
    });
    // radius: the farthest point of any pose from the centre.
    let (lo, hi) = bounds.unwrap_or_default();
    let center = sphere_center(lo, hi);
    let mut radius = 0.0f64;
    each_pose(&mut |pose, _| radius = farthest(radius, center, pose));
    let skin = &skinning.skin;
    let weights = (skin.weights.chunks_exact(skin.influences.max(1)))
        .map(|w| w.iter().map(|w| w.abs()).sum::<f32>())
        .fold(0.0, f32::max);
    ((center.into(), round_up(radius)), (weights * norm).max(1.0))
}

/// `x` as an `f32` no smaller than it (NaN stays NaN).
fn round_up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x {
        y.next_up()
    } else {
        y
    }
}

/// `values` in a read-only storage buffer, or a 16-byte zero buffer when there are none (a
/// binding cannot be empty; WebGPU defines an out-of-range storage read to return a value from
/// inside the buffer or zero, so every read gives 0).
pub(super) fn storage_or_zero(
    device: &wgpu::Device,
    label: &'static str,
    values: &[[f32; 3]],
) -> wgpu::Buffer {
    let contents: &[u8] = if values.is_empty() {
        &[0; 16]
    } else {
        bytemuck::cast_slice(values)
    };
    device.create_buffer_init(&BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sphere holds every point (a radius rounded down would lose the farthest), and a
    /// non-finite point gives a NaN radius, which culls nothing.
    #[test]
    fn bounding_sphere_holds_every_point() {
        let points = [
            [0.1f32, -3.0, 7.3],
            [2.9, 0.3, -1.0],
            [1.0 / 3.0, 1e-3, 0.7],
        ];
        let (center, radius) = bounding_sphere(&[&points[..2], &points[2..]]);
        assert_eq!(center, [1.5, -1.35, 3.15]);
        for p in &points {
            let d = (0..3).map(|c| f64::from(p[c]) - f64::from(center[c]));
            assert!(d.map(|x| x * x).sum::<f64>().sqrt() <= f64::from(radius));
        }
        let nan = [[0.0, 0.0, 0.0], [f32::NAN, 1.0, 1.0], [2.0, 2.0, 2.0]];
        assert!(bounding_sphere(&[&nan]).1.is_nan());
        assert!(round_up(0.1) >= 0.1 && round_up(f64::NAN).is_nan());
    }
}
