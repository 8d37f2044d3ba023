//! TODO(helper): obj loader.
