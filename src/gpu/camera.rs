//! A camera that frames an object: view and projection fitted to its bounding box, in wgpu's
//! clip space (right-handed world, y up, depth in [0, 1]; glam's `directx` convention).
//!
//! The box is enclosed in its bounding sphere so the fit holds for any view direction and for
//! every pose of a morph when the caller passes the union of both poses' bounds.

use glam::{DMat4, DVec3, DVec4, Mat4, Vec3};

use super::GpuError;

/// How the fitted camera projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with this vertical field of view, in radians, in (0, π).
    Perspective { vertical_fov: f32 },
    /// Orthographic: parallel rays, no foreshortening.
    Orthographic,
}

/// A view and a projection matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// World to view space (right-handed, the camera looks down -z).
    pub view: Mat4,
    /// View to wgpu clip space.
    pub proj: Mat4,
}

impl Camera {
    /// Projection * view: what [`super::Object::set_view_proj`] takes.
    pub fn view_proj(&self) -> Mat4 {
        self.proj * self.view
    }
}

/// Depth range slack: near and far planes sit this fraction of the sphere's radius outside it,
/// so surface points on the sphere are not clipped by rounding.
const DEPTH_MARGIN: f32 = 0.05;

/// A camera looking along `direction` at the box `min..max`, which it shows whole in a viewport
/// of `aspect` = width / height.
///
/// The up vector is +y unless `direction` is (nearly) vertical, where it is -z. A box with no
/// extent (one point) is framed as a sphere of radius 1 around it.
pub fn fit_to_bounds(
    min: [f32; 3],
    max: [f32; 3],
    direction: Vec3,
    aspect: f32,
    projection: Projection,
) -> Result<Camera, GpuError> {
    let (lo, hi) = (Vec3::from(min), Vec3::from(max));
    if !lo.is_finite() || !hi.is_finite() || lo.cmpgt(hi).any() {
        return Err(GpuError::InvalidParameter {
            what: "bounds",
            value: format!("{lo}..{hi}"),
            expected: "min and max must be finite with min <= max on every axis",
        });
    }
    if !direction.is_finite() || direction.length_squared() == 0.0 {
        return Err(GpuError::InvalidParameter {
            what: "view direction",
            value: format!("{direction}"),
            expected: "the direction must be finite and nonzero",
        });
    }
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(GpuError::InvalidParameter {
            what: "aspect ratio",
            value: aspect.to_string(),
            expected: "width / height must be finite and positive",
        });
    }
    // In f64: the f32 half-diagonal of a box ~1e19 across overflows (its squared length
    // passes f32::MAX) and that of a box ~1e-22 across underflows to 0; either used to fall
    // back to radius 1 and frame empty space. The f32 matrices are checked at the end.
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let centre = (lo + hi) * 0.5;
    let radius = match (hi - lo).length() * 0.5 {
        r if r > 0.0 && r.is_finite() => r,
        _ => 1.0,
    };
    let forward = direction.as_dvec3().normalize();
    let up = if forward.cross(DVec3::Y).length_squared() < 1e-6 {
        DVec3::NEG_Z
    } else {
        DVec3::Y
    };
    let margin = f64::from(DEPTH_MARGIN);
    let (distance, proj) = match projection {
        Projection::Perspective { vertical_fov } => {
            if !(vertical_fov > 0.0 && vertical_fov < std::f32::consts::PI) {
                return Err(GpuError::InvalidParameter {
                    what: "vertical field of view",
                    value: vertical_fov.to_string(),
                    expected: "the angle is in radians and must lie strictly between 0 and π",
                });
            }
            let (fov, aspect) = (f64::from(vertical_fov), f64::from(aspect));
            // The sphere fits when its radius subtends at most the narrower half-angle.
            let half_y = fov * 0.5;
            let half_x = (half_y.tan() * aspect).atan();
            let distance = radius / half_y.min(half_x).sin();
            let near = (distance - radius * (1.0 + margin)).max(distance * 1e-3);
            let far = distance + radius * (1.0 + margin);
            let proj = perspective(fov, aspect, near, far);
            (distance, proj)
        }
        Projection::Orthographic => {
            let aspect = f64::from(aspect);
            let (half_w, half_h) = if aspect >= 1.0 {
                (radius * aspect, radius)
            } else {
                (radius, radius / aspect)
            };
            // Any distance past the sphere works; 2r keeps near and far well separated.
            let distance = 2.0 * radius;
            let near = distance - radius * (1.0 + margin);
            let far = distance + radius * (1.0 + margin);
            let proj = orthographic(half_w, half_h, near, far);
            (distance, proj)
        }
    };
    let eye = centre - forward * distance;
    let view = look_to(eye, forward, up);
    let camera = Camera {
        view: view.as_mat4(),
        proj: proj.as_mat4(),
    };
    let finite = |m: Mat4| m.to_cols_array().iter().all(|c| c.is_finite());
    if !finite(camera.view) || !finite(camera.proj) || !finite(camera.view_proj()) {
        return Err(GpuError::InvalidParameter {
            what: "bounds",
            value: format!("{lo}..{hi}"),
            expected: "a box whose camera fits in f32 (about 1e-30 to 1e30 across): scale the mesh",
        });
    }
    Ok(camera)
}

