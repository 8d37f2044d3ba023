// morphlod: the shading morph.wgsl (one object) and crowd.wgsl (a crowd) share; each is
// compiled with this file in front (gpu::MORPH_WGSL, gpu::CROWD_WGSL), so an object and a crowd
// instance in the same state shade every fragment with the same arithmetic.
//
// Modes: 0 faceted (the colour, lit with the facet normal from screen-space derivatives, see
// morph.wgsl), 1 one colour per strip (the strip id), 2 smooth (the colour, lit with the
// interpolated vertex normal), 3 textured (base colour * texture * vertex colour, smooth).

const MODE_STRIPS: u32 = 1u;
const MODE_TEXTURED: u32 = 3u;

// `v / |v|`, or 0 for a zero vector (where normalize would give NaN), without a branch.
fn unit_or_zero(v: vec3<f32>) -> vec3<f32> {
    return v * inverseSqrt(max(dot(v, v), 1e-30));
}

// A well-spread, stable colour per strip id (integer hash; u32 arithmetic wraps in WGSL).
fn strip_colour(id: u32) -> vec3<f32> {
    var h = id * 2654435761u;
    h = h ^ (h >> 15u);
    h = h * 2246822519u;
    h = h ^ (h >> 13u);
    let rgb = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    // Keep every channel away from black so shading stays visible.
    return 0.25 + 0.75 * rgb;
}

// The facet normal of the drawn triangle at this fragment, from screen-space derivatives.
fn facet_normal(world: vec3<f32>) -> vec3<f32> {
    // Each derivative is scaled to its largest component first: for a mesh ~1e19 across,
    // dot(c, c) would overflow f32 (n = 0, ambient only), and for one ~1e-22 across it would
    // underflow; scaled, the normal is the same at every size.
    let a = dpdy(world);
    let b = dpdx(world);
    let c = cross(a / max(max(abs(a.x), max(abs(a.y), abs(a.z))), 1e-37),
                  b / max(max(abs(b.x), max(abs(b.y), abs(b.z))), 1e-37));
    // A zero-area fragment footprint gives c = 0: n stays 0 and the fragment gets ambient only,
    // instead of the NaN that normalize(0) would produce.
    return c * inverseSqrt(max(dot(c, c), 1e-30));
}

// Lambert with an ambient floor: the light factor for unit (or zero) normal n.
fn light_factor(n: vec3<f32>, light: vec4<f32>) -> f32 {
    let diffuse = max(dot(n, normalize(light.xyz)), 0.0);
    return light.w + (1.0 - light.w) * diffuse;
}

// The sRGB transfer function (IEC 61966-2-1) of a linear colour in [0, 1].
fn srgb_encode(linear: vec3<f32>) -> vec3<f32> {
    let c = clamp(linear, vec3<f32>(0.0), vec3<f32>(1.0));
    return select(1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055, 12.92 * c, c <= vec3<f32>(0.0031308));
}

// What shades a mesh with a surface: the mode, the object's colour (faceted, smooth), the
// material's base colour factor (textured), the light (xyz towards it, w ambient) and whether
// the textured colour is encoded to sRGB by the shader (1) or by the target format (0).
struct Material {
    mode: u32,
    color: vec4<f32>,
    base_color: vec4<f32>,
    light: vec4<f32>,
    encode_srgb: u32,
}

// A fragment of a mesh without a surface: faceted, in the colour or the strip's colour.
fn shade_plain(world: vec3<f32>, strip: u32, mode: u32, color: vec4<f32>, light: vec4<f32>) -> vec4<f32> {
    let shade = light_factor(facet_normal(world), light);
    var base = color.rgb;
    if mode == MODE_STRIPS {
        base = strip_colour(strip);
    }
    return vec4<f32>(base * shade, color.a);
}

// A fragment of a mesh with a surface; `texel` is the base-colour texture sampled at its UV
// (sampled by the caller, in uniform control flow), `vertex_color` its interpolated colour.
// Every mode's colour is computed and one is selected, with no branch: on lavapipe the crowd's
// fragment stage with an `if` on the mode kept 0.4-0.9 MB of host memory per draw (tests/memory.rs,
// the crowd case: +2.4 GB over 3,000 frames), as a vertex-stage loop did (examples/driver_leak.rs).
// The selected arithmetic is the branch's, so every mode draws the same pixels as before.
fn shade_surface(
    world: vec3<f32>,
    strip: u32,
    normal: vec3<f32>,
    texel: vec4<f32>,
    vertex_color: vec4<f32>,
    m: Material,
) -> vec4<f32> {
    let smooth_normal = m.mode >= 2u;
    let n = select(facet_normal(world), unit_or_zero(normal), smooth_normal);
    let shade = light_factor(n, m.light);
    let albedo = m.base_color * texel * vertex_color;
    let lit = albedo.rgb * shade;
    let textured = vec4<f32>(select(lit, srgb_encode(lit), m.encode_srgb == 1u), albedo.a);
    let base = select(m.color.rgb, strip_colour(strip), m.mode == MODE_STRIPS);
    return select(vec4<f32>(base * shade, m.color.a), textured, m.mode == MODE_TEXTURED);
}
