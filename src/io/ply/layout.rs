//! Where the mesh data sits in a parsed header ([`Header::mesh_layout`]): the vertex
//! element's coordinates, normals, texture coordinates and colours, and the face element's
//! vertex-index list, their types checked.

use std::path::Path;

use super::super::{LoadError, Location};
use super::header::{Header, Kind};

/// Where the wanted data sits: element and property indices into the header.
pub(super) struct MeshLayout {
    pub(super) vertex: usize,
    /// The `x`, `y`, `z` property indices of the vertex element.
    xyz: [usize; 3],
    /// The `nx`, `ny`, `nz` scalar properties, when all three are declared.
    pub(super) normal: Option<[usize; 3]>,
    /// The texture coordinate pair of scalar properties, when declared.
    pub(super) uv: Option<[usize; 2]>,
    /// The `red`, `green`, `blue` scalar properties when all three are declared, and
    /// `alpha` when it is too.
    pub(super) color: Option<([usize; 3], Option<usize>)>,
    pub(super) face: usize,
    /// The vertex-index list property of the face element.
    pub(super) indices: usize,
}

/// What a vertex property holds.
pub(super) enum Slot {
    Position(usize),
    Normal(usize),
    Uv(usize),
    /// Red, green, blue, alpha: 0 to 3.
    Color(usize),
    Other,
}

impl MeshLayout {
    pub(super) fn slot(&self, property: usize) -> Slot {
        let find = |axes: &[usize]| axes.iter().position(|&a| a == property);
        if let Some(axis) = find(&self.xyz) {
            return Slot::Position(axis);
        }
        if let Some(axis) = self.normal.as_ref().and_then(|n| find(n)) {
            return Slot::Normal(axis);
        }
        if let Some(axis) = self.uv.as_ref().and_then(|uv| find(uv)) {
            return Slot::Uv(axis);
        }
        match self.color {
            Some((_, Some(alpha))) if alpha == property => Slot::Color(3),
            Some((rgb, _)) => find(&rgb).map_or(Slot::Other, Slot::Color),
            None => Slot::Other,
        }
    }
}

/// The names exporters give a vertex's texture coordinates.
const UV_NAMES: [[&str; 2]; 4] = [
    ["u", "v"],
    ["s", "t"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

impl Header {
    /// Finds the vertex coordinates and the face index list, checking their types.
    pub(super) fn mesh_layout(&self, path: &Path) -> Result<MeshLayout, LoadError> {
        let syntax = |line: usize, message: String| LoadError::Syntax {
            path: path.to_path_buf(),
            at: Location::Line(line),
            message,
        };
        let find = |name: &str| self.elements.iter().position(|e| e.name == name);
        let end = self.lines;
        let vertex = find("vertex")
            .ok_or_else(|| syntax(end, "the header declares no `element vertex`".into()))?;
        let face = find("face").ok_or_else(|| {
            syntax(
                end,
                "the header declares no `element face`: this is a point cloud, not a mesh".into(),
            )
        })?;
        let vertices = &self.elements[vertex];
        let mut xyz = [0usize; 3];
        for (slot, axis) in xyz.iter_mut().zip(["x", "y", "z"]) {
            let p = vertices
                .properties
                .iter()
                .position(|p| p.name == axis)
                .ok_or_else(|| {
                    syntax(
                        vertices.line,
                        format!("`element vertex` has no `{axis}` property"),
                    )
                })?;
            if let Kind::List(..) = vertices.properties[p].kind {
                return Err(syntax(
                    vertices.properties[p].line,
                    format!("vertex property `{axis}` must be a scalar, not a list"),
                ));
            }
            *slot = p;
        }
        // Normals and UVs are optional: a name declared as a list is not one.
        let scalar = |name: &str| {
            vertices
                .properties
                .iter()
                .position(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
        };
        let normal = match ["nx", "ny", "nz"].map(scalar) {
            [Some(x), Some(y), Some(z)] => Some([x, y, z]),
            _ => None,
        };
        let uv = UV_NAMES.iter().find_map(|names| match names.map(scalar) {
            [Some(u), Some(v)] => Some([u, v]),
            _ => None,
        });
        let color = match ["red", "green", "blue"].map(scalar) {
            [Some(r), Some(g), Some(b)] => Some(([r, g, b], scalar("alpha"))),
            _ => None,
        };
        let faces = &self.elements[face];
        let indices = faces
            .properties
            .iter()
            .position(|p| p.name == "vertex_indices" || p.name == "vertex_index")
            .ok_or_else(|| {
                syntax(
                    faces.line,
                    "`element face` has no `vertex_indices` (or `vertex_index`) list".into(),
                )
            })?;
        let property = &faces.properties[indices];
        match property.kind {
            Kind::List(_, item) if item.is_integer() => {}
            _ => {
                return Err(syntax(
                    property.line,
                    format!("`{}` must be a list of an integer type", property.name),
                ))
            }
        }
        Ok(MeshLayout {
            vertex,
            xyz,
            normal,
            uv,
            color,
            face,
            indices,
        })
    }
}
