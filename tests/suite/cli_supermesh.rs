//! The supermesh through the command line: `morphlod supermesh A B -o S.glb` writes a GLB
//! that reads back (with our loader and with the `gltf` crate) as exactly the supermesh's
//! poses, `morphlod build A B` takes meshes of different connectivity, and bad input (open,
//! genus > 0, several components, a bad landmarks line) is a clear error with exit code 1,
//! never a panic.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use morphlod::io::{load_mesh, load_morph, LoadOptions, MorphSource};
use morphlod::morph::supermesh::{Supermesh, SupermeshOptions};

fn morphlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .args(args)
        .output()
        .expect("the morphlod binary runs")
}

fn text(output: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

/// A fresh directory under the target's temp folder.
fn temp_dir(name: &str) -> PathBuf {
    common::scratch_dir("cli_supermesh", name)
}

fn write_off(path: &Path, vertices: &[[f64; 3]], faces: &[Vec<usize>]) {
    let mut s = format!("OFF\n{} {} 0\n", vertices.len(), faces.len());
    for v in vertices {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for f in faces {
        s += &format!(
            "{} {}\n",
            f.len(),
            f.iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    std::fs::write(path, s).unwrap();
}

/// A UV sphere: `rings` latitude bands, `segments` around, poles as single vertices
/// (closed, genus 0), radius `r`, squashed along z by `squash`.
fn uv_sphere(
    rings: usize,
    segments: usize,
    r: f64,
    squash: f64,
) -> (Vec<[f64; 3]>, Vec<Vec<usize>>) {
    let mut v = vec![[0.0, 0.0, r * squash]];
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = std::f64::consts::TAU * j as f64 / segments as f64;
            v.push([
                r * theta.sin() * phi.cos(),
                r * theta.sin() * phi.sin(),
                r * squash * theta.cos(),
            ]);
        }
    }
    v.push([0.0, 0.0, -r * squash]);
    let south = v.len() - 1;
    let at = |i: usize, j: usize| 1 + (i - 1) * segments + j % segments;
    let mut f = Vec::new();
    for j in 0..segments {
        f.push(vec![0, at(1, j), at(1, j + 1)]);
        f.push(vec![south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            f.push(vec![at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            f.push(vec![at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (v, f)
}

/// A cube of side 2 with each face split into 2×2 quads, each quad into two triangles.
fn cube() -> (Vec<[f64; 3]>, Vec<Vec<usize>>) {
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut id = |p: [i32; 3], v: &mut Vec<[f64; 3]>| {
        *index.entry(p).or_insert_with(|| {
            v.push([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]);
            v.len() - 1
        })
    };
    let mut f = Vec::new();
    // Each face: normal axis k, side s; (u, w) the other two axes, oriented outward.
    for k in 0..3 {
        for s in [-1i32, 1] {
            let (u, w) = if s > 0 {
                ((k + 1) % 3, (k + 2) % 3)
            } else {
                ((k + 2) % 3, (k + 1) % 3)
            };
            for a in -1..1 {
                for b in -1..1 {
                    let point = |da: i32, db: i32| {
                        let mut p = [0; 3];
                        p[k] = s;
                        p[u] = a + da;
                        p[w] = b + db;
                        p
                    };
                    let q =
                        [point(0, 0), point(1, 0), point(1, 1), point(0, 1)].map(|p| id(p, &mut v));
                    f.push(vec![q[0], q[1], q[2]]);
                    f.push(vec![q[0], q[2], q[3]]);
                }
            }
        }
    }
    (v, f)
}

/// A torus (genus 1).
fn torus() -> (Vec<[f64; 3]>, Vec<Vec<usize>>) {
    let (n, m) = (12, 8);
    let mut v = Vec::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        for j in 0..m {
            let b = std::f64::consts::TAU * j as f64 / m as f64;
            let r = 1.0 + 0.3 * b.cos();
            v.push([r * a.cos(), r * a.sin(), 0.3 * b.sin()]);
        }
    }
    let at = |i: usize, j: usize| (i % n) * m + j % m;
    let mut f = Vec::new();
    for i in 0..n {
        for j in 0..m {
            f.push(vec![at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            f.push(vec![at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (v, f)
}

/// Two meshes of different connectivity: a UV sphere and a subdivided cube.
fn pair(dir: &Path) -> (PathBuf, PathBuf) {
    let a = dir.join("sphere.off");
    let b = dir.join("cube.off");
    let (v, f) = uv_sphere(8, 12, 1.2, 0.8);
    write_off(&a, &v, &f);
    let (v, f) = cube();
    write_off(&b, &v, &f);
    (a, b)
}

/// Whether some f32 `d` has `a + d == b` (searched near `b − a`, where it is if anywhere).
fn reachable(a: f32, b: f32) -> bool {
    let d = b - a;
    (-8i32..=8).any(|k| {
        let c = f32::from_bits((d.to_bits() as i32 + k) as u32);
        c.is_finite() && a + c == b
    })
}

#[test]
fn supermesh_glb_reads_back_bit_for_bit() {
    let dir = temp_dir("glb");
    let (a, b) = pair(&dir);
    let glb = dir.join("s.glb");
    let out = morphlod(&[
        "supermesh",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        glb.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "supermesh",
        "crossings",
        "fold-overs        0",
        "Hausdorff t = 0 to A",
        "Hausdorff t = 1 to B",
        "alignment",
        "limb tips",
        "stages",
    ] {
        assert!(stdout.contains(needle), "no '{needle}' in\n{}", text(&out));
    }

    // The same build in the library (the seed is fixed, so it is the same supermesh).
    let options = LoadOptions::default();
    let ma = load_mesh(&a, &options).unwrap();
    let mb = load_mesh(&b, &options).unwrap();
    let (supermesh, report) = Supermesh::build(&ma, &mb, &SupermeshOptions::default()).unwrap();
    assert_eq!(report.fold_overs, 0);

    // Our loader: V(0) and V(1) bit for bit, the triangles as built.
    let morph = load_morph(&glb, &options, &MorphSource::Target("0".into())).unwrap();
    assert_eq!(morph.triangles(), supermesh.triangles.as_slice());
    let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&morph.v0()), bits(&supermesh.v0));
    // V(1) is stored as base + delta (glTF has no other way): bit for bit wherever an f32
    // delta reaches V(1) from V(0); where none does (V(1) has finer steps than V(0) and the
    // delta, e.g. 0.96 -> 0.4005698 with an odd last bit), the nearest, 1 ulp of V(0) away.
    let loaded = morph.v1();
    let mut unreachable = 0;
    for (i, ((a, b), got)) in supermesh
        .v0
        .iter()
        .zip(&supermesh.v1)
        .zip(&loaded)
        .enumerate()
    {
        for k in 0..3 {
            if reachable(a[k], b[k]) {
                assert_eq!(got[k].to_bits(), b[k].to_bits(), "vertex {i} axis {k}");
            } else {
                unreachable += 1;
                let ulp = f32::EPSILON * a[k].abs().max(b[k].abs());
                assert!(
                    (got[k] - b[k]).abs() <= ulp,
                    "vertex {i} axis {k}: {} vs {}",
                    got[k],
                    b[k]
                );
            }
        }
    }
    eprintln!(
        "V(1): {unreachable} of {} coordinates cannot be reached by an f32 delta",
        3 * loaded.len()
    );
    // By name too (extras.targetNames).
    assert!(load_morph(&glb, &options, &MorphSource::Target("V(1)".into())).is_ok());

    // The gltf crate validates the document (Gltf::from_slice runs its validator).
    let bytes = std::fs::read(&glb).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid glTF");
    assert_eq!(gltf.meshes().count(), 1);
    let mesh = gltf.meshes().next().unwrap();
    assert_eq!(mesh.weights(), Some(&[0.0f32][..]));
    let primitive = mesh.primitives().next().unwrap();
    let position = primitive.get(&gltf::Semantic::Positions).unwrap();
    assert!(position.min().is_some() && position.max().is_some());
    assert_eq!(position.count(), supermesh.v0.len());
    assert_eq!(primitive.morph_targets().count(), 1);
    let target = primitive
        .morph_targets()
        .next()
        .unwrap()
        .positions()
        .unwrap();
    assert!(target.min().is_some() && target.max().is_some());
    let animation = gltf.animations().next().expect("a weight animation");
    let channel = animation.channels().next().unwrap();
    assert_eq!(
        channel.target().property(),
        gltf::animation::Property::MorphTargetWeights
    );
    assert_eq!(
        channel.sampler().interpolation(),
        gltf::animation::Interpolation::Linear
    );
    assert!(channel.sampler().input().min().is_some());
    // Framing: header length, 4-byte chunks, BIN chunk present.
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(json_len % 4, 0);
    assert_eq!(&bytes[20 + json_len + 4..20 + json_len + 8], b"BIN\0");
    for view in gltf.views() {
        assert_eq!(view.offset() % 4, 0);
        assert_eq!(view.length() % 4, 0);
    }
}

#[test]
fn build_takes_meshes_of_different_connectivity() {
    let dir = temp_dir("build");
    let (a, b) = pair(&dir);
    let landmarks = dir.join("pairs.txt");
    std::fs::write(
        &landmarks,
        "# north pole of the sphere to a cube corner\n0 0\n",
    )
    .unwrap();
    let asset = dir.join("s.mlod");
    let out = morphlod(&[
        "build",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--frames",
        "4",
        "--landmarks",
        landmarks.to_str().unwrap(),
        "-o",
        asset.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("have different connectivity: built a supermesh"),
        "{}",
        text(&out)
    );
    assert!(stdout.contains("landmarks"), "{}", text(&out));
    let loaded = morphlod::Asset::load(&asset).unwrap();
    assert_eq!(loaded.frames.len(), 4);
    // The landmark was used: one vertex of the asset is the sphere's north pole at t = 0 and
    // the cube's corner 0 at t = 1 (the pair merged into one supermesh vertex, each end at its
    // mesh's position exactly); the automatic alignment puts the pole on the cube's top face.
    let options = LoadOptions::default();
    let pole = load_mesh(&a, &options).unwrap().positions[0];
    let corner = load_mesh(&b, &options).unwrap().positions[0];
    let paired = (loaded.v0.iter().zip(&loaded.v1)).filter(|&(&p, &q)| (p, q) == (pole, corner));
    assert_eq!(
        paired.count(),
        1,
        "the pole {pole:?} is not paired with the corner {corner:?}"
    );
}

/// Two poses of one mesh: `supermesh` says the connectivity is the same and
/// writes it as it is (A's vertices and triangles, V(1) = B).
#[test]
fn supermesh_of_two_poses_uses_their_connectivity() {
    let dir = temp_dir("same");
    let (a, b) = (dir.join("round.off"), dir.join("flat.off"));
    let (v, f) = uv_sphere(8, 12, 1.2, 1.0);
    write_off(&a, &v, &f);
    let (v, f) = uv_sphere(8, 12, 0.7, 0.4);
    write_off(&b, &v, &f);
    let glb = dir.join("s.glb");
    let out = morphlod(&[
        "supermesh",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        glb.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("connectivity      the same"),
        "{}",
        text(&out)
    );
    let options = LoadOptions::default();
    let morph = load_morph(&glb, &options, &MorphSource::Target("0".into())).unwrap();
    let ma = load_mesh(&a, &options).unwrap();
    assert_eq!(morph.triangles(), ma.triangles.as_slice());
    assert_eq!(morph.v0(), ma.positions);
}

#[test]
fn bad_landmarks_name_the_line() {
    let dir = temp_dir("landmarks");
    let (a, b) = pair(&dir);
    let landmarks = dir.join("pairs.txt");
    // A line that does not parse, then one out of range (the library's check, through the CLI).
    for (content, says) in [
        ("0 0\n3 x\n", ["pairs.txt", "line 2"]),
        ("0 100000\n", ["out of range", "line 1"]),
    ] {
        std::fs::write(&landmarks, content).unwrap();
        let out = morphlod(&[
            "supermesh",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--landmarks",
            landmarks.to_str().unwrap(),
            "-o",
            dir.join("s.glb").to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(1), "{}", text(&out));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(says.iter().all(|s| stderr.contains(s)), "{}", text(&out));
    }
}

/// Each bad B mesh against a good A, through both commands: exit code 1, an error line
/// naming the check, no panic.
#[test]
fn bad_input_is_a_clear_error() {
    let dir = temp_dir("bad");
    let (a, _) = pair(&dir);
    let (sv, sf) = uv_sphere(6, 8, 1.0, 1.0);

    let open = dir.join("open.off");
    write_off(&open, &sv, &sf[1..]);
    let genus = dir.join("torus.off");
    let (tv, tf) = torus();
    write_off(&genus, &tv, &tf);
    let two = dir.join("two.off");
    let mut v2 = sv.clone();
    let mut f2 = sf.clone();
    let offset = v2.len();
    v2.extend(sv.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
    f2.extend(sf.iter().map(|f| f.iter().map(|i| i + offset).collect()));
    write_off(&two, &v2, &f2);

    for (file, needle) in [
        (&open, "is open"),
        (&genus, "genus 1"),
        (&two, "2 connected components"),
    ] {
        for command in ["supermesh", "build"] {
            let output = dir.join(if command == "build" {
                "x.mlod"
            } else {
                "x.glb"
            });
            let out = morphlod(&[
                command,
                a.to_str().unwrap(),
                file.to_str().unwrap(),
                "-o",
                output.to_str().unwrap(),
            ]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(
                out.status.code(),
                Some(1),
                "{command} {}: {}",
                file.display(),
                text(&out)
            );
            assert!(!stderr.contains("panicked"), "{}", text(&out));
            assert!(
                stderr.contains("error: mesh B") && stderr.contains(needle),
                "{command} {}: no '{needle}' in {}",
                file.display(),
                text(&out)
            );
            assert!(
                !output.exists(),
                "{command} wrote {} on failure",
                output.display()
            );
        }
    }
}

/// `supermesh --fit`: V(1) in the GLB is B fitted onto A (`fit_b_onto_a` of the same
/// supermesh), and the report says so and measures the fitted ends.
#[test]
fn supermesh_fit_writes_b_fitted_onto_a() {
    use morphlod::morph::supermesh::fit_b_onto_a;
    let dir = temp_dir("fit");
    let (a, b) = pair(&dir);
    let glb = dir.join("s.glb");
    let (a_str, b_str, glb_str) = (
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        glb.to_str().unwrap(),
    );
    let out = morphlod(&["supermesh", a_str, b_str, "--fit", "-o", glb_str]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("B fitted onto A"),
        "{}",
        text(&out)
    );
    let options = LoadOptions::default();
    let (ma, mb) = (
        load_mesh(&a, &options).unwrap(),
        load_mesh(&b, &options).unwrap(),
    );
    let (supermesh, _) = Supermesh::build(&ma, &mb, &SupermeshOptions::default()).unwrap();
    let fitted = fit_b_onto_a(&supermesh.triangles, &supermesh.v0, &supermesh.v1);
    let morph = load_morph(&glb, &options, &MorphSource::Target("0".into())).unwrap();
    let loaded = morph.v1();
    assert_eq!(loaded.len(), fitted.len());
    let moved = fitted
        .iter()
        .zip(&supermesh.v1)
        .any(|(f, b)| (0..3).any(|k| (f[k] - b[k]).abs() > 1e-3));
    assert!(moved, "the pair is placed alike: the fit moved nothing");
    for (got, want) in loaded.iter().zip(&fitted) {
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() <= 1e-5 * (1.0 + want[k].abs()),
                "{got:?} {want:?}"
            );
        }
    }
}
