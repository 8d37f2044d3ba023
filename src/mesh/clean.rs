//! TODO(helper): cleaning.
