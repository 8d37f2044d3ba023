//! How even an embedding is ([`EmbeddingQuality`]), for the supermesh's report.

use glam::DVec3;

use super::super::sphere::spherical_area;
use super::d3;

/// How even an embedding is: the smallest spherical triangle area and the
/// spread of each triangle's area distortion, its share of the sphere's
/// area over its share of the surface's (1 everywhere for an
/// area-proportional map).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EmbeddingQuality {
    /// Smallest spherical triangle area (steradians).
    pub min_area: f64,
    /// Mean spherical triangle area, `4π / triangles` (for scale).
    pub mean_area: f64,
    /// 5th, 50th and 95th percentiles of the area distortion.
    pub distortion: [f64; 3],
}

pub(crate) fn quality(
    points: &[DVec3],
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
) -> EmbeddingQuality {
    let surface: Vec<f64> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| d3(positions[v as usize]));
            0.5 * (b - a).cross(c - a).length()
        })
        .collect();
    let total: f64 = surface.iter().sum();
    let four_pi = 4.0 * std::f64::consts::PI;
    let mut min_area = f64::INFINITY;
    let mut ratios: Vec<f64> = triangles
        .iter()
        .zip(&surface)
        .map(|(t, &s)| {
            let [a, b, c] = t.map(|v| points[v as usize]);
            let area = spherical_area(a, b, c);
            min_area = min_area.min(area);
            (area / four_pi) / (s / total).max(f64::MIN_POSITIVE)
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let at = |f: f64| {
        ratios
            .get(((ratios.len() as f64 - 1.0) * f).round() as usize)
            .copied()
            .unwrap_or(0.0)
    };
    EmbeddingQuality {
        min_area,
        mean_area: four_pi / triangles.len().max(1) as f64,
        distortion: [at(0.05), at(0.5), at(0.95)],
    }
}
