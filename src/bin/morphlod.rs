//! The `morphlod` command line.
fn main() {}
