//! TODO(helper): topology.
