//! Whether this process runs under CI: the one rule by which every test that needs what a
//! developer's machine may lack (a GPU adapter, node with the pinned npm packages) decides to
//! fail instead of skipping ([`crate::gpu::test_context`], and tests/common's skip helper).
//!
//! CI services set the environment variable `CI` to `true` (GitHub Actions, GitLab) or `1`
//! (others), and people write `CI=yes`: any value but empty, `0` or `false` (any case) is CI,
//! so a CI run can never pass by skipping because of how its service spells the variable.

/// Whether the environment variable `CI` marks a CI run ([`marks_ci`]).
pub fn is_ci() -> bool {
    marks_ci(
        std::env::var_os("CI")
            .as_deref()
            .map(|v| v.to_string_lossy())
            .as_deref(),
    )
}

/// Whether a value of the `CI` variable (`None`: unset) marks a CI run: anything but unset,
/// empty (or blank), `0` or `false` (any case).
pub fn marks_ci(value: Option<&str>) -> bool {
    match value.map(str::trim) {
        None | Some("" | "0") => false,
        Some(v) => !v.eq_ignore_ascii_case("false"),
    }
}

#[cfg(test)]
mod tests {
    use super::marks_ci;

    /// The values CI services use mark CI; unset, empty, `0` and `false` do not.
    #[test]
    fn ci_values() {
        for (value, ci) in [
            (Some("true"), true),
            (Some("1"), true),
            (Some("yes"), true),
            (Some("TRUE"), true),
            (Some("woodpecker"), true),
            (None, false),
            (Some(""), false),
            (Some(" "), false),
            (Some("0"), false),
            (Some("false"), false),
            (Some("False"), false),
        ] {
            assert_eq!(marks_ci(value), ci, "CI={value:?}");
        }
    }
}
