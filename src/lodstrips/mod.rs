//! TODO(helper): lodstrips.
