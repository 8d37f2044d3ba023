//! Argument types more than one command takes: the simplifier's weights (`build`, `export`)
//! and the shading (`render --color`, `bench --shade`).

use morphlod::gpu::ShadeMode;
use morphlod::simplify::SimplifyOptions;

/// The simplifier's optional error terms: how much UVs and given normals count (meshes with
/// attributes; others never use them), and the distance term.
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct SimplifyWeights {
    /// Weight of the UV error (0 = geometry only; see `SimplifyOptions::uv_weight`).
    #[arg(long, default_value_t = morphlod::simplify::UV_WEIGHT, value_parser = weight, allow_negative_numbers = true)]
    uv_weight: f32,
    /// Weight of the normal error (0 = geometry only; see `SimplifyOptions::normal_weight`).
    #[arg(long, default_value_t = morphlod::simplify::NORMAL_WEIGHT, value_parser = weight, allow_negative_numbers = true)]
    normal_weight: f32,
    /// Weight of the distance term (0 = off): lower Hausdorff error, most at low triangle
    /// counts, for a build many times longer (see `SimplifyOptions::distance_weight`).
    /// Default: 4 for one shared sequence (export, build --sequence shared), 0 for per-frame
    /// sequences (one simplification per frame).
    #[arg(long, value_parser = weight, allow_negative_numbers = true)]
    distance_weight: Option<f32>,
}

impl SimplifyWeights {
    /// The options for a shared sequence (`shared`) or per-frame ones.
    pub(crate) fn simplify_options(self, shared: bool) -> SimplifyOptions {
        let distance = if shared {
            morphlod::simplify::DISTANCE_WEIGHT
        } else {
            0.0
        };
        SimplifyOptions {
            uv_weight: self.uv_weight,
            normal_weight: self.normal_weight,
            distance_weight: self.distance_weight.unwrap_or(distance),
            ..SimplifyOptions::default()
        }
    }
}

fn weight(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(w) if w.is_finite() && w >= 0.0 => Ok(w),
        _ => Err(format!(
            "'{text}' is not a weight: give a finite number >= 0 (0 turns the term off)"
        )),
    }
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Colour {
    Textured,
    Smooth,
    #[value(alias = "base")]
    Faceted,
    Strips,
}

impl Colour {
    pub(crate) fn shade(self) -> ShadeMode {
        match self {
            Colour::Textured => ShadeMode::Textured,
            Colour::Smooth => ShadeMode::Smooth,
            Colour::Faceted => ShadeMode::Faceted,
            Colour::Strips => ShadeMode::StripColours,
        }
    }
}
