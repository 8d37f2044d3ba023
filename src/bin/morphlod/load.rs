//! What the commands read, loaded the one way for all of them: `.mlod` assets within a
//! memory budget, meshes as the pipeline sees them (texture checked), two meshes as one morph
//! (over their supermesh when their connectivity differs), and the cleaning with its summary.

use crate::supermesh::{build_supermesh, read_landmarks, warn_fold_overs};
use morphlod::asset::{AssetLoadOptions, MAGIC};
use morphlod::io::{load_attributed, morph_from_pair, Format, LoadError, LoadOptions, MorphSource};
use morphlod::mesh::clean::CleanOptions;
use morphlod::morph::{Attributes, Morph, MorphError};
use std::io::Read;
use std::path::Path;

/// `--memory-budget MB` as load options.
pub(crate) fn budget(mb: u64) -> AssetLoadOptions {
    AssetLoadOptions {
        max_bytes: mb.saturating_mul(1 << 20),
    }
}

/// A `.mlod` file by extension, or any file starting with the `.mlod` magic.
pub(crate) fn is_asset(path: &Path) -> bool {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mlod"))
    {
        return true;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == MAGIC)
}

/// The bytes of a `.mlod` file, or a clear error for a mesh or a directory given instead.
pub(crate) fn read_asset(path: &Path, options: &AssetLoadOptions) -> Result<Vec<u8>, String> {
    if path.is_dir() {
        return Err(format!(
            "{}: is a directory, not a .mlod asset",
            path.display()
        ));
    }
    if !is_asset(path) && Format::from_path(path).is_some() {
        return Err(format!(
            "{}: this is a mesh: build it first with `morphlod build` (then give the .mlod file)",
            path.display()
        ));
    }
    let length = std::fs::metadata(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    if length > options.max_bytes {
        let e = morphlod::asset::AssetError::OverBudget {
            needed: length,
            budget: options.max_bytes,
        };
        return Err(format!("{}: {e}", path.display()));
    }
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The file as the pipeline sees it: a glTF mesh with its targets (at their default
/// weights) and attributes, or any mesh with its attributes and no targets.
pub(crate) fn load_surface(path: &Path, options: &LoadOptions) -> Result<Morph, String> {
    if Format::from_path(path) == Some(Format::Gltf) {
        match morphlod::io::load_morph(path, options, &MorphSource::DefaultWeights) {
            Err(LoadError::NoTargets { .. }) => {}
            other => return other.map_err(|e| e.to_string()),
        }
    }
    let morph = load_attributed(path, options)
        .map_err(|e| e.to_string())?
        .to_static_morph()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    check_texture(morph.attributes(), path)?;
    Ok(morph)
}

/// Refuses a base-colour texture that does not decode. Loading checks only the image's header
/// (the core does not link an image decoder), so without this a broken image would be built or
/// exported and fail only when drawn.
pub(crate) fn check_texture(attributes: &Attributes, path: &Path) -> Result<(), String> {
    match &attributes.material.texture {
        Some(texture) => morphlod::gpu::decode_texture(texture)
            .map(drop)
            .map_err(|e| format!("{}: {e}", path.display())),
        None => Ok(()),
    }
}

/// Two meshes as a morph from the first to the second: directly when they share their
/// connectivity, else over their supermesh (with the optional landmark pairs).
pub(crate) fn load_pair(
    a_path: &Path,
    b_path: &Path,
    landmarks: Option<&Path>,
    options: &LoadOptions,
) -> Result<Morph, String> {
    let a = load_attributed(a_path, options).map_err(|e| e.to_string())?;
    let b = load_attributed(b_path, options).map_err(|e| e.to_string())?;
    // The morph takes the first mesh's material.
    check_texture(&a.attributes, a_path)?;
    match morph_from_pair(&a, &b) {
        Ok(morph) => {
            if landmarks.is_some() {
                eprintln!("note: the meshes have the same connectivity: no supermesh is built and --landmarks is not used");
            }
            Ok(morph)
        }
        Err(
            MorphError::PoseSizeMismatch { .. }
            | MorphError::TriangleCountMismatch { .. }
            | MorphError::TriangleMismatch { .. },
        ) => {
            let landmarks = read_landmarks(landmarks)?;
            let (supermesh, report) =
                build_supermesh(&a.positions, &b.positions, &landmarks, true)?;
            println!(
                "{} and {} have different connectivity: built a supermesh ({} vertices, {} triangles, {} crossings)\n{report}",
                a_path.display(),
                b_path.display(),
                report.vertices,
                report.triangles,
                report.crossings
            );
            warn_fold_overs(&report);
            supermesh.to_morph().map_err(|e| e.to_string())
        }
        Err(e) => Err(e.to_string()),
    }
}

/// `--weld` / `--no-weld` as cleaning options (neither: only a triangle soup is welded).
pub(crate) fn clean_options(weld: bool, no_weld: bool) -> CleanOptions {
    CleanOptions {
        weld,
        weld_soup: !no_weld,
    }
}

pub(crate) fn weld_mode(options: &CleanOptions) -> &'static str {
    match (options.weld, options.weld_soup) {
        (true, _) => "weld on",
        (false, true) => "weld off, triangle soups welded",
        (false, false) => "weld off",
    }
}

/// Cleans through [`Morph::clean`] (decisions on V(0), welds only where every
/// pose agrees, one connectivity for all poses) and prints the cleaning summary.
pub(crate) fn clean_morph(morph: Morph, options: &CleanOptions) -> Result<Morph, String> {
    let (morph, report) = morph.clean(options).map_err(|e| e.to_string())?;
    println!("cleaning ({})\n{report}", weld_mode(options));
    Ok(morph)
}
