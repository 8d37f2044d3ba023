//! The asset cache: each morph's `.mlod` file under the demo's output folder, built with
//! [`Builder`] when first asked for and missing, stale or damaged.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use morphlod::build::Progress;
use morphlod::simplify::SimplifyOptions;
use morphlod::{Asset, Builder, DeformingModel, Morph};

use super::{DemoError, MorphSpec, NamedMorph};

/// A built morph, ready for the GPU.
pub struct BuiltMorph {
    pub label: String,
    pub asset: Asset,
    pub model: Arc<DeformingModel>,
}

/// A demo's morphs and where their assets are cached; an asset is loaded or built when asked
/// for ([`Library::load`]), not up front.
pub struct Library {
    morphs: Vec<NamedMorph>,
    out: PathBuf,
    frames: u16,
    /// CRC-32 of the source files' content, part of every cache key.
    source_hash: u32,
}

impl Library {
    pub fn new(
        sources: &[&str],
        out: &Path,
        morphs: Vec<NamedMorph>,
        frames: u16,
    ) -> Result<Library, DemoError> {
        // The content, not the path or the modification time: an edited or replaced source
        // file gets new assets, an untouched checkout elsewhere reuses them. (One file hashes
        // as before, so existing caches stay valid.)
        let mut hasher = crc32fast::Hasher::new();
        for source in sources {
            let bytes = std::fs::read(source).map_err(|source_error| DemoError::Io {
                path: Path::new(source).to_path_buf(),
                source: source_error,
            })?;
            hasher.update(&bytes);
        }
        Ok(Library {
            morphs,
            out: out.to_path_buf(),
            frames,
            source_hash: hasher.finalize(),
        })
    }

    pub fn len(&self) -> usize {
        self.morphs.len()
    }

    pub fn label(&self, index: usize) -> &str {
        self.morphs.get(index).map_or("", |m| m.label.as_str())
    }

    /// Morph `index`'s asset and runtime model: cached, or built and cached now.
    pub fn load(&self, index: usize) -> Result<BuiltMorph, DemoError> {
        let named = self.morphs.get(index).ok_or(DemoError::NoSuchMorph {
            index,
            count: self.morphs.len(),
        })?;
        let key = match &named.morph {
            MorphSpec::Ready(_) => "",
            MorphSpec::Deferred { key, .. } => key.as_str(),
        };
        let path = self
            .out
            .join(cache_name(&named.label, self.source_hash, self.frames, key));
        let number = (index + 1, self.morphs.len());
        let mut asset = load_or_build(named, &path, self.frames, number)?;
        let model = Arc::new(DeformingModel::new(&asset).map_err(DemoError::lib)?);
        // The model holds what the runtime needs of the sequences; the demo draws from the
        // poses and targets.
        asset.release_frames();
        Ok(BuiltMorph {
            label: named.label.clone(),
            asset,
            model,
        })
    }
}

/// The cache file of one morph: label, frame count, and a hash of the source file's content
/// together with every build parameter and the file format, so any change to them names
/// another file.
fn cache_name(label: &str, source_hash: u32, frames: u16, key: &str) -> String {
    // Target names come from the file: keep the name to characters every file system takes
    // (the hash below still covers the exact label).
    let safe: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    // A cached asset built by an older simplifier is still a valid LOD model of the same
    // morph (load checks it against the poses), so the key names what the asset must match,
    // not the code that built it: no rebuild, and no pile of files, after every recompile.
    let mut parameters = format!(
        "source {source_hash:08x}; label {label}; frames {frames}; simplify {:?}; \
         morphlod {} (file format {})",
        SimplifyOptions::default(),
        env!("CARGO_PKG_VERSION"),
        morphlod::asset::VERSION,
    );
    if !key.is_empty() {
        parameters += &format!("; {key}");
    }
    format!(
        "{safe}.f{frames}.{source_hash:08x}{:08x}.mlod",
        crc32fast::hash(parameters.as_bytes())
    )
}

fn load_or_build(
    named: &NamedMorph,
    path: &Path,
    frames: u16,
    (number, count): (usize, usize),
) -> Result<Asset, DemoError> {
    if path.exists() {
        // A cached file is used only if it loads (checksums, structure) and holds exactly the
        // poses this morph has; anything else is rebuilt and overwritten.
        match Asset::load(path) {
            Ok(asset) if matches_spec(&asset, &named.morph, frames) => {
                println!(
                    "[{number}/{count}] {}: cached {}",
                    named.label,
                    path.display()
                );
                return Ok(asset);
            }
            Ok(_) => println!(
                "[{number}/{count}] {}: {} holds another morph; rebuilding",
                named.label,
                path.display()
            ),
            Err(error) => println!(
                "[{number}/{count}] {}: cached file does not load ({error}); rebuilding",
                named.label
            ),
        }
    }
    build(named, path, frames, (number, count))
}

fn bar_for(
    frames: u16,
    named: &NamedMorph,
    (number, count): (usize, usize),
) -> Option<ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(u64::from(frames));
        if let Ok(style) =
            ProgressStyle::with_template("{msg} {bar:32} {pos}/{len} frames [{elapsed_precise}]")
        {
            bar.set_style(style);
        }
        bar.set_message(format!("[{number}/{count}] building {}", named.label));
        bar
    })
}

fn build(
    named: &NamedMorph,
    path: &Path,
    frames: u16,
    (number, count): (usize, usize),
) -> Result<Asset, DemoError> {
    let start = Instant::now();
    let made;
    let morph = match &named.morph {
        MorphSpec::Ready(morph) => morph,
        MorphSpec::Deferred { make, .. } => {
            made = make()?;
            &made
        }
    };
    let bar = bar_for(frames, named, (number, count));
    let progress = |p: Progress| {
        if let Some(bar) = &bar {
            bar.set_position(p.frames_done as u64);
        }
    };
    let built = Builder::new(morph)
        .frames(usize::from(frames))
        .progress(&progress)
        .build();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let (asset, report) = built.map_err(DemoError::lib)?;
    asset.save(path).map_err(DemoError::lib)?;
    println!(
        "[{number}/{count}] {}: built {} frames ({} triangles, {} strips) in {:.0} ms on {} threads -> {}",
        named.label,
        frames,
        report.triangles,
        report.strips,
        start.elapsed().as_secs_f64() * 1e3,
        report.threads,
        path.display()
    );
    Ok(asset)
}

/// A cached asset of a deferred morph is trusted on its key (sources and parameters); one of
/// a ready morph must hold exactly its poses.
fn matches_spec(asset: &Asset, spec: &MorphSpec, frames: u16) -> bool {
    match spec {
        MorphSpec::Ready(morph) => matches_morph(asset, morph, frames),
        MorphSpec::Deferred { .. } => asset.frames.len() == usize::from(frames),
    }
}

/// Same poses and frame count, and a surface exactly when the morph has vertex attributes
/// (a file cached before attributes were kept is rebuilt).
fn matches_morph(asset: &Asset, morph: &Morph, frames: u16) -> bool {
    asset.frames.len() == usize::from(frames)
        && asset.v0 == morph.v0()
        && asset.v1 == morph.v1()
        && asset.surface.is_some() == morph.attributes().has_vertex_attributes()
}
