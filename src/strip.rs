//! TODO(helper): strip.
