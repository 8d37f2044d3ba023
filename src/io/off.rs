//! TODO(helper): off loader.
