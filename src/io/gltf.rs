//! TODO(helper): gltf loader.
