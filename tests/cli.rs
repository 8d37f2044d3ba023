//! The `morphlod` command line, run as a user runs it: messages and exit codes
//! for the rough edges of issue 13.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn morphlod(args: &[&str]) -> Output {
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

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
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
