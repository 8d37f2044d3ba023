//! The `morphlod` command line, run as a user runs it: messages and exit codes
//! for the rough edges of issue 13.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub(crate) fn morphlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets")
        .join(name)
}

/// A fresh directory for one test's files, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("morphlod-cli-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

pub(crate) fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Whether a command that renders failed for want of a GPU adapter (the CLI prints
/// `GpuError::NoAdapter`'s message): then the test skips, except under CI, where this panics
/// (`common::skip_outside_ci`, the rule of every GPU test). Any other failure is the test's to
/// judge.
pub(crate) fn no_adapter(out: &Output) -> bool {
    let stderr = text(&out.stderr);
    if out.status.success() || !stderr.contains("no GPU adapter found") {
        return false;
    }
    common::skip_outside_ci(&format!("no GPU adapter: {stderr}"));
    true
}

/// The cow as a triangle soup: every triangle its own three vertices.
fn cow_soup() -> String {
    let cow = morphlod::io::off::load(&asset("cow.off")).unwrap();
    let mut out = String::new();
    for t in &cow.triangles {
        for &v in t {
            let p = cow.positions[v as usize];
            out += &format!("v {} {} {}\n", p[0], p[1], p[2]);
        }
    }
    for i in 0..cow.triangles.len() {
        out += &format!("f {} {} {}\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    out
}

/// `info` says a soup is a soup and that it was welded (into the cow's one
/// closed component), and `--no-weld` keeps it apart but still says so.
#[test]
fn info_detects_and_welds_a_soup() {
    let dir = Scratch::new("soup");
    let soup = dir.path("soup.obj");
    std::fs::write(&soup, cow_soup()).unwrap();
    let out = morphlod(&["info", soup.to_str().unwrap()]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(stdout.contains("triangle soup"), "{stdout}");
    assert!(stdout.contains("components        1 ("), "{stdout}");
    assert!(stdout.contains("--no-weld"), "{stdout}");

    let out = morphlod(&["info", "--no-weld", soup.to_str().unwrap()]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(stdout.contains("triangle soup"), "{stdout}");
    assert!(stdout.contains("components        5804"), "{stdout}");
}

/// `build one.off` alone: an OFF file holds one mesh and no morph targets, so the
/// message asks for a second mesh and does not send the user to `morphlod info`.
#[test]
fn build_one_off_asks_for_two_meshes() {
    let dir = Scratch::new("one-off");
    let out_path = dir.path("out.mlod");
    let cow = asset("cow.off");
    let out = morphlod(&[
        "build",
        cow.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("morphlod info"), "{stderr}");
    assert!(!stderr.contains("--target"), "{stderr}");
    assert!(stderr.contains("two meshes"), "{stderr}");
    assert!(!out_path.exists());
}

/// `build` welds a two-pose soup morph, says so, and the asset has the welded vertex count.
#[test]
fn build_welds_a_soup_morph() {
    let dir = Scratch::new("soup-build");
    let (a, b, out_path) = (dir.path("a.obj"), dir.path("b.obj"), dir.path("out.mlod"));
    let soup = cow_soup();
    std::fs::write(&a, &soup).unwrap();
    // V(1): the same soup twice as large (every copy still meets its twins).
    let scaled: String = soup
        .lines()
        .map(|line| match line.strip_prefix("v ") {
            Some(xyz) => {
                let p: Vec<f32> = xyz
                    .split(' ')
                    .map(|c| c.parse::<f32>().unwrap() * 2.0)
                    .collect();
                format!("v {} {} {}\n", p[0], p[1], p[2])
            }
            None => format!("{line}\n"),
        })
        .collect();
    std::fs::write(&b, scaled).unwrap();
    let args = [
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--frames",
        "2",
        "-o",
        out_path.to_str().unwrap(),
    ];
    let out = morphlod(&[&["build"][..], &args].concat());
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        stdout.contains("welded (keep it apart with --no-weld)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("build: 2903 vertices, 5804 triangles"),
        "{stdout}"
    );
}

// ---- phase 2: items 3, 6, 9, 11 --------------------------------------------------

/// A closed octahedron scaled by `scale`, as OFF text: a small mesh that still
/// simplifies and renders.
fn octahedron(scale: f64, stretch: f64) -> String {
    let mut out = String::from("OFF\n6 8 0\n");
    for p in [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ] {
        let q = [p[0] * scale * stretch, p[1] * scale, p[2] * scale];
        out += &format!("{:e} {:e} {:e}\n", q[0], q[1], q[2]);
    }
    for f in [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ] {
        out += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    out
}

/// Builds the octahedron morph at `scale` into `dir/name.mlod`.
fn build_octahedron(dir: &Scratch, name: &str, scale: f64) -> PathBuf {
    let (a, b) = (
        dir.path(&format!("{name}0.off")),
        dir.path(&format!("{name}1.off")),
    );
    std::fs::write(&a, octahedron(scale, 1.0)).unwrap();
    std::fs::write(&b, octahedron(scale, 1.5)).unwrap();
    let out_path = dir.path(&format!("{name}.mlod"));
    let out = morphlod(&[
        "build",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--frames",
        "2",
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    out_path
}

/// Item 9: `--t -0.5` parses (as a number, not as a flag), and out-of-range t is
/// handled by one rule with --lod: clamped to [0, 1] with a note saying so.
#[test]
fn render_negative_and_out_of_range_numbers() {
    let dir = Scratch::new("negative");
    let asset = build_octahedron(&dir, "oct", 1.0);
    let png = dir.path("out.png");
    let out = morphlod(&[
        "render",
        asset.to_str().unwrap(),
        "--t",
        "-0.5",
        "--lod",
        "1.5",
        "--size",
        "32",
        "-o",
        png.to_str().unwrap(),
    ]);
    if no_adapter(&out) {
        return;
    }
    let stderr = text(&out.stderr);
    assert!(!stderr.contains("unexpected argument"), "{stderr}");
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("t -0.5 is outside [0, 1]: clamped to 0"),
        "{stderr}"
    );
    assert!(
        stderr.contains("lod 1.5 is outside [0, 1]: clamped to 1"),
        "{stderr}"
    );
    // NaN is refused by both.
    let out = morphlod(&[
        "render",
        asset.to_str().unwrap(),
        "--t",
        "NaN",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("not a number"),
        "{}",
        text(&out.stderr)
    );
}

/// Item 3: a sheet whose image would pass the limit is refused before any
/// allocation, and the message says the limit.
#[test]
fn render_refuses_a_huge_sheet() {
    let dir = Scratch::new("huge-sheet");
    let asset = build_octahedron(&dir, "oct", 1.0);
    let png = dir.path("out.png");
    let out = morphlod(&[
        "render",
        asset.to_str().unwrap(),
        "--t",
        "0,0.25,0.5,0.75",
        "--lod",
        "0,0.25,0.5,0.75",
        "--size",
        "16384",
        "-o",
        png.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("65536 x 65536"), "{stderr}");
    assert!(stderr.contains("limit"), "{stderr}");
    assert!(!png.exists());
}

/// The fraction of a PNG's pixels that differ from its corner pixel (the
/// background), and how many distinct colours those pixels have.
fn drawn_fraction(png: &Path) -> (f64, usize) {
    let image = image::open(png).unwrap().to_rgba8();
    let background = *image.get_pixel(0, 0);
    let drawn: Vec<_> = image.pixels().filter(|&&p| p != background).collect();
    let mut colours: Vec<[u8; 4]> = drawn.iter().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    (
        drawn.len() as f64 / f64::from(image.width() * image.height()),
        colours.len(),
    )
}

/// Item 6: meshes about 1e19 and 1e-22 across render visibly and shaded: the render succeeds
/// (no error is an acceptable answer for a mesh whose coordinates are finite f32) and the
/// image is neither blank nor flat.
#[test]
fn render_extreme_scales_is_not_blank() {
    let dir = Scratch::new("scales");
    for (name, scale) in [("huge", 1e19), ("tiny", 1e-22), ("unit", 1.0)] {
        let asset = build_octahedron(&dir, name, scale);
        let png = dir.path(&format!("{name}.png"));
        let out = morphlod(&[
            "render",
            asset.to_str().unwrap(),
            "--size",
            "64",
            "-o",
            png.to_str().unwrap(),
        ]);
        if no_adapter(&out) {
            return;
        }
        let stderr = text(&out.stderr);
        assert!(out.status.success(), "{name} (scale {scale}): {stderr}");
        let (drawn, colours) = drawn_fraction(&png);
        assert!(
            drawn > 0.05,
            "{name} (scale {scale}): only {drawn} of the pixels drawn"
        );
        // Shaded, not ambient only: the visible faces of the octahedron differ.
        assert!(
            colours >= 3,
            "{name} (scale {scale}): {colours} colours, the faces are not shaded"
        );
    }
}

/// Item 11: clear errors for a directory, for a mesh given to `render`, and for
/// a `build` output that would overwrite an input or is not `.mlod`.
#[test]
fn clear_errors_for_wrong_paths() {
    let dir = Scratch::new("paths");
    let out = morphlod(&["info", dir.0.to_str().unwrap()]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("is a directory"), "{stderr}");
    assert!(!stderr.contains("extension"), "{stderr}");

    let cow = asset("cow.off");
    let png = dir.path("cow.png");
    let out = morphlod(&["render", cow.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("this is a mesh: build it first with `morphlod build`"),
        "{stderr}"
    );
    assert!(stderr.len() < 400, "{stderr}");

    let (a, b) = (dir.path("a.off"), dir.path("b.off"));
    std::fs::write(&a, octahedron(1.0, 1.0)).unwrap();
    std::fs::write(&b, octahedron(1.0, 1.5)).unwrap();
    let before = std::fs::read(&b).unwrap();
    let out = morphlod(&[
        "build",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        b.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("is one of the inputs"), "{stderr}");
    assert_eq!(
        std::fs::read(&b).unwrap(),
        before,
        "the input was overwritten"
    );

    let wrong = dir.path("out.png");
    let out = morphlod(&[
        "build",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        wrong.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains(".mlod"), "{stderr}");
    assert!(!wrong.exists());
}

/// A closed cube as OFF text (6 quads, 12 triangles): another connectivity than the octahedron.
fn cube() -> String {
    let mut out = String::from("OFF\n8 6 0\n");
    for k in 0..8 {
        let c = |bit: u32| if k & bit == 0 { -1.0 } else { 1.0 };
        out += &format!("{} {} {}\n", c(1), c(2), c(4));
    }
    for f in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        out += &format!("4 {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    out
}

/// Item 10: two meshes of different connectivity build through the supermesh,
/// with a note saying so, instead of an error suggesting one.
#[test]
fn build_different_connectivity_builds_a_supermesh() {
    let dir = Scratch::new("supermesh");
    let (a, b, out_path) = (
        dir.path("oct.off"),
        dir.path("cube.off"),
        dir.path("out.mlod"),
    );
    std::fs::write(&a, octahedron(1.0, 1.0)).unwrap();
    std::fs::write(&b, cube()).unwrap();
    let out = morphlod(&[
        "build",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--frames",
        "2",
        "-o",
        out_path.to_str().unwrap(),
    ]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{stderr}");
    assert!(
        stdout.contains("different connectivity: built a supermesh"),
        "{stdout}"
    );
    assert!(out_path.exists(), "{stdout}");
}

/// `info` on the MakeHuman face (refused before issue 11: zero-initialised accessors) reports
/// its attributes, the seams, and the welded surface the simplifier works on: one component
/// with one boundary loop at the neck, as assets/README.md describes it.
#[test]
fn info_reports_attributes_and_seams() {
    let face = asset("makehuman_face.glb");
    let out = morphlod(&["info", face.to_str().unwrap()]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for needle in [
        "4632 attribute vertices on 4437 topology vertices (191 seam vertices)",
        "normals           given",
        "uvs               given",
        "material          'skin', base colour [1.0, 1.0, 1.0, 1.0]",
        "texture           image/jpeg, 31373 bytes, 1024 x 1024 pixels",
        "normal deltas     given for 52 of 52 targets\n",
        "topology of the welded surface (seam copies joined)\n  vertices          4437 (0 isolated)",
        "boundary          54 edges in 1 loops",
    ] {
        assert!(stdout.contains(needle), "{needle:?} not in\n{stdout}");
    }
    // A mesh without attributes says its normals are computed and has no seams to weld.
    let out = morphlod(&["info", asset("cow.off").to_str().unwrap()]);
    let stdout = text(&out.stdout);
    assert!(stdout.contains("(0 seam vertices)"), "{stdout}");
    assert!(stdout.contains("none in the file: computed"), "{stdout}");
    assert!(
        !stdout.contains("topology of the welded surface"),
        "{stdout}"
    );
}

/// `info` on the walker names its skin (53 joints, its inverse bind matrices, the node that
/// draws mesh 0 with it) and which animation moves the joints: `walk`'s 14 channels are all on
/// skin joints, `morph` drives the weights; each with its length.
#[test]
fn info_lists_skins_and_the_animations_that_move_them() {
    let walker = asset("makehuman_walker.glb");
    let out = morphlod(&["info", walker.to_str().unwrap()]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for needle in [
        "1 skin(s)\n  skin 0",
        ": 53 joints, with inverse bind matrices; drawn by node ",
        " (mesh 0)\n",
        "animation 0 'walk': 0 weight channel(s), 14 other channel(s) (14 on skin joints), 1 s",
        "animation 1 'morph': 1 weight channel(s), 0 other channel(s) (0 on skin joints), 8 s",
    ] {
        assert!(stdout.contains(needle), "{needle:?} not in\n{stdout}");
    }
    // Without a skin, no skin line.
    let out = morphlod(&["info", asset("makehuman_face.glb").to_str().unwrap()]);
    assert!(!text(&out.stdout).contains("skin(s)"));
}

/// A tetrahedron with UVs in `dir/name.gltf` whose base-colour texture is the external file
/// `dir/name.png` holding `png`.
fn textured_tetrahedron(dir: &Scratch, name: &str, png: &[u8]) -> PathBuf {
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let uvs: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    let indices: [u16; 12] = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
    let mut bin = Vec::new();
    positions
        .iter()
        .flatten()
        .for_each(|c| bin.extend(c.to_le_bytes()));
    uvs.iter()
        .flatten()
        .for_each(|c| bin.extend(c.to_le_bytes()));
    indices.iter().for_each(|i| bin.extend(i.to_le_bytes()));
    std::fs::write(dir.path(&format!("{name}.bin")), &bin).unwrap();
    std::fs::write(dir.path(&format!("{name}.png")), png).unwrap();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},
        "buffers":[{{"uri":"{name}.bin","byteLength":{}}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},{{"buffer":0,"byteOffset":80,"byteLength":24}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1]}},
                     {{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},
                     {{"bufferView":2,"componentType":5123,"count":12,"type":"SCALAR"}}],
        "images":[{{"uri":"{name}.png"}}],"textures":[{{"source":0}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        bin.len()
    );
    let path = dir.path(&format!("{name}.gltf"));
    std::fs::write(&path, json).unwrap();
    path
}

/// A texture whose header is a PNG's but whose data does not decode is refused by `info`,
/// `build` and `export` when loading, before anything is written (loading alone checks only
/// the header), while the same file with a real PNG goes through.
#[test]
fn a_texture_that_does_not_decode_is_refused_before_writing() {
    let dir = Scratch::new("texture");
    let mut good = Vec::new();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255]))
        .write_to(
            &mut std::io::Cursor::new(&mut good),
            image::ImageFormat::Png,
        )
        .unwrap();
    // The signature and the IHDR chunk of a 2 x 2 RGBA image, then no image data.
    let mut broken = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x00\x02\x00\x00\x00\x02\x08\x06\x00\x00\x00".to_vec();
    broken.extend_from_slice(b"\x00\x00\x00\x00 not a PNG any more");
    let good = textured_tetrahedron(&dir, "good", &good);
    let broken = textured_tetrahedron(&dir, "broken", &broken);
    for (input, decodes) in [(&good, true), (&broken, false)] {
        let input = input.to_str().unwrap();
        let mlod = dir.path("out.mlod");
        let glb = dir.path("out.glb");
        let _ = std::fs::remove_file(&mlod);
        let _ = std::fs::remove_file(&glb);
        let runs = [
            morphlod(&["info", input]),
            morphlod(&[
                "build",
                input,
                input,
                "--frames",
                "2",
                "-o",
                mlod.to_str().unwrap(),
            ]),
            morphlod(&[
                "export",
                input,
                "-o",
                glb.to_str().unwrap(),
                "--lods",
                "0.5",
            ]),
        ];
        for out in &runs {
            let stderr = text(&out.stderr);
            assert_eq!(out.status.success(), decodes, "{input}: {stderr}");
            if !decodes {
                assert!(stderr.contains("broken.gltf"), "{stderr}");
                assert!(stderr.contains("(image/png) does not decode"), "{stderr}");
            }
        }
        assert_eq!(mlod.exists(), decodes, "{input}");
        assert_eq!(glb.exists(), decodes, "{input}");
    }
}

/// `--uv-weight`, `--normal-weight` and `--distance-weight` reach the simplifier of `export`
/// and `build`: on the face (UVs and normals) zero attribute weights, and the distance term
/// off, each give another sequence than export's defaults, and a weight that is negative or
/// not a number is refused.
#[test]
fn simplifier_weights_reach_the_simplifier() {
    let dir = Scratch::new("weights");
    let face = asset("makehuman_face.glb");
    let face = face.to_str().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path(name);
        // Two poses instead of 32: the weights reach the simplifier all the same, for a
        // sixteenth of the pricing (the distance term is on by default).
        let mut args = vec![
            "export",
            face,
            "-o",
            out.to_str().unwrap(),
            "--lods",
            "0.1",
            "--poses",
            "2",
        ];
        args.extend_from_slice(extra);
        let result = morphlod(&args);
        assert!(result.status.success(), "{}", text(&result.stderr));
        std::fs::read(out).unwrap()
    };
    let default = run("default.glb", &[]);
    let explicit = run(
        "explicit.glb",
        &["--uv-weight", "4", "--normal-weight", "0.1"],
    );
    let geometric = run(
        "geometric.glb",
        &["--uv-weight", "0", "--normal-weight", "0"],
    );
    let distance = run("distance.glb", &["--distance-weight", "4"]);
    let no_distance = run("no_distance.glb", &["--distance-weight", "0"]);
    assert!(default == explicit, "the defaults are 4 and 0.1");
    assert!(
        default == distance,
        "export's distance weight defaults to 4"
    );
    assert!(
        default != geometric,
        "zero weights must change the face's LOD"
    );
    assert!(
        default != no_distance,
        "turning the distance term off must change the face's LOD"
    );
    for (flag, bad) in ["--uv-weight", "--normal-weight", "--distance-weight"]
        .into_iter()
        .flat_map(|flag| ["-1", "nan", "inf"].map(|bad| (flag, bad)))
    {
        for command in ["export", "build"] {
            let out = morphlod(&[
                command,
                face,
                "--animation",
                "expressions",
                "-o",
                dir.path("x").to_str().unwrap(),
                flag,
                bad,
            ]);
            assert_eq!(out.status.code(), Some(2), "{command} {flag} {bad}");
            assert!(
                text(&out.stderr).contains("is not a weight"),
                "{}",
                text(&out.stderr)
            );
        }
    }
}

// ---- issue 23: one output rule for every command --------------------------------------

/// Runs `morphlod args...` in `dir` (so relative paths are relative to it), expects exit code
/// 1 with `needle` in the message, and every file of `inputs` byte for byte as it was.
fn assert_refused(dir: &Path, args: &[&str], needle: &str, inputs: &[&Path]) {
    let before: Vec<Vec<u8>> = inputs.iter().map(|p| std::fs::read(p).unwrap()).collect();
    let out = Command::new(env!("CARGO_BIN_EXE_morphlod"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("the binary runs");
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(
        stderr.contains(needle),
        "{args:?}: {needle:?} not in {stderr}"
    );
    for (input, bytes) in inputs.iter().zip(before) {
        assert!(
            std::fs::read(input).unwrap() == bytes,
            "{args:?}: {} was overwritten",
            input.display()
        );
    }
}

const IS_INPUT: &str = "the output is one of the inputs";

/// `dir/name`, a symbolic link to `target`.
fn link(dir: &Scratch, name: &str, target: &Path) -> PathBuf {
    let path = dir.path(name);
    std::os::unix::fs::symlink(target, &path).unwrap();
    path
}

/// `supermesh cow.off bull.off -o cow.off` overwrote the cow with a GLB: an output that is an
/// input, however spelled (same path, `./`, absolute, a symlink; the landmarks file too), and
/// an output that is not `.glb`, are refused and the inputs stay as they were.
#[test]
fn supermesh_refuses_an_input_or_a_wrong_extension_as_output() {
    let dir = Scratch::new("out-supermesh");
    let (cow, bull, pairs) = (
        dir.path("cow.off"),
        dir.path("bull.off"),
        dir.path("pairs.txt"),
    );
    std::fs::copy(asset("cow.off"), &cow).unwrap();
    std::fs::copy(asset("bull.off"), &bull).unwrap();
    std::fs::write(&pairs, "0 0\n").unwrap();
    let glb = link(&dir, "cow_link.glb", &cow);
    let inputs = [cow.as_path(), bull.as_path(), pairs.as_path()];
    let cow_abs = cow.to_str().unwrap();
    for output in [
        "cow.off",
        "./cow.off",
        cow_abs,
        "../",
        "bull.off",
        "pairs.txt",
    ] {
        let output = if output == "../" {
            // The scratch folder reached from its parent: `../<scratch>/cow.off`.
            format!(
                "../{}/cow.off",
                dir.0.file_name().unwrap().to_str().unwrap()
            )
        } else {
            output.to_string()
        };
        let args = [
            "supermesh",
            "cow.off",
            "bull.off",
            "--landmarks",
            "pairs.txt",
            "-o",
            &output,
        ];
        assert_refused(&dir.0, &args, IS_INPUT, &inputs);
    }
    let args = [
        "supermesh",
        "cow.off",
        "bull.off",
        "-o",
        glb.to_str().unwrap(),
    ];
    assert_refused(&dir.0, &args, IS_INPUT, &inputs);
    let args = ["supermesh", "cow.off", "bull.off", "-o", "out.off"];
    assert_refused(&dir.0, &args, "must be a .glb file", &inputs);
    assert!(!dir.path("out.off").exists());
}

/// `render head.mlod -o head.mlod` replaced the asset with a PNG: refused, as is an output
/// that is not `.png`.
#[test]
fn render_refuses_an_input_or_a_wrong_extension_as_output() {
    let dir = Scratch::new("out-render");
    let head = build_octahedron(&dir, "head", 1.0);
    let png = link(&dir, "head.png", &head);
    for output in [
        "head.mlod",
        "./head.mlod",
        head.to_str().unwrap(),
        png.to_str().unwrap(),
    ] {
        assert_refused(
            &dir.0,
            &["render", "head.mlod", "-o", output],
            IS_INPUT,
            &[&head],
        );
    }
    assert_refused(
        &dir.0,
        &["render", "head.mlod", "-o", "head.jpg"],
        "must be a .png file",
        &[&head],
    );
    assert!(!dir.path("head.jpg").exists());
}

/// `build` refuses every spelling of an input (a mesh or the landmarks file) and an output
/// that is not `.mlod`.
#[test]
fn build_refuses_an_input_or_a_wrong_extension_as_output() {
    assert_two_mesh_command_refuses_its_inputs("build", "mlod", "glb");
}

/// `export` refuses every spelling of an input (a mesh or the landmarks file) and an output
/// that is not `.glb`.
#[test]
fn export_refuses_an_input_or_a_wrong_extension_as_output() {
    assert_two_mesh_command_refuses_its_inputs("export", "glb", "gltf");
}

/// `command a.off b.off --landmarks pairs.txt -o X` (its output a `.ext` file) refuses as `X`
/// each input, spelled as given, with `./`, absolute, or through a link named `*.ext`; and
/// refuses an output ending in `.wrong`. The inputs stay as they were and nothing is written.
fn assert_two_mesh_command_refuses_its_inputs(command: &str, ext: &str, wrong: &str) {
    let dir = Scratch::new(&format!("out-{command}"));
    let (a, b, pairs) = (dir.path("a.off"), dir.path("b.off"), dir.path("pairs.txt"));
    std::fs::write(&a, octahedron(1.0, 1.0)).unwrap();
    std::fs::write(&b, cube()).unwrap();
    std::fs::write(&pairs, "0 0\n").unwrap();
    let linked = link(&dir, &format!("b.{ext}"), &b);
    let inputs = [a.as_path(), b.as_path(), pairs.as_path()];
    for output in [
        "a.off",
        "./b.off",
        a.to_str().unwrap(),
        "pairs.txt",
        linked.to_str().unwrap(),
    ] {
        let args = [
            command,
            "a.off",
            "b.off",
            "--landmarks",
            "pairs.txt",
            "-o",
            output,
        ];
        assert_refused(&dir.0, &args, IS_INPUT, &inputs);
    }
    let wrong_output = format!("out.{wrong}");
    let args = [command, "a.off", "b.off", "-o", &wrong_output];
    assert_refused(&dir.0, &args, &format!("must be a .{ext} file"), &inputs);
    assert!(!dir.path(&wrong_output).exists());
}

/// `bench --json` and `--plot` refuse the asset and a wrong extension before the benchmark
/// runs.
#[test]
fn bench_refuses_an_input_or_a_wrong_extension_as_output() {
    let dir = Scratch::new("out-bench");
    let head = build_octahedron(&dir, "head", 1.0);
    let json = link(&dir, "rows.json", &head);
    for flag in ["--json", "--plot"] {
        for output in ["head.mlod", "./head.mlod", head.to_str().unwrap()] {
            assert_refused(
                &dir.0,
                &["bench", "head.mlod", flag, output],
                IS_INPUT,
                &[&head],
            );
        }
    }
    let json = json.to_str().unwrap();
    assert_refused(
        &dir.0,
        &["bench", "head.mlod", "--json", json],
        IS_INPUT,
        &[&head],
    );
    for (flag, output, needle) in [
        ("--json", "rows.csv", "must be a .json file"),
        ("--plot", "plot.json", "must be a .png file"),
    ] {
        assert_refused(
            &dir.0,
            &["bench", "head.mlod", flag, output],
            needle,
            &[&head],
        );
        assert!(!dir.path(output).exists());
    }
}

/// The demo writes demo.mlod, demo.png and demo_strips.png into `--output`: one of them
/// resolving to the demo's input (here a symlink to the face) is refused before anything is
/// built, and an `--output` that is a file is refused, not written into.
#[test]
fn demo_refuses_an_input_as_output_and_a_file_as_folder() {
    let dir = Scratch::new("out-demo");
    let face = asset("makehuman_face.glb");
    let out = dir.path("out");
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&face, out.join("demo.mlod")).unwrap();
    assert_refused(&dir.0, &["demo", "-o", "out"], IS_INPUT, &[&face]);
    let file = dir.path("notes.txt");
    std::fs::write(&file, "keep me").unwrap();
    assert_refused(
        &dir.0,
        &["demo", "-o", "notes.txt"],
        "is a file, not a folder",
        &[&file],
    );
}
