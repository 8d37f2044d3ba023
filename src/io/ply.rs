//! TODO(helper): ply loader.