/// glam's right-handed DirectX/WebGPU perspective (depth in [0, 1]), in f64.
pub(crate) fn perspective(fov: f64, aspect: f64, near: f64, far: f64) -> DMat4 {
    let h = 1.0 / (fov * 0.5).tan();
    let w = h / aspect;
    let r = far / (near - far);
    DMat4::from_cols(
        DVec4::new(w, 0.0, 0.0, 0.0),
        DVec4::new(0.0, h, 0.0, 0.0),
        DVec4::new(0.0, 0.0, r, -1.0),
        DVec4::new(0.0, 0.0, r * near, 0.0),
    )
}

/// glam's right-handed DirectX/WebGPU orthographic projection of the centred
/// box `±half_w × ±half_h × [near, far]`, in f64.
fn orthographic(half_w: f64, half_h: f64, near: f64, far: f64) -> DMat4 {
    let r = 1.0 / (near - far);
    DMat4::from_cols(
        DVec4::new(1.0 / half_w, 0.0, 0.0, 0.0),
        DVec4::new(0.0, 1.0 / half_h, 0.0, 0.0),
        DVec4::new(0.0, 0.0, r, 0.0),
        DVec4::new(0.0, 0.0, r * near, 1.0),
    )
}

/// glam's right-handed view looking from `eye` along the unit vector `forward`, in f64.
pub(crate) fn look_to(eye: DVec3, forward: DVec3, up: DVec3) -> DMat4 {
    let s = forward.cross(up).normalize();
    let u = s.cross(forward);
    DMat4::from_cols(
        DVec4::new(s.x, u.x, -forward.x, 0.0),
        DVec4::new(s.y, u.y, -forward.y, 0.0),
        DVec4::new(s.z, u.z, -forward.z, 0.0),
        DVec4::new(-eye.dot(s), -eye.dot(u), eye.dot(forward), 1.0),
    )
}

