//! TODO(helper): simplify.
