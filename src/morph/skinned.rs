//! A morph posed by a skin: the skin and clip attached and checked, what cleaning and welding
//! compare of them, and the reduction of influences.

use super::{Morph, MorphError};
use crate::skin::{Reduction, Skinning};

impl Morph {
    /// The same morph posed by `skinning` ([`crate::skin`]): its pose at `t` becomes the
    /// morphed pose skinned at the clip's time `t · duration`. The skin is checked for this
    /// morph's vertex count and the clip on its skeleton.
    pub fn with_skinning(mut self, skinning: Skinning) -> Result<Morph, MorphError> {
        skinning.validate(self.vertex_count())?;
        self.skinning = Some(Box::new(skinning));
        Ok(self)
    }

    /// The skin and clip of a skinned morph.
    pub fn skinning(&self) -> Option<&Skinning> {
        self.skinning.as_deref()
    }

    /// Whether the morph plays as a loop: a skinned morph whose clip ends where it starts
    /// ([`crate::skin::Clip::looping`]). Frames of a loop sample `t_k = k / |r|`.
    pub fn looping(&self) -> bool {
        self.skinning.as_ref().is_some_and(|s| s.clip.looping)
    }

    /// Keeps at most `max` influences a vertex ([`Skinning::reduce_influences`]), the
    /// displacement measured on `V(0)`; `None` for a morph without a skin.
    pub fn reduce_influences(&mut self, max: usize) -> Option<Reduction> {
        let bind = self.v0();
        let skinning = self.skinning.as_mut()?;
        Some(skinning.reduce_influences(max, &bind))
    }

    /// Each vertex's joints and weights as triples of `f32` (a joint's bits as a float's),
    /// for the bit-for-bit comparisons of cleaning; empty without a skin.
    pub(super) fn skin_triples(&self) -> Vec<Vec<[f32; 3]>> {
        let Some(skin) = self.skinning.as_ref().map(|s| &s.skin) else {
            return Vec::new();
        };
        let i = skin.influences;
        let values = |v: usize| {
            skin.joints[v * i..(v + 1) * i]
                .iter()
                .map(|&j| f32::from_bits(j))
                .chain(skin.weights[v * i..(v + 1) * i].iter().copied())
        };
        let per_vertex = 2 * i;
        (0..per_vertex.div_ceil(3))
            .map(|triple| {
                (0..self.vertex_count())
                    .map(|v| {
                        let mut out = [0.0; 3];
                        for (slot, value) in values(v).skip(3 * triple).take(3).enumerate() {
                            out[slot] = value;
                        }
                        out
                    })
                    .collect()
            })
            .collect()
    }
}
