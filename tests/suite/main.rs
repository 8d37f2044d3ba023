//! The integration suite as one test binary: each file beside this one is a module (an area of
//! the library), so the suite links once instead of once per file, which was most of CI's time
//! (issue 23). Modules that need the renderer or the `morphlod` binary are compiled with the
//! feature that provides them.
//!
//! Four tests stay in binaries of their own (tests/*.rs): they measure the whole process
//! (resident set, a counting global allocator), which other tests running beside them would move.
//! A new area goes here as `mod area;`; a new top-level tests/*.rs file is a binary of its own.

#[path = "../common/mod.rs"]
mod common;

mod asset_file;
mod asset_golden;
mod asset_skin;
mod attribute_quality;
mod bad_input;
mod baselines;
mod clean_attributes;
mod correspondence;
mod deform_quality;
mod oracle;
mod oracle_deform;
mod polygons;
mod seams;
mod shared_frames;
mod shared_sequence;
mod simplify_quality;
mod skin_oracle;
mod skin_quality;
mod soup;
mod supermesh;

#[cfg(feature = "gpu")]
mod crowd;
#[cfg(feature = "gpu")]
mod gpu_buffers;
#[cfg(feature = "gpu")]
mod gpu_render;
#[cfg(feature = "gpu")]
mod image_oracle;
#[cfg(feature = "gpu")]
mod lod_object;
#[cfg(feature = "gpu")]
mod skin_gpu;
#[cfg(feature = "gpu")]
mod textured;

#[cfg(feature = "cli")]
mod cli;
#[cfg(feature = "cli")]
mod cli_supermesh;
#[cfg(feature = "cli")]
mod export;
#[cfg(feature = "cli")]
mod export_compressed;
#[cfg(feature = "cli")]
mod export_skinned;
#[cfg(feature = "cli")]
mod gltf_loader;
#[cfg(feature = "cli")]
mod gltf_validator;
