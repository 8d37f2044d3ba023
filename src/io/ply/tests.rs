use super::*;

fn ply(bytes: &[u8]) -> Result<IndexedMesh, LoadError> {
    parse(bytes, Path::new("test.ply"))
}

#[test]
fn ascii_with_extra_properties_and_elements() {
    let text = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 4\r\nproperty float nx\r\nproperty float32 x\r\nproperty double y\r\nproperty uchar red\r\nproperty int z\r\nelement face 2\r\nproperty list uchar int vertex_indices\r\nproperty list ushort float texcoord\r\nelement edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\nend_header\r\n9 0 0 255 0\r\n9 1 0 255 0\r\n9 1 1 255 0\r\n9 0 1 255 3\r\n4 0 1 2 3 2 0.5 0.5\r\n3 3 2 1 0\r\n0 1\r\n";
    let mesh = ply(text.as_bytes()).unwrap();
    assert_eq!(
        mesh.positions,
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 3.0]
        ]
    );
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]]);
}

/// Binary little-endian PLY: double coordinates between other scalars, a
/// face element with a skipped list before the indices, an `edge` element.
#[test]
fn binary_little_endian_skips_by_size() {
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty uint8 flag\nproperty float64 x\nproperty float64 y\nproperty float64 z\nproperty short s\nelement face 1\nproperty list uint16 float32 uv\nproperty list uint int32 vertex_index\nelement edge 1\nproperty list uchar int vertices\nend_header\n";
    let mut bytes = header.as_bytes().to_vec();
    for (i, p) in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]]
        .iter()
        .enumerate()
    {
        bytes.push(i as u8);
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        bytes.extend_from_slice(&(-7i16).to_le_bytes());
    }
    bytes.extend_from_slice(&2u16.to_le_bytes());
    bytes.extend_from_slice(&0.25f32.to_le_bytes());
    bytes.extend_from_slice(&0.75f32.to_le_bytes());
    bytes.extend_from_slice(&3u32.to_le_bytes());
    for v in [2i32, 1, 0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes.push(2);
    bytes.extend_from_slice(&0i32.to_le_bytes());
    bytes.extend_from_slice(&1i32.to_le_bytes());
    let mesh = ply(&bytes).unwrap();
    assert_eq!(mesh.positions[2], [0.0, 1.0, 0.5]);
    assert_eq!(mesh.triangles, vec![[2, 1, 0]]);
    // One byte short of the edge record: truncation names the element.
    let err = ply(&bytes[..bytes.len() - 1]).unwrap_err();
    assert!(matches!(err, LoadError::Truncated { .. }), "{err}");
    assert!(err.to_string().contains("edge 0 of the 1"), "{err}");
}

/// The cow written as ASCII and as binary PLY loads back bit for bit.
#[test]
fn cow_round_trips_through_both_encodings() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/cow.off");
    let cow = crate::io::off::load(&path).unwrap();
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
            cow.vertex_count(),
            cow.triangle_count()
        )
    };
    let mut ascii = header("ascii");
    let mut binary = header("binary_little_endian").into_bytes();
    for p in &cow.positions {
        // `{:?}` prints the shortest text that parses back to the same f32.
        ascii += &format!("{:?} {:?} {:?}\n", p[0], p[1], p[2]);
        for c in p {
            binary.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &cow.triangles {
        ascii += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
        binary.push(3);
        for v in t {
            binary.extend_from_slice(&v.to_le_bytes());
        }
    }
    assert_eq!(ply(ascii.as_bytes()).unwrap(), cow);
    assert_eq!(ply(&binary).unwrap(), cow);
}

#[test]
fn normals_and_texture_coordinates_are_read() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float nx\nproperty float y\nproperty float z\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty float s\nproperty float t\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                0 0 0 0 0 1 255 0 0\n1 0 0 0 0 1 255 1 0.25\n0 0 1 0 1 0 255 0 1\n3 0 1 2\n";
    let mesh = parse_attributed(text.as_bytes(), Path::new("n.ply")).unwrap();
    assert_eq!(mesh.positions.positions[2], [0.0, 1.0, 0.0]);
    assert_eq!(
        mesh.attributes.normals.as_deref(),
        Some(&[[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]][..])
    );
    // `t` flipped to glTF's convention.
    assert_eq!(
        mesh.attributes.uvs.as_deref(),
        Some(&[[0.0, 1.0], [1.0, 0.75], [0.0, 0.0]][..])
    );
    assert_eq!(mesh.position_of, vec![0, 1, 2]);
    // Only `nx ny` (no `nz`) is not a normal; `u` without `v` is not a UV.
    let partial = PLY_PARTIAL;
    let mesh = parse_attributed(partial.as_bytes(), Path::new("p.ply")).unwrap();
    assert!(!mesh.attributes.has_vertex_attributes());
    assert_eq!(mesh.positions.positions[1], [1.0, 0.0, 0.0]);
}

