//! TODO(helper): gpu.
