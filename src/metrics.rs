//! TODO(helper): metrics.
