//! Malformed inputs for every loader, one submodule per format.

// A test crate root resolves `mod x;` beside itself (tests/x.rs), so the
// per-format files under tests/bad_input/ need explicit paths.
#[path = "bad_input/gltf.rs"]
mod gltf;