/// A perspective camera looking along `direction` that frames the union of both poses of
/// `asset`, so the object does not jump between frames of an animation.
pub fn frame_both_poses(asset: &crate::asset::Asset, direction: Vec3) -> Result<Camera, GpuError> {
    let both: Vec<[f32; 3]> = asset.v0.iter().chain(&asset.v1).copied().collect();
    let (min, max) = crate::mesh::bounds(&both).ok_or(GpuError::NoVertices)?;
    fit_to_bounds(
        min,
        max,
        direction,
        1.0,
        Projection::Perspective {
            vertical_fov: 30f32.to_radians(),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every corner of the box must land inside clip space (x, y in [-1, 1], z in [0, 1]),
    /// and the box must fill a good part of the view (the fit is tight, not just safe).
    #[test]
    fn fitted_box_is_inside_clip_space_and_fills_it() {
        let (min, max) = ([-1.0, 2.0, 5.0], [3.0, 2.5, 9.0]);
        let cases = [
            (Vec3::NEG_Z, 1.0),
            (Vec3::new(1.0, -0.5, -0.3), 16.0 / 9.0),
            (Vec3::NEG_Y, 0.5),
            (Vec3::Y, 1.0),
        ];
        for (direction, aspect) in cases {
            for projection in [
                Projection::Perspective { vertical_fov: 0.8 },
                Projection::Orthographic,
            ] {
                let camera =
                    fit_to_bounds(min, max, direction, aspect, projection).expect("valid input");
                let m = camera.view_proj();
                let mut extent = 0.0f32;
                for corner in box_corners(min, max) {
                    let clip = m.project_point3(corner);
                    let what = format!("{direction} {aspect} {projection:?}: {clip}");
                    assert!(clip.x.abs() <= 1.0 && clip.y.abs() <= 1.0, "{what}");
                    assert!((0.0..=1.0).contains(&clip.z), "{what}");
                    extent = extent.max(clip.x.abs()).max(clip.y.abs());
                }
                assert!(extent > 0.4, "{direction} {projection:?}: extent {extent}");
            }
        }
    }

    /// The eight corners of the box `min..max`.
    fn box_corners(min: [f32; 3], max: [f32; 3]) -> impl Iterator<Item = Vec3> {
        (0..8).map(move |k| {
            Vec3::new(
                if k & 1 == 0 { min[0] } else { max[0] },
                if k & 2 == 0 { min[1] } else { max[1] },
                if k & 4 == 0 { min[2] } else { max[2] },
            )
        })
    }

    /// Boxes ~1e19 and ~1e-22 across are framed like a unit box (their f32 half-diagonal
    /// overflows or underflows), not replaced by a sphere of radius 1.
    #[test]
    fn extreme_scales_are_framed() {
        let persp = Projection::Perspective { vertical_fov: 0.8 };
        for scale in [1e19f32, 1e-22, 1.0, 3e30, 1e-30] {
            let (min, max) = ([-scale; 3], [scale, scale * 0.5, scale]);
            let camera = fit_to_bounds(min, max, Vec3::new(0.3, -0.2, -1.0), 1.0, persp)
                .unwrap_or_else(|e| panic!("scale {scale}: {e}"));
            let m = camera.view_proj();
            let mut extent = 0.0f32;
            for corner in box_corners(min, max) {
                let clip = m * corner.extend(1.0);
                let ndc = clip.truncate() / clip.w;
                assert!(ndc.is_finite(), "scale {scale}: {ndc}");
                assert!(
                    ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0,
                    "scale {scale}: {ndc}"
                );
                assert!((0.0..=1.0).contains(&ndc.z), "scale {scale}: {ndc}");
                extent = extent.max(ndc.x.abs()).max(ndc.y.abs());
            }
            assert!(extent > 0.4, "scale {scale}: extent {extent}");
        }
        // Past what f32 matrices can hold: a clear error, not a blank picture.
        let err = fit_to_bounds([-3e38; 3], [3e38; 3], Vec3::Z, 1.0, persp).unwrap_err();
        assert!(err.to_string().contains("scale the mesh"), "{err}");
    }

    #[test]
    fn rejects_bad_input() {
        let ok = |r: Result<Camera, GpuError>| r.is_ok();
        let persp = Projection::Perspective { vertical_fov: 1.0 };
        assert!(ok(fit_to_bounds([0.0; 3], [0.0; 3], Vec3::Z, 1.0, persp)));
        assert!(!ok(fit_to_bounds([1.0; 3], [0.0; 3], Vec3::Z, 1.0, persp)));
        assert!(!ok(fit_to_bounds(
            [f32::NAN; 3],
            [0.0; 3],
            Vec3::Z,
            1.0,
            persp
        )));
        assert!(!ok(fit_to_bounds(
            [0.0; 3],
            [1.0; 3],
            Vec3::ZERO,
            1.0,
            persp
        )));
        assert!(!ok(fit_to_bounds([0.0; 3], [1.0; 3], Vec3::Z, 0.0, persp)));
        let wide = Projection::Perspective { vertical_fov: 4.0 };
        assert!(!ok(fit_to_bounds([0.0; 3], [1.0; 3], Vec3::Z, 1.0, wide)));
    }
}
