//! The one rule for every file the command line writes (`build -o`, `supermesh -o`,
//! `export -o`, `render -o`, `bench --json` and `--plot`, the demo's files in `--output`),
//! checked before any work is done so a refused output leaves nothing written:
//!
//! * an output must not be one of the command's inputs, however it is spelled: both paths are
//!   resolved as the file system sees them (symlinks, `.` and `..`, relative or absolute; an
//!   output that does not exist yet by its folder and file name), and on Unix two names of one
//!   file (a hard link) are the same file too;
//! * an output's extension must name what is written (`.png`, `.glb`, `.mlod`, `.json`), so a
//!   file is never given a name that makes other tools misread it.

use std::path::{Path, PathBuf};
use thiserror::Error;

/// What a command writes to a path: decides the extension the path must have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Written {
    /// A PNG image: `render -o`, `bench --plot`, the demo's contact sheets.
    Png,
    /// Binary glTF: `supermesh -o`, `export -o`.
    Glb,
    /// A morphlod asset: `build -o`, the demo's asset.
    Mlod,
    /// JSON: `bench --json`.
    Json,
}

impl Written {
    /// The extension the output must have, without the dot.
    pub(crate) fn extension(self) -> &'static str {
        match self {
            Written::Png => "png",
            Written::Glb => "glb",
            Written::Mlod => "mlod",
            Written::Json => "json",
        }
    }

    fn what(self) -> &'static str {
        match self {
            Written::Png => "a PNG image",
            Written::Glb => "binary glTF",
            Written::Mlod => "a morphlod asset",
            Written::Json => "JSON",
        }
    }
}

/// Why an output path is refused.
#[derive(Debug, Error)]
pub(crate) enum OutputError {
    #[error("{}: the output is one of the inputs ({}); writing it would destroy that input: choose another output file", output.display(), input.display())]
    IsInput { output: PathBuf, input: PathBuf },
    #[error("{}: the output must be a .{expected} file (this command writes {what} there): give a path ending in .{expected}", output.display())]
    Extension {
        output: PathBuf,
        expected: &'static str,
        what: &'static str,
    },
    #[error("{}: is a file, not a folder: --output names the folder the demo writes its files into", output.display())]
    NotAFolder { output: PathBuf },
}

/// The command line prints errors as text; `?` turns a refusal into its message.
impl From<OutputError> for String {
    fn from(error: OutputError) -> String {
        error.to_string()
    }
}

/// The files a command reads: its input meshes and the landmarks file, if any. No output
/// may be one of them ([`check_output`]).
pub(crate) fn command_inputs<'a>(
    inputs: impl IntoIterator<Item = &'a PathBuf>,
    landmarks: Option<&'a Path>,
) -> Vec<&'a Path> {
    inputs
        .into_iter()
        .map(PathBuf::as_path)
        .chain(landmarks)
        .collect()
}

/// Refuses `output` if it is one of `inputs` (module docs) or its extension is not
/// `written`'s. Call before reading the inputs, so nothing is written on refusal.
pub(crate) fn check_output(
    output: &Path,
    written: Written,
    inputs: &[&Path],
) -> Result<(), OutputError> {
    let resolved = resolve(output);
    if let Some(input) = inputs
        .iter()
        .find(|input| resolve(input) == resolved || same_file(input, output))
    {
        return Err(OutputError::IsInput {
            output: output.to_path_buf(),
            input: input.to_path_buf(),
        });
    }
    let expected = written.extension();
    if !output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(expected))
    {
        return Err(OutputError::Extension {
            output: output.to_path_buf(),
            expected,
            what: written.what(),
        });
    }
    Ok(())
}

/// Refuses a folder argument that names an existing file (the demo writes several files
/// into its `--output`).
pub(crate) fn check_folder(output: &Path) -> Result<(), OutputError> {
    if output.exists() && !output.is_dir() {
        return Err(OutputError::NotAFolder {
            output: output.to_path_buf(),
        });
    }
    Ok(())
}

/// `path` as the file system resolves it: canonical where it exists; for a file not created
/// yet, its folder's canonical path joined with its name; lexically absolute when the
/// folder does not exist either (nothing there can be an input).
fn resolve(path: &Path) -> PathBuf {
    if let Ok(canonical) = path.canonicalize() {
        return canonical;
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (absolute.parent(), absolute.file_name()) {
        (Some(folder), Some(name)) => folder
            .canonicalize()
            .map_or_else(|_| absolute.clone(), |folder| folder.join(name)),
        _ => absolute,
    }
}

/// Whether two existing paths are one file (device and inode: hard links included).
#[cfg(unix)]
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_: &Path, _: &Path) -> bool {
    false
}