#[test]
fn colours_are_read_and_decoded_from_srgb() {
    // `uchar` channels with alpha, as MeshLab writes them; properties in any order.
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty uchar alpha\nproperty float x\nproperty uchar blue\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                255 0 0 0 0 255 0\n128 1 255 0 0 0 255\n0 0 10 1 0 255 255\n3 0 1 2\n";
    let mesh = parse_attributed(text.as_bytes(), Path::new("c.ply")).unwrap();
    let colors = mesh
        .attributes
        .colors
        .expect("red, green and blue are declared");
    assert_eq!(colors[0], [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(colors[1], [0.0, 1.0, 1.0, 128.0 / 255.0]);
    // sRGB 10/255 lies on the transfer function's linear segment: 10/255/12.92.
    assert!(
        (colors[2][2] - 10.0 / 255.0 / 12.92).abs() < 1e-7,
        "{colors:?}"
    );
    assert_eq!(colors[2][3], 0.0);
    // Float channels are in [0, 1]; no `alpha` means opaque; mid-grey decodes to ~0.214.
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float red\nproperty float green\nproperty float blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                0 0 0 0.5 0.5 0.5\n1 0 0 1 1 1\n0 1 0 0 0 0\n3 0 1 2\n";
    let mesh = parse_attributed(text.as_bytes(), Path::new("f.ply")).unwrap();
    let colors = mesh.attributes.colors.unwrap();
    assert!((colors[0][0] - 0.21404).abs() < 1e-4, "{colors:?}");
    assert_eq!(colors[1], [1.0; 4]);
    // `red` alone is not a colour.
    let mesh = parse_attributed(
        PLY_PARTIAL.replace("float u", "uchar red").as_bytes(),
        Path::new("r.ply"),
    );
    assert!(mesh.unwrap().attributes.colors.is_none());
}

const PLY_PARTIAL: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float u\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n3 0 1 2\n";

#[test]
fn binary_normals_and_uvs() {
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty double nx\nproperty double ny\nproperty double nz\nproperty float texture_u\nproperty float texture_v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for (p, uv) in [
        ([0.0f32, 0.0, 0.0], [0.0f32, 0.0]),
        ([1.0, 0.0, 0.0], [1.0, 0.0]),
        ([0.0, 1.0, 0.0], [0.0, 1.0]),
    ] {
        p.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
        [0.0f64, 0.0, -1.0]
            .iter()
            .for_each(|c| bytes.extend(c.to_le_bytes()));
        uv.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
    }
    bytes.push(3);
    [0i32, 1, 2]
        .iter()
        .for_each(|i| bytes.extend(i.to_le_bytes()));
    let mesh = parse_attributed(&bytes, Path::new("b.ply")).unwrap();
    assert_eq!(
        mesh.attributes.normals.as_deref(),
        Some(&[[0.0, 0.0, -1.0]; 3][..])
    );
    assert_eq!(
        mesh.attributes.uvs.as_deref(),
        Some(&[[0.0, 1.0], [1.0, 1.0], [0.0, 0.0]][..])
    );
}
